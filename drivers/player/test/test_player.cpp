// Player end to end, in-process on one memq:// instance (no host network).
#include <gtest/gtest.h>
#include <lcm/eventlog.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <pplvo_msgs/node_status_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>

#include "pplvo/msgs/convert.h"
#include "pplvo/player/player_node.h"

namespace fs = std::filesystem;
using namespace pplvo;
using player::PlayerNode;
using player::PlayerOptions;

namespace {

std::string iclDir() {
  const char* env = std::getenv("PPLVO_SHARED_DATA");
  return std::string(env ? env : "../shared/data") + "/icl_living_room_kt0_short";
}

/// Records everything the player publishes on the same LCM instance.
struct Recorder {
  std::vector<pplvo_msgs::rgbd_frame_t> frames;
  std::vector<pplvo_msgs::stream_event_t> events;
  std::vector<pplvo_msgs::node_status_t> statuses;
  bool keep_images = false;
  explicit Recorder(lcm::LCM& lcm) {
    lcm.subscribe("PPLVO_RGBD", &Recorder::onFrame, this);
    lcm.subscribe("PPLVO_STREAM", &Recorder::onEvent, this);
    lcm.subscribe("PPLVO_STATUS", &Recorder::onStatus, this);
  }
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::rgbd_frame_t* m) {
    frames.push_back(*m);
    if (!keep_images && frames.size() > 3) {  // keep memory small: first 3 frames in full
      frames.back().rgb.data.clear();
      frames.back().depth.data.clear();
    }
  }
  void onEvent(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::stream_event_t* m) {
    events.push_back(*m);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::node_status_t* m) {
    statuses.push_back(*m);
  }
};

/// A fake odometry: answers every frame with a pose of the same seq, and records whether the
/// player waited (frame k must arrive only after the pose of k - 1 was sent).
struct Responder {
  lcm::LCM& lcm;
  int64_t last_pose_sent = -1;
  int out_of_step = 0;
  int frames = 0;
  explicit Responder(lcm::LCM& l) : lcm(l) {
    lcm.subscribe("PPLVO_RGBD", &Responder::onFrame, this);
  }
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::rgbd_frame_t* m) {
    ++frames;
    if (m->seq != last_pose_sent + 1) ++out_of_step;
    pplvo_msgs::pose_t p{};
    p.utime = m->utime;
    p.seq = m->seq;
    p.stamp = m->stamp;
    p.orientation[0] = 1.0;
    p.n_window = 0;
    lcm.publish("PPLVO_POSE", &p);
    last_pose_sent = m->seq;
  }
};

PlayerOptions baseOptions() {
  PlayerOptions o;
  o.dataset_dir = iclDir();
  o.rate = 0.0;
  return o;
}

}  // namespace

TEST(PlayerArgs, ParsesAndCollectsErrors) {
  auto r = player::parsePlayerArgs({"--dataset", "/x", "--rate=2", "--lockstep",
                                    "--lockstep-timeout", "0.5", "--rgb-encoding", "jpeg",
                                    "--depth-encoding", "zlib", "--max-frames", "7", "--loop"});
  EXPECT_TRUE(r.errors.empty());
  EXPECT_EQ(r.options.dataset_dir, "/x");
  EXPECT_DOUBLE_EQ(r.options.rate, 2.0);
  EXPECT_TRUE(r.options.lockstep);
  EXPECT_DOUBLE_EQ(r.options.lockstep_timeout_s, 0.5);
  EXPECT_EQ(r.options.rgb_encoding, pplvo_msgs::image_t::ENCODING_JPEG);
  EXPECT_EQ(r.options.depth_encoding, pplvo_msgs::image_t::ENCODING_ZLIB_U16);
  EXPECT_EQ(r.options.max_frames, 7);
  EXPECT_TRUE(r.options.loop);
  r = player::parsePlayerArgs({"--rate", "-1", "--bogus", "--rgb-encoding", "bmp", "--start"});
  EXPECT_EQ(r.errors.size(), 5u);  // rate, bogus, encoding, start needs value, no --dataset
}

