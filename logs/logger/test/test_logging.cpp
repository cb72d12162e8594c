// Event logs, trajectories and the logger node (in-process on memq://, or file:// logs).
#include <gtest/gtest.h>
#include <lcm/eventlog.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <pplvo_msgs/node_status_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>
#include <random>
#include <sstream>

#include "pplvo/core/trajectory.h"
#include "pplvo/logging/event_log.h"
#include "pplvo/logging/logger_node.h"
#include "pplvo/logging/run_record.h"

namespace fs = std::filesystem;
using namespace pplvo;
using namespace pplvo::logging;

namespace {

std::string tmpPath(const std::string& name) {
  return (fs::temp_directory_path() /
          ("pplvo_test_logging_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

struct Removed {
  std::vector<std::string> paths;
  ~Removed() {
    std::error_code ec;
    for (const auto& p : paths) fs::remove(p, ec);
  }
};

struct Sent {
  std::string channel;
  std::vector<uint8_t> data;
};

std::vector<Sent> makeEvents(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> size(0, 3000), byte(0, 255);
  const char* channels[] = {"PPLVO_RGBD", "PPLVO_POSE", "PPLVO_STATUS", "X"};
  std::vector<Sent> out;
  for (int i = 0; i < n; ++i) {
    Sent s;
    s.channel = channels[i % 4];
    s.data.resize(size(rng));
    for (auto& b : s.data) b = static_cast<uint8_t>(byte(rng));
    out.push_back(std::move(s));
  }
  return out;
}

/// Byte offsets where each event ends.
std::vector<int64_t> writeLog(const std::string& path, const std::vector<Sent>& events) {
  EventLogWriter w(path);
  std::vector<int64_t> ends;
  int64_t t = 1000000;
  for (const auto& e : events) {
    w.write(e.channel, t += 33333, e.data.data(), static_cast<int32_t>(e.data.size()));
    ends.push_back(w.bytesWritten());
    EXPECT_EQ(static_cast<int64_t>(fs::file_size(path)), w.bytesWritten());  // flushed
  }
  w.close();
  return ends;
}

pplvo_msgs::pose_t makePose(int64_t seq, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  pplvo_msgs::pose_t p{};
  p.utime = 1000 + seq;
  p.seq = seq;
  p.stamp = "1341845688." + std::to_string(100000 + seq * 33333);
  p.status = pplvo_msgs::pose_t::STATUS_TRACKING;
  double q[4] = {n(rng), n(rng), n(rng), n(rng)};
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int i = 0; i < 4; ++i) p.orientation[i] = q[i] / norm;
  for (int i = 0; i < 3; ++i) p.position[i] = n(rng) * 3.0;
  p.rel_orientation[0] = 1.0;
  p.n_window = 0;
  return p;
}

pplvo_msgs::rgbd_frame_t makeFrame(int64_t seq) {
  pplvo_msgs::rgbd_frame_t f{};
  f.utime = seq * 33333;
  f.seq = seq;
  f.stamp = std::to_string(seq);
  f.source = "test";
  f.camera.width = 2;
  f.camera.height = 1;
  f.camera.fx = f.camera.fy = 1;
  f.depth_scale = 5000;
  f.rgb.width = 2;
  f.rgb.height = 1;
  f.rgb.encoding = pplvo_msgs::image_t::ENCODING_RAW_BGR8;
  f.rgb.data = {1, 2, 3, 4, 5, 6};
  f.rgb.size = 6;
  f.depth.encoding = pplvo_msgs::image_t::ENCODING_NONE;
  f.depth.size = 0;
  return f;
}

std::string binDir() {
  const char* b = std::getenv("PPLVO_BINARY_DIR");
  return std::string(b ? b : "build") + "/bin";
}

int runCommand(const std::string& cmd) {
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

}  // namespace

TEST(EventLog, RoundTripThroughLcmEventlogAndFileProvider) {
  Removed cleanup;
  const std::string path = tmpPath("roundtrip.lcmlog");
  cleanup.paths.push_back(path);
  const auto sent = makeEvents(24, 11);
  writeLog(path, sent);

  const EventLogReadResult r = readEventLog(path);
  EXPECT_FALSE(r.truncated) << r.detail;
  EXPECT_EQ(r.valid_bytes, r.file_bytes);
  ASSERT_EQ(r.events.size(), sent.size());
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(r.events[i].channel, sent[i].channel);
    EXPECT_EQ(r.events[i].data, sent[i].data);
    EXPECT_EQ(r.events[i].eventnum, static_cast<int64_t>(i));
  }

  // LCM's own reader.
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "r");
  ASSERT_NE(log, nullptr);
  size_t n = 0;
  while (lcm_eventlog_event_t* ev = lcm_eventlog_read_next_event(log)) {
    ASSERT_LT(n, sent.size());
    EXPECT_EQ(std::string(ev->channel, ev->channellen), sent[n].channel);
    const auto* b = static_cast<const uint8_t*>(ev->data);
    EXPECT_EQ(std::vector<uint8_t>(b, b + ev->datalen), sent[n].data);
    lcm_eventlog_free_event(ev);
    ++n;
  }
  lcm_eventlog_destroy(log);
  EXPECT_EQ(n, sent.size());

  // The file:// provider plays it back to a subscriber.
  struct Sub {
    std::vector<Sent> got;
    void on(const lcm::ReceiveBuffer* rb, const std::string& ch) {
      const auto* b = static_cast<const uint8_t*>(rb->data);
      got.push_back({ch, std::vector<uint8_t>(b, b + rb->data_size)});
    }
  } sub;
  {
    lcm::LCM lcm("file://" + path + "?speed=0");
    ASSERT_TRUE(lcm.good());
    lcm.subscribe(".*", &Sub::on, &sub);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (sub.got.size() < sent.size() && std::chrono::steady_clock::now() < deadline) {
      if (lcm.handleTimeout(200) < 0) break;  // end of log
    }
  }
  ASSERT_EQ(sub.got.size(), sent.size());
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(sub.got[i].channel, sent[i].channel);
    EXPECT_EQ(sub.got[i].data, sent[i].data);
  }
}

TEST(EventLog, TruncatedCopyIsReadUpToTheCut) {
  Removed cleanup;
  const std::string path = tmpPath("full.lcmlog");
  const std::string cut = tmpPath("cut.lcmlog");
  cleanup.paths = {path, cut};
  const auto sent = makeEvents(6, 5);
  const auto ends = writeLog(path, sent);
  const int64_t size = static_cast<int64_t>(fs::file_size(path));
  ASSERT_EQ(size, ends.back());
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Every cut point: complete events before the cut come back intact, never a partial one.
  for (int64_t k = 0; k <= size; k += (k < 200 ? 1 : 7)) {
    {
      std::ofstream out(cut, std::ios::binary | std::ios::trunc);
      out.write(bytes.data(), k);
    }
    const EventLogReadResult r = readEventLog(cut);
    size_t complete = 0;
    while (complete < ends.size() && ends[complete] <= k) ++complete;
    const bool at_boundary = k == 0 || (complete > 0 && ends[complete - 1] == k);
    ASSERT_EQ(r.events.size(), complete) << "cut at " << k;
    EXPECT_EQ(r.truncated, !at_boundary) << "cut at " << k;
    EXPECT_EQ(r.valid_bytes, complete ? ends[complete - 1] : 0);
    for (size_t i = 0; i < complete; ++i) EXPECT_EQ(r.events[i].data, sent[i].data);
    if (r.truncated) {
      EXPECT_NE(r.detail.find("byte"), std::string::npos);
    }
  }
  // Mid-event cut of the last event, as the brief's scenario: flag set, 5 events.
  {
    std::ofstream out(cut, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), ends[4] + (ends[5] - ends[4]) / 2);
  }
  const EventLogReadResult r = readEventLog(cut);
  EXPECT_TRUE(r.truncated);
  EXPECT_EQ(r.events.size(), 5u);
  EXPECT_NE(r.detail.find("incomplete event"), std::string::npos) << r.detail;
  // Garbage after the last event, including a fake sync word with absurd lengths.
  {
    std::ofstream out(cut, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), size);
    const unsigned char junk[] = {0xED, 0xA1, 0xDA, 0x01, 0,    0,    0,    0,   0, 0,
                                  0,    9,    0,    0,    0,    0,    0,    0,   0, 1,
                                  0x7f, 0xff, 0xff, 0xff, 0x7f, 0xff, 0xff, 0xff};
    out.write(reinterpret_cast<const char*>(junk), sizeof junk);
  }
  const EventLogReadResult g = readEventLog(cut);
  EXPECT_TRUE(g.truncated);
  EXPECT_EQ(g.events.size(), sent.size());
  EXPECT_THROW(readEventLog(tmpPath("does_not_exist.lcmlog")), LogReadError);
}