TEST(PlayerProgress, LineShowsFramesRateAndEta) {
  // 30 of 90 frames in 2 s: 15 frames/s, 60 frames left = 4 s.
  EXPECT_EQ(player::progressLine("pplvo-player", 30, 90, 2.0, 1),
            "[pplvo-player] 30/90 frames, 15.0 frames/s, ETA 0:04, skipped 1");
  // 100 of 10000 at 1 frame/s: 9900 s = 165 min.
  EXPECT_EQ(player::progressLine("p", 100, 10000, 100.0, 0),
            "[p] 100/10000 frames, 1.0 frames/s, ETA 165:00, skipped 0");
  EXPECT_EQ(player::progressLine("p", 0, 90, 0.0, 0),
            "[p] 0/90 frames, 0.0 frames/s, ETA --:--, skipped 0");
  EXPECT_EQ(player::progressLine("p", 12, 0, 2.0, 0), "[p] 12 frames, 6.0 frames/s, skipped 0");
}

TEST(Player, MissingDatasetIsAClearError) {
  lcm::LCM lcm("memq://");
  PlayerOptions o = baseOptions();
  o.dataset_dir = "/nonexistent/pplvo_player_dataset";
  try {
    PlayerNode node(o, lcm);
    FAIL();
  } catch (const dataset::DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/pplvo_player_dataset"), std::string::npos);
  }
}

TEST(Player, PublishesAllIclFramesAsFastAsPossible) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  Recorder rec(lcm);
  PlayerNode node(baseOptions(), lcm);
  const player::PlayerResult r = node.run();
  EXPECT_FALSE(r.failed) << r.error;
  EXPECT_EQ(r.published, 251);
  EXPECT_EQ(r.skipped, 0);
  ASSERT_EQ(rec.frames.size(), 251u);
  for (size_t i = 0; i < rec.frames.size(); ++i) {
    const auto& f = rec.frames[i];
    EXPECT_EQ(f.seq, static_cast<int64_t>(i));
    EXPECT_EQ(f.stamp, std::to_string(i));  // verbatim ICL frame index
    EXPECT_EQ(f.utime, static_cast<int64_t>(std::llround(i * 1e6 / 30.0)));  // 30 Hz
    EXPECT_EQ(f.depth_utime, f.utime);  // ICL-NUIM renders both at once
  }
  // Frame content: camera with the signed fy, raw depth equal to the PNG.
  const auto& f0 = rec.frames[2];
  EXPECT_DOUBLE_EQ(f0.camera.fy, -480.0);
  EXPECT_EQ(f0.camera.width, 640);
  EXPECT_DOUBLE_EQ(f0.depth_scale, 5000.0);
  const cv::Mat depth = msgs::decodeImage(f0.depth);
  const cv::Mat png = cv::imread(iclDir() + "/depth/2.png", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(depth.type(), CV_16UC1);
  EXPECT_EQ(cv::norm(depth, png, cv::NORM_INF), 0.0);
  const cv::Mat bgr = msgs::decodeImage(f0.rgb);
  EXPECT_EQ(cv::norm(bgr, cv::imread(iclDir() + "/rgb/2.png"), cv::NORM_INF), 0.0);
  // START then END with counts; at least the final status.
  ASSERT_EQ(rec.events.size(), 2u);
  EXPECT_EQ(rec.events[0].event, pplvo_msgs::stream_event_t::EVENT_START);
  EXPECT_EQ(rec.events[1].event, pplvo_msgs::stream_event_t::EVENT_END);
  EXPECT_EQ(rec.events[1].frames_published, 251);
  ASSERT_FALSE(rec.statuses.empty());
  EXPECT_EQ(rec.statuses.back().node, "pplvo-player");
  EXPECT_EQ(rec.statuses.back().frames_out, 251);
  EXPECT_EQ(rec.statuses.back().last_seq, 250);
  EXPECT_GT(rec.statuses.back().n_stages, 0);
  std::printf("251 ICL frames published in %.2f s (%.1f frames/s, raw encodings)\n", r.elapsed_s,
              r.published / r.elapsed_s);
}