TEST(EventLog, FullDiskGivesAClearErrorAndNoCrash) {
  EventLogWriter w("/dev/full");
  const std::vector<uint8_t> data(100, 7);
  try {
    w.write("PPLVO_RGBD", 1, data.data(), 100);
    FAIL() << "write to /dev/full succeeded";
  } catch (const LogWriteError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("/dev/full"), std::string::npos) << m;
    EXPECT_NE(m.find("No space left"), std::string::npos) << m;
  }
  EXPECT_TRUE(w.failed());
  EXPECT_THROW(w.write("PPLVO_RGBD", 2, data.data(), 100), LogWriteError);
  EXPECT_NO_THROW(w.close());
  EXPECT_THROW(TrajectoryWriter("/dev/full"), LogWriteError);
  RunSummary s;
  EXPECT_THROW(s.writeFile("/dev/full"), LogWriteError);
  EXPECT_THROW(EventLogWriter("/nonexistent_dir/x.lcmlog"), LogWriteError);
}

TEST(EventLog, FileSizeLimitLeavesAValidLogOfCompleteEvents) {
  // A real file hitting a size limit (RLIMIT_FSIZE, EFBIG) stands in for a disk filling up:
  // the partial event is cut away and the log reads back complete, without the truncation flag.
  Removed cleanup;
  const std::string path = tmpPath("limited.lcmlog");
  cleanup.paths.push_back(path);
  struct rlimit old {};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit lim = old;
  lim.rlim_cur = 20000;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &lim), 0);
  const auto sent = makeEvents(40, 17);
  std::string error;
  int64_t written = 0;
  {
    EventLogWriter w(path);
    try {
      for (const auto& e : sent) {
        w.write(e.channel, 1, e.data.data(), static_cast<int32_t>(e.data.size()));
      }
    } catch (const LogWriteError& e) {
      error = e.what();
    }
    written = w.eventsWritten();
  }
  setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, old_handler);
  ASSERT_FALSE(error.empty()) << "40 events of up to 3 kB fit in 20 kB?";
  EXPECT_NE(error.find(path), std::string::npos) << error;
  EXPECT_GT(written, 0);
  const EventLogReadResult r = readEventLog(path);
  EXPECT_FALSE(r.truncated) << r.detail;  // cut back to the last complete event
  ASSERT_EQ(static_cast<int64_t>(r.events.size()), written);
  for (size_t i = 0; i < r.events.size(); ++i) EXPECT_EQ(r.events[i].data, sent[i].data);
}

TEST(Trajectory, LinesEqualThePosesSent) {
  Removed cleanup;
  const std::string path = tmpPath("traj.txt");
  cleanup.paths.push_back(path);
  std::mt19937 rng(3);
  std::vector<pplvo_msgs::pose_t> poses;
  {
    TrajectoryWriter w(path);
    for (int i = 0; i < 20; ++i) {
      poses.push_back(makePose(i, rng));
      EXPECT_TRUE(w.write(poses.back().stamp, poses.back().position, poses.back().orientation));
      // Flushed per line: the file already holds header + i + 1 lines.
      std::ifstream in(path);
      EXPECT_EQ(
          std::count(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>(), '\n'),
          i + 2);
    }
    const double nan_pos[3] = {NAN, 0, 0};
    EXPECT_FALSE(w.write("99", nan_pos, poses[0].orientation));
    w.close();
  }
  const TrajectoryReadResult r = readTumTrajectory(path);
  EXPECT_EQ(r.skipped_lines, 0);
  ASSERT_EQ(r.poses.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(r.poses[i].stamp_text, poses[i].stamp);
    const Eigen::Vector3d t = r.poses[i].T_w_c.translation();
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(t[k], poses[i].position[k], 1e-9);
    // Same rotation (q and -q are the same; the file keeps the sign sent).
    const Eigen::Quaterniond q(r.poses[i].T_w_c.linear());
    const Eigen::Quaterniond qs(poses[i].orientation[0], poses[i].orientation[1],
                                poses[i].orientation[2], poses[i].orientation[3]);
    EXPECT_NEAR(std::abs(q.dot(qs)), 1.0, 1e-8);
  }
  // The raw text: qx qy qz qw order, 9 decimals, stamp verbatim.
  std::ifstream in(path);
  std::string header, line;
  std::getline(in, header);
  std::getline(in, line);
  std::istringstream ss(line);
  std::string stamp;
  double v[7];
  ss >> stamp;
  for (double& x : v) ss >> x;
  EXPECT_EQ(stamp, poses[0].stamp);
  EXPECT_NEAR(v[3], poses[0].orientation[1], 1e-9);  // qx
  EXPECT_NEAR(v[6], poses[0].orientation[0], 1e-9);  // qw last
}