TEST(Player, LosslessEncodingsRoundTripAndStartMaxFrames) {
  lcm::LCM lcm("memq://");
  Recorder rec(lcm);
  rec.keep_images = true;
  PlayerOptions o = baseOptions();
  o.start = 100;
  o.max_frames = 3;
  o.rgb_encoding = pplvo_msgs::image_t::ENCODING_PNG;
  o.depth_encoding = pplvo_msgs::image_t::ENCODING_ZLIB_U16;
  PlayerNode node(o, lcm);
  const auto r = node.run();
  ASSERT_EQ(r.published, 3);
  ASSERT_EQ(rec.frames.size(), 3u);
  EXPECT_EQ(rec.frames[0].seq, 0);        // seq counts published frames from 0
  EXPECT_EQ(rec.frames[0].stamp, "100");  // stamp of dataset frame 100
  const cv::Mat depth = msgs::decodeImage(rec.frames[1].depth);
  EXPECT_EQ(
      cv::norm(depth, cv::imread(iclDir() + "/depth/101.png", cv::IMREAD_UNCHANGED), cv::NORM_INF),
      0.0);
  const cv::Mat bgr = msgs::decodeImage(rec.frames[1].rgb);
  EXPECT_EQ(cv::norm(bgr, cv::imread(iclDir() + "/rgb/101.png"), cv::NORM_INF), 0.0);
}

TEST(Player, LockstepWaitsForEachPose) {
  lcm::LCM lcm("memq://");
  Recorder rec(lcm);
  Responder responder(lcm);
  PlayerOptions o = baseOptions();
  o.lockstep = true;
  o.lockstep_timeout_s = 5.0;
  o.max_frames = 30;
  PlayerNode node(o, lcm);
  const auto r = node.run();
  EXPECT_FALSE(r.failed) << r.error;
  EXPECT_EQ(r.published, 30);
  EXPECT_EQ(r.lockstep_timeouts, 0);
  EXPECT_EQ(responder.frames, 30);
  EXPECT_EQ(responder.out_of_step, 0);
  EXPECT_LT(r.elapsed_s, 10.0);  // far from 30 timeouts of 5 s
}

TEST(Player, LockstepTimeoutWarnsCountsAndContinues) {
  lcm::LCM lcm("memq://");
  Recorder rec(lcm);
  PlayerOptions o = baseOptions();
  o.lockstep = true;
  o.lockstep_timeout_s = 0.1;
  o.lockstep_in_flight = 1;  // every frame waits for its own pose
  o.max_frames = 3;
  PlayerNode node(o, lcm);
  const auto r = node.run();
  EXPECT_FALSE(r.failed);
  EXPECT_EQ(r.published, 3);
  EXPECT_EQ(r.lockstep_timeouts, 3);
  EXPECT_GE(r.elapsed_s, 0.3);
  EXPECT_NE(node.counters().last_warning.find("lockstep"), std::string::npos);
  ASSERT_FALSE(rec.statuses.empty());
  EXPECT_EQ(rec.statuses.back().errors, 3);
}

/// Answers each frame with the pose of the frame `lag` before it (the newest `lag` frames are
/// still "being processed"); records how many frames were out without their pose.
struct LaggingResponder {
  lcm::LCM& lcm;
  int lag;
  int64_t last_pose_sent = -1;
  int64_t max_without_pose = 0;
  explicit LaggingResponder(lcm::LCM& l, int lag_frames) : lcm(l), lag(lag_frames) {
    lcm.subscribe("PPLVO_RGBD", &LaggingResponder::onFrame, this);
  }
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::rgbd_frame_t* m) {
    max_without_pose = std::max(max_without_pose, m->seq - last_pose_sent);
    const int64_t seq = m->seq - lag;
    if (seq < 0) return;
    pplvo_msgs::pose_t p{};
    p.seq = seq;
    p.orientation[0] = 1.0;
    lcm.publish("PPLVO_POSE", &p);
    last_pose_sent = seq;
  }
};

TEST(Player, LockstepKeepsInFlightFramesWithoutTheirPose) {
  for (const int in_flight : {2, 3}) {
    lcm::LCM lcm("memq://");
    LaggingResponder responder(lcm, in_flight - 1);
    PlayerOptions o = baseOptions();
    o.lockstep = true;
    o.lockstep_in_flight = in_flight;
    o.lockstep_timeout_s = 0.2;
    o.max_frames = 12;
    PlayerNode node(o, lcm);
    const auto r = node.run();
    EXPECT_FALSE(r.failed) << r.error;
    EXPECT_EQ(r.published, 12);
    // Never more than in_flight frames out without a pose, and the lag never stalls the
    // player: the only wait that times out is the final one for the last frame's pose.
    EXPECT_EQ(responder.max_without_pose, in_flight);
    EXPECT_EQ(r.lockstep_timeouts, 1) << "in flight " << in_flight;
  }
}

TEST(Player, InProcessLockstepDoesNotWaitOnAnIdleQueue) {
  // With every node in this thread an empty memq queue means no pose can come: go on at once.
  lcm::LCM lcm("memq://");
  PlayerOptions o = baseOptions();
  o.lockstep = true;
  o.in_process = true;
  o.lockstep_timeout_s = 5.0;
  o.max_frames = 4;
  PlayerNode node(o, lcm);
  const auto r = node.run();
  EXPECT_FALSE(r.failed) << r.error;
  EXPECT_EQ(r.published, 4);
  EXPECT_EQ(r.lockstep_timeouts, 0);
  EXPECT_LT(r.elapsed_s, 4.0);  // far from one 5 s timeout per frame
}

TEST(Player, RealTimePacingFollowsStampsAndFps) {
  {
    lcm::LCM lcm("memq://");
    PlayerOptions o = baseOptions();
    o.rate = 1.0;
    o.max_frames = 10;  // 9 intervals of 1/30 s
    PlayerNode node(o, lcm);
    const auto r = node.run();
    EXPECT_EQ(r.published, 10);
    EXPECT_GE(r.elapsed_s, 9.0 / 30.0 - 0.01);
  }
  {
    lcm::LCM lcm("memq://");
    PlayerOptions o = baseOptions();
    o.rate = 2.0;
    o.fps = 20.0;  // 40 frames/s
    o.max_frames = 9;
    PlayerNode node(o, lcm);
    const auto r = node.run();
    EXPECT_EQ(r.published, 9);
    EXPECT_GE(r.elapsed_s, 8.0 / 40.0 - 0.01);
  }
}

TEST(Player, LoopKeepsSeqAndUtimeIncreasing) {
  // Streaming, all 3 frames of a pass preloaded, and 2 of 3 preloaded (bound of 2 MiB).
  for (const int64_t preload_mb : {int64_t{0}, int64_t{2048}, int64_t{2}}) {
    SCOPED_TRACE("--preload-max-mb " + std::to_string(preload_mb));
    lcm::LCM lcm("memq://");
    Recorder rec(lcm);
    rec.keep_images = true;
    PlayerOptions o = baseOptions();
    o.start = 248;  // 3 frames per pass
    o.loop = true;
    o.max_frames = 7;
    o.preload = preload_mb > 0;
    if (o.preload) o.preload_max_mb = preload_mb;
    PlayerNode node(o, lcm);
    const auto r = node.run();
    ASSERT_EQ(rec.frames.size(), 7u);
    EXPECT_EQ(r.loops, 2);
    for (size_t i = 1; i < rec.frames.size(); ++i) {
      EXPECT_EQ(rec.frames[i].seq, rec.frames[i - 1].seq + 1);
      EXPECT_GT(rec.frames[i].utime, rec.frames[i - 1].utime);
    }
    for (size_t i = 0; i < rec.frames.size(); ++i) {
      EXPECT_EQ(rec.frames[i].stamp, std::to_string(248 + i % 3)) << i;
    }
    // Each pass publishes the same pixels (preloaded frames are served again, unchanged).
    EXPECT_EQ(rec.frames[3].rgb.data, rec.frames[0].rgb.data);
    EXPECT_EQ(rec.frames[4].depth.data, rec.frames[1].depth.data);
    const cv::Mat depth = msgs::decodeImage(rec.frames[5].depth);
    EXPECT_EQ(cv::norm(depth, cv::imread(iclDir() + "/depth/250.png", cv::IMREAD_UNCHANGED),
                       cv::NORM_INF),
              0.0);
  }
}