TEST(LoggerArgs, ParsesAndCollectsErrors) {
  auto r = parseLoggerArgs({"--output", "a.lcmlog", "--channels=PPLVO_POSE", "--until-end",
                            "--drain", "0.5", "--idle-timeout", "3"});
  EXPECT_TRUE(r.errors.empty());
  EXPECT_EQ(r.options.output, "a.lcmlog");
  EXPECT_EQ(r.options.channels, "PPLVO_POSE");
  EXPECT_TRUE(r.options.until_end);
  EXPECT_DOUBLE_EQ(r.options.drain_s, 0.5);
  EXPECT_DOUBLE_EQ(r.options.idle_timeout_s, 3.0);
  r = parseLoggerArgs({"--summary", "s.yaml", "--channels", "PPLVO_(POSE"});
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NE(r.errors[0].find("invalid regular expression"), std::string::npos);
  r = parseLoggerArgs({"--timeout", "x", "--what"});
  EXPECT_EQ(r.errors.size(), 3u);  // bad number, unknown option, nothing to record
}

TEST(Logger, RecordsLogTrajectoryAndSummaryUntilEnd) {
  Removed cleanup;
  const std::string log_path = tmpPath("run.lcmlog");
  const std::string traj_path = tmpPath("run_traj.txt");
  const std::string sum_path = tmpPath("run_summary.yaml");
  cleanup.paths = {log_path, traj_path, sum_path};
  lcm::LCM lcm("memq://");
  LoggerOptions o;
  o.output = log_path;
  o.trajectory = traj_path;
  o.summary = sum_path;
  o.until_end = true;
  o.drain_s = 0.2;
  o.timeout_s = 30.0;  // safety net
  LoggerNode node(o, lcm);

  // What a pipeline would publish; all queued on memq before the logger runs.
  std::vector<Sent> expected;
  auto publish = [&](const std::string& ch, const auto& msg, bool recorded) {
    lcm.publish(ch, &msg);
    if (recorded) {
      std::vector<uint8_t> buf(msg.getEncodedSize());
      msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
      expected.push_back({ch, buf});
    }
  };
  pplvo_msgs::stream_event_t start{};
  start.event = pplvo_msgs::stream_event_t::EVENT_START;
  publish("PPLVO_STREAM", start, true);
  std::mt19937 rng(9);
  std::vector<pplvo_msgs::pose_t> poses;
  for (int64_t seq = 0; seq < 10; ++seq) {
    if (seq == 5) continue;  // a frame lost upstream: one gap
    publish("PPLVO_RGBD", makeFrame(seq), true);
    poses.push_back(makePose(seq, rng));
    publish("PPLVO_POSE", poses.back(), true);
    publish("OTHER_CHANNEL", makeFrame(seq), false);  // outside the regex
  }
  pplvo_msgs::node_status_t st{};
  st.node = "pplvo-odometry";
  st.frames_in = 9;
  st.frames_out = 9;
  st.frames_skipped = 1;
  st.n_stages = 1;
  st.stages.resize(1);
  st.stages[0].name = "optimise";
  st.stages[0].count = 9;
  st.stages[0].mean_ms = 12.5;
  st.stages[0].max_ms = 20.0;
  publish("PPLVO_STATUS", st, true);
  pplvo_msgs::stream_event_t end{};
  end.event = pplvo_msgs::stream_event_t::EVENT_END;
  end.frames_published = 9;
  publish("PPLVO_STREAM", end, true);

  const LoggerResult r = node.run();
  EXPECT_EQ(r.exit_code, kExitOk) << r.summary.error;
  EXPECT_EQ(r.summary.stop_reason, "end of stream");
  EXPECT_EQ(r.summary.events_logged, static_cast<int64_t>(expected.size()));

  const EventLogReadResult log = readEventLog(log_path);
  EXPECT_FALSE(log.truncated);
  ASSERT_EQ(log.events.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(log.events[i].channel, expected[i].channel);
    EXPECT_EQ(log.events[i].data, expected[i].data);
  }

  const TrajectoryReadResult traj = readTumTrajectory(traj_path);
  ASSERT_EQ(traj.poses.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(traj.poses[i].stamp_text, poses[i].stamp);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(traj.poses[i].T_w_c.translation()[k], poses[i].position[k], 1e-9);
    }
  }

  const YAML::Node s = YAML::LoadFile(sum_path);
  EXPECT_EQ(s["stop_reason"].as<std::string>(), "end of stream");
  EXPECT_EQ(s["channels"]["PPLVO_RGBD"]["messages"].as<int>(), 9);
  EXPECT_EQ(s["channels"]["PPLVO_RGBD"]["first_seq"].as<int>(), 0);
  EXPECT_EQ(s["channels"]["PPLVO_RGBD"]["last_seq"].as<int>(), 9);
  EXPECT_EQ(s["channels"]["PPLVO_RGBD"]["gaps"].as<int>(), 1);
  EXPECT_EQ(s["channels"]["PPLVO_RGBD"]["missing_seq"].as<int>(), 1);
  EXPECT_EQ(s["channels"]["PPLVO_POSE"]["messages"].as<int>(), 9);
  EXPECT_FALSE(s["channels"]["OTHER_CHANNEL"]);
  EXPECT_FALSE(s["channels"]["PPLVO_STATUS"]["first_seq"]);  // no frame seq in status
  EXPECT_EQ(s["nodes"]["pplvo-odometry"]["frames_skipped"].as<int>(), 1);
  EXPECT_DOUBLE_EQ(s["nodes"]["pplvo-odometry"]["stages"]["optimise"]["mean_ms"].as<double>(),
                   12.5);
  EXPECT_TRUE(s["stream"]["end_seen"].as<bool>());
  EXPECT_EQ(s["stream"]["frames_published"].as<int>(), 9);
  EXPECT_EQ(s["trajectory"]["poses"].as<int>(), 9);
}