// TUM fr1's Kinect captures depth and colour independently: each frame carries its depth
// image's own instant (depth.txt), which the depth filter moves to the colour instant.
TEST(Player, FramesCarryTheDepthImagesOwnInstant) {
  const std::string dir = std::filesystem::path(iclDir()).parent_path() / "tum_fr1_xyz_short";
  lcm::LCM lcm("memq://");
  Recorder rec(lcm);
  PlayerOptions o = baseOptions();
  o.dataset_dir = dir;
  o.max_frames = 5;
  PlayerNode node(o, lcm);
  ASSERT_FALSE(node.run().failed);
  ASSERT_EQ(rec.frames.size(), 5u);
  int differing = 0;
  for (const auto& f : rec.frames) {
    EXPECT_NE(f.depth_utime, 0);
    EXPECT_LE(std::abs(f.depth_utime - f.utime), 20000) << f.stamp;  // TUM's 20 ms window
    if (f.depth_utime != f.utime) ++differing;
  }
  EXPECT_EQ(differing, 5);
  // fr1's first frame: colour 1305031102.175304, depth 1305031102.160407 (depth.txt).
  EXPECT_EQ(rec.frames[0].utime, 1305031102175304);
  EXPECT_EQ(rec.frames[0].depth_utime, 1305031102160407);
}

TEST(Player, PreloadBeyondItsBoundDecodesTheRestWhilePlaying) {
  lcm::LCM lcm("memq://");
  Recorder rec(lcm);
  rec.keep_images = true;
  PlayerOptions o = baseOptions();
  o.preload = true;
  o.preload_max_mb = 2;  // a 640x480 frame decodes to 1.5 MiB: 2 frames held, then streaming
  o.max_frames = 6;
  PlayerNode node(o, lcm);
  const auto r = node.run();
  EXPECT_FALSE(r.failed) << r.error;
  ASSERT_EQ(rec.frames.size(), 6u);
  for (size_t i = 0; i < rec.frames.size(); ++i) {
    EXPECT_EQ(rec.frames[i].seq, static_cast<int64_t>(i));
    EXPECT_EQ(rec.frames[i].stamp, std::to_string(i));
  }
  for (const int i : {1, 4}) {  // one preloaded, one decoded while playing
    const cv::Mat png =
        cv::imread(iclDir() + "/depth/" + std::to_string(i) + ".png", cv::IMREAD_UNCHANGED);
    EXPECT_EQ(
        cv::norm(msgs::decodeImage(rec.frames[static_cast<size_t>(i)].depth), png, cv::NORM_INF),
        0.0);
  }
  const auto parsed =
      player::parsePlayerArgs({"--dataset", "D", "--preload", "--preload-max-mb", "100"});
  EXPECT_TRUE(parsed.errors.empty());
  EXPECT_TRUE(parsed.options.preload);
  EXPECT_EQ(parsed.options.preload_max_mb, 100);
}

TEST(Player, CorruptFrameIsFatalUnlessSkipBad) {
  const fs::path dir =
      fs::temp_directory_path() / ("pplvo_test_player_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "rgb");
  fs::create_directories(dir / "depth");
  std::ofstream assoc(dir / "associations.txt");
  for (int i = 0; i < 5; ++i) {
    const std::string n = std::to_string(i) + ".png";
    fs::copy_file(iclDir() + "/rgb/" + n, dir / "rgb" / n);
    fs::copy_file(iclDir() + "/depth/" + n, dir / "depth" / n);
    assoc << i << " depth/" << n << " " << i << " rgb/" << n << "\n";
  }
  assoc.close();
  fs::copy_file(iclDir() + "/calib_params.xml", dir / "calib_params.xml");
  std::ofstream(dir / "rgb" / "3.png") << "garbage, not a PNG";
  for (const bool preload : {false, true}) {
    // With --preload the error surfaces at the same point of the stream.
    SCOPED_TRACE(preload ? "--preload" : "streaming");
    lcm::LCM lcm("memq://");
    Recorder rec(lcm);
    PlayerOptions o = baseOptions();
    o.dataset_dir = dir.string();
    o.preload = preload;
    PlayerNode node(o, lcm);
    const auto r = node.run();
    EXPECT_TRUE(r.failed);
    EXPECT_EQ(r.exitCode(), 1);
    EXPECT_NE(r.error.find("rgb/3.png"), std::string::npos) << r.error;
    EXPECT_EQ(r.published, 3);
    ASSERT_FALSE(rec.events.empty());
    EXPECT_EQ(rec.events.back().event, pplvo_msgs::stream_event_t::EVENT_ERROR);
  }
  {
    lcm::LCM lcm("memq://");
    Recorder rec(lcm);
    PlayerOptions o = baseOptions();
    o.dataset_dir = dir.string();
    o.skip_bad = true;
    PlayerNode node(o, lcm);
    const auto r = node.run();
    EXPECT_FALSE(r.failed);
    EXPECT_EQ(r.published, 4);
    EXPECT_EQ(r.skipped, 1);
    ASSERT_EQ(rec.frames.size(), 4u);
    EXPECT_EQ(rec.frames[3].seq, 3);      // seq stays consecutive
    EXPECT_EQ(rec.frames[3].stamp, "4");  // the stamp of the frame after the bad one
    EXPECT_EQ(rec.events.back().event, pplvo_msgs::stream_event_t::EVENT_END);
    EXPECT_EQ(rec.events.back().frames_skipped, 1);
  }
  fs::remove_all(dir);
}

TEST(Player, WritesAFileLogThroughTheFileProvider) {
  const std::string path =
      (fs::temp_directory_path() / ("pplvo_test_player_" + std::to_string(getpid()) + ".lcmlog"))
          .string();
  {
    lcm::LCM lcm("file://" + path + "?mode=w");
    ASSERT_TRUE(lcm.good());
    PlayerOptions o = baseOptions();
    o.max_frames = 5;
    PlayerNode node(o, lcm);
    const auto r = node.run();
    EXPECT_FALSE(r.failed) << r.error;
  }
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "r");
  ASSERT_NE(log, nullptr);
  std::map<std::string, int> per_channel;
  int64_t expected_seq = 0;
  while (lcm_eventlog_event_t* ev = lcm_eventlog_read_next_event(log)) {
    per_channel[ev->channel]++;
    if (std::string(ev->channel) == "PPLVO_RGBD") {
      pplvo_msgs::rgbd_frame_t m;
      ASSERT_GT(m.decode(ev->data, 0, ev->datalen), 0);
      EXPECT_EQ(m.seq, expected_seq++);
    }
    lcm_eventlog_free_event(ev);
  }
  lcm_eventlog_destroy(log);
  EXPECT_EQ(per_channel["PPLVO_RGBD"], 5);
  EXPECT_EQ(per_channel["PPLVO_STREAM"], 2);
  EXPECT_GE(per_channel["PPLVO_STATUS"], 1);
  fs::remove(path);
}

TEST(PlayerProcess, ExitCodesAndCtrlC) {
  const char* b = std::getenv("PPLVO_BINARY_DIR");
  const std::string exe = std::string(b ? b : "build") + "/bin/pplvo-player";
  ASSERT_TRUE(fs::exists(exe)) << exe;
  auto run = [](const std::string& cmd) {
    const int rc = std::system(cmd.c_str());
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  };
  EXPECT_EQ(run(exe + " --rate x 2>/dev/null"), 2);
  EXPECT_EQ(run(exe + " --lcm-url memq:// --dataset /nonexistent 2>/dev/null"), 1);
  // Unreadable calibration: a camera file that does not parse.
  EXPECT_EQ(run(exe + " --lcm-url memq:// --dataset " + iclDir() +
                " --camera /nonexistent/cam.yaml 2>/dev/null"),
            1);
  // Real-time playback of 251 frames takes 8 s; SIGINT after 3 s stops it cleanly (handlers are
  // installed first thing in main).
  EXPECT_EQ(run("timeout --preserve-status -s INT 3 " + exe + " --lcm-url memq:// --dataset " +
                iclDir() + " 2>/dev/null"),
            0);
}