TEST(Logger, FullDiskStopsWithErrorAndKeepsOtherOutputs) {
  Removed cleanup;
  const std::string sum_path = tmpPath("full_summary.yaml");
  cleanup.paths = {sum_path};
  lcm::LCM lcm("memq://");
  LoggerOptions o;
  o.output = "/dev/full";
  o.summary = sum_path;
  o.timeout_s = 10.0;
  LoggerNode node(o, lcm);
  for (int i = 0; i < 3; ++i)
    lcm.publish("PPLVO_RGBD", &static_cast<const pplvo_msgs::rgbd_frame_t&>(makeFrame(i)));
  const LoggerResult r = node.run();
  EXPECT_EQ(r.exit_code, kExitFailed);
  EXPECT_EQ(r.summary.stop_reason, "write error");
  EXPECT_NE(r.summary.error.find("No space left"), std::string::npos) << r.summary.error;
  EXPECT_NE(r.summaryLine().find("/dev/full"), std::string::npos);
  EXPECT_LT(r.summary.elapsed_s, 5.0);
  const YAML::Node s = YAML::LoadFile(sum_path);
  EXPECT_EQ(s["stop_reason"].as<std::string>(), "write error");
}

TEST(Logger, IdleTimeoutStopsWhenUpstreamDies) {
  lcm::LCM lcm("memq://");
  LoggerOptions o;
  o.summary = tmpPath("idle_summary.yaml");
  Removed cleanup;
  cleanup.paths = {o.summary};
  o.until_end = true;
  o.idle_timeout_s = 0.3;
  LoggerNode node(o, lcm);
  pplvo_msgs::stream_event_t start{};
  start.event = pplvo_msgs::stream_event_t::EVENT_START;
  lcm.publish("PPLVO_STREAM", &start);
  lcm.publish("PPLVO_RGBD", &static_cast<const pplvo_msgs::rgbd_frame_t&>(makeFrame(0)));
  // ... and then the player dies: no END.
  const LoggerResult r = node.run();
  EXPECT_EQ(r.exit_code, kExitNoEnd);
  EXPECT_NE(r.summary.stop_reason.find("idle"), std::string::npos) << r.summary.stop_reason;
  EXPECT_GE(r.summary.elapsed_s, 0.3);
  EXPECT_LT(r.summary.elapsed_s, 5.0);
  EXPECT_TRUE(r.summary.stream_start_seen);
  EXPECT_FALSE(r.summary.stream_end_seen);
}

TEST(Logger, ExistingLogIsNotOverwrittenWithoutForce) {
  Removed cleanup;
  const std::string path = tmpPath("exists.lcmlog");
  cleanup.paths = {path};
  std::ofstream(path) << "keep me";
  lcm::LCM lcm("memq://");
  LoggerOptions o;
  o.output = path;
  EXPECT_THROW(LoggerNode(o, lcm), LogWriteError);
  o.force = true;
  EXPECT_NO_THROW(LoggerNode(o, lcm));
}

TEST(LoggerProcess, ExitCodesAndCtrlC) {
  const std::string exe = binDir() + "/pplvo-logger";
  ASSERT_TRUE(fs::exists(exe)) << exe;
  EXPECT_EQ(runCommand(exe + " --bogus 2>/dev/null"), 2);
  EXPECT_EQ(runCommand(exe + " --help >/dev/null"), 0);
  Removed cleanup;
  const std::string sum = tmpPath("proc_summary.yaml");
  cleanup.paths = {sum};
  // Nothing arrives (memq in its own process): idle timeout while waiting for END -> 3.
  EXPECT_EQ(runCommand(exe + " --lcm-url memq:// --summary " + sum +
                       " --until-end --idle-timeout 0.3 2>/dev/null"),
            3);
  EXPECT_TRUE(fs::exists(sum));
  // SIGINT stops it cleanly (exit 0) and the summary says so.
  fs::remove(sum);
  EXPECT_EQ(runCommand("timeout --preserve-status -s INT 2 " + exe +
                       " --lcm-url memq:// --summary " + sum + " 2>/dev/null"),
            0);
  ASSERT_TRUE(fs::exists(sum));
  EXPECT_EQ(YAML::LoadFile(sum)["stop_reason"].as<std::string>(), "interrupted");
  // A log on a full disk: clear message, exit 1 (needs an event: none arrive on a private
  // memq, so this goes through the summary file instead).
  EXPECT_EQ(runCommand(exe + " --lcm-url memq:// --summary /dev/full --timeout 0.2 2>/dev/null"),
            1);
}

TEST(LcmLogplayer, ReplaysOurLogIntoAFileLog) {
  // lcm-logplayer (LCM 1.3.1) has -l/--lcm-url: replay into a file:// log in write mode and
  // compare what it re-recorded with what we wrote.
  if (runCommand("command -v lcm-logplayer >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "lcm-logplayer not installed";
  }
  Removed cleanup;
  const std::string in = tmpPath("player_in.lcmlog");
  const std::string out = tmpPath("player_out.lcmlog");
  cleanup.paths = {in, out};
  const auto sent = makeEvents(12, 21);
  writeLog(in, sent);
  const int rc = runCommand("timeout 60 lcm-logplayer -s 1000 -l 'file://" + out + "?mode=w' " +
                            in + " >/dev/null 2>&1");
  EXPECT_EQ(rc, 0);
  const EventLogReadResult r = readEventLog(out);
  EXPECT_FALSE(r.truncated) << r.detail;
  ASSERT_EQ(r.events.size(), sent.size());
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(r.events[i].channel, sent[i].channel);
    EXPECT_EQ(r.events[i].data, sent[i].data);
  }
}
