// pplvo_launch unit tests (options, URL policy, supervisor with ordinary programs, report) and
// integration tests of the pplvo-launch program. The integration tests run the launch only
// with --isolated (private network namespace; nothing reaches the host network) and are
// skipped with a message when the kernel refuses unprivileged user namespaces.
#include <fcntl.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <net/if.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

#include "pplvo/core/trajectory.h"
#include "pplvo/launch/isolation.h"
#include "pplvo/launch/launch_args.h"
#include "pplvo/launch/launch_report.h"
#include "pplvo/launch/lcm_url.h"
#include "pplvo/launch/process_specs.h"
#include "pplvo/launch/supervisor.h"

namespace fs = std::filesystem;
using namespace pplvo::launch;

namespace {

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path tempDir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("pplvo_test_launch_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string binDir() {
  const char* b = std::getenv("PPLVO_BINARY_DIR");
  return std::string(b ? b : "build") + "/bin";
}

}  // namespace

// ---------------------------------------------------------------- options and URL policy

TEST(LaunchArgs, RequiredOptionsAndErrorsTogether) {
  const ParsedArgs p = parseLaunchArgs({"--rate", "x", "--bogus", "--depth-model", "foo"});
  EXPECT_FALSE(p.help);
  const std::string all = [&] {
    std::string s;
    for (const auto& e : p.errors) s += e + "\n";
    return s;
  }();
  EXPECT_NE(all.find("--dataset is required"), std::string::npos) << all;
  EXPECT_NE(all.find("--output is required"), std::string::npos) << all;
  EXPECT_NE(all.find("--rate: expected a number"), std::string::npos) << all;
  EXPECT_NE(all.find("unknown option --bogus"), std::string::npos) << all;
  EXPECT_NE(all.find("--depth-model"), std::string::npos) << all;
}

TEST(LaunchArgs, LockstepDefaultsToFullSpeedAndValuesParse) {
  ParsedArgs p = parseLaunchArgs({"--dataset", "D", "--output=T", "--lockstep", "--max-frames",
                                  "12", "--fps", "30", "--test-kill", "pplvo-estimator:5"});
  ASSERT_TRUE(p.errors.empty()) << p.errors.front();
  EXPECT_TRUE(p.options.lockstep);
  EXPECT_EQ(p.options.rate, 0.0);
  EXPECT_EQ(p.options.output, "T");
  EXPECT_EQ(p.options.max_frames, 12);
  EXPECT_EQ(p.options.fps, 30.0);
  p = parseLaunchArgs({"--dataset", "D", "--output", "T", "--lockstep", "--rate", "2"});
  EXPECT_EQ(p.options.rate, 2.0);
  p = parseLaunchArgs({"--dataset", "D", "--output", "T"});
  EXPECT_EQ(p.options.rate, 1.0);
  EXPECT_FALSE(p.options.preload.has_value());  // decided by the mode
  p = parseLaunchArgs({"--dataset", "D", "--output", "T", "--no-preload", "--preload=x"});
  EXPECT_EQ(p.errors.size(), 1u);  // a flag takes no value
  p = parseLaunchArgs({"--dataset", "D", "--output", "T", "--preload", "--no-preload"});
  EXPECT_EQ(p.options.preload, std::optional<bool>(false));  // the last one wins
  EXPECT_GT(p.options.timeout_s, 0.0);  // always bounded
  p = parseLaunchArgs({"--dataset", "D", "--output", "T", "--test-kill", "nobody:3"});
  EXPECT_EQ(p.errors.size(), 1u);
  p = parseLaunchArgs(
      {"--dataset", "D", "--output", "T", "--set", "a.b=1", "--set=c=2", "--set", "nokey"});
  EXPECT_EQ(p.errors.size(), 1u);
  EXPECT_EQ(p.options.set, (std::vector<std::string>{"a.b=1", "c=2"}));
}

// Every option of each group (run, pipeline, transport, supervision, test faults) in one
// command line, inline and separate values mixed, and the errors in argument order.
TEST(LaunchArgs, EveryOptionGroupParses) {
  // clang-format off: one option and its value per pair
  const ParsedArgs p = parseLaunchArgs(
      {"--dataset=D", "--output", "T", "--rate", "0.5", "--lockstep-timeout", "3",
       "--lockstep-in-flight", "4", "--max-frames", "7", "--log", "L", "--summary=S", "--quiet",
       "--config", "C", "--features", "points", "--depth-model", "cgm", "--lcm-url", "memq://",
       "--isolated", "--single-url", "--bin-dir", "B", "--node-logs", "N", "--compress",
       "--timeout", "60", "--startup-timeout", "5", "--drain-idle", "0.5", "--stop-grace", "1",
       "--restart", "3", "--restart-backoff", "0.25", "--test-pause", "pplvo-frontend:10:1.5",
       "--camera", "config/cameras/tum_fr1.yaml"});
  // clang-format on
  ASSERT_TRUE(p.errors.empty()) << p.errors.front();
  const LaunchOptions& o = p.options;
  EXPECT_EQ(o.dataset_dir, "D");
  EXPECT_EQ(o.camera_file, "config/cameras/tum_fr1.yaml");
  // ... handed to the player, the only program that reads the folder.
  UrlDecision url;
  url.url = kIsolatedUrl;
  const std::vector<ProcessSpec> specs = buildProcessSpecs(o, url, "/B", "/L");
  for (const ProcessSpec& s : specs) {
    const bool player = s.name == kPlayer;
    EXPECT_EQ(std::find(s.args.begin(), s.args.end(), "config/cameras/tum_fr1.yaml") !=
                  s.args.end(),
              player)
        << s.name;
  }
  EXPECT_EQ(o.rate, 0.5);
  EXPECT_EQ(o.lockstep_timeout_s, 3.0);
  EXPECT_EQ(o.lockstep_in_flight, 4);
  EXPECT_EQ(o.max_frames, 7);
  EXPECT_EQ(o.log, "L");
  EXPECT_EQ(o.summary, "S");
  EXPECT_TRUE(o.quiet);
  EXPECT_EQ(o.config, "C");
  EXPECT_EQ(o.features, "points");
  EXPECT_EQ(o.depth_model, "cgm");
  EXPECT_EQ(o.lcm_url, "memq://");
  EXPECT_TRUE(o.isolated && o.single_url && o.compress);
  EXPECT_EQ(o.bin_dir, "B");
  EXPECT_EQ(o.node_log_dir, "N");
  EXPECT_EQ(o.timeout_s, 60.0);
  EXPECT_EQ(o.startup_timeout_s, 5.0);
  EXPECT_EQ(o.drain_idle_s, 0.5);
  EXPECT_EQ(o.stop_grace_s, 1.0);
  EXPECT_EQ(o.restart_limit, 3);
  EXPECT_EQ(o.restart_backoff_s, 0.25);
  EXPECT_EQ(o.test_pause, "pplvo-frontend:10:1.5");

  const ParsedArgs bad = parseLaunchArgs({"--dataset", "D", "--output", "T", "--restart", "1001",
                                          "--lockstep-in-flight=0", "--stop-grace", "0.01",
                                          "--isolated=yes", "--test-pause", "pplvo-player:1",
                                          "--timeout"});
  EXPECT_EQ(bad.errors, (std::vector<std::string>{
                            "--restart: expected an integer in [0, 1000], not '1001'",
                            "--lockstep-in-flight: expected an integer in [1, 1000], not '0'",
                            "--stop-grace: must be >= 0.1", "--isolated takes no value",
                            "--test-pause: NODE:POSES:SECONDS with NODE one of the programs",
                            "--timeout needs a value"}));
  EXPECT_TRUE(parseLaunchArgs({"--bogus", "-h"}).help);
}

TEST(LaunchArgs, TestFaultPlan) {
  LaunchOptions o;
  TestFaultPlan plan = planTestFaults(o);
  EXPECT_EQ(plan.kill_after_poses, -1);
  EXPECT_EQ(plan.pause_after_poses, -1);
  o.test_kill = "pplvo-estimator:25";
  o.test_pause = "pplvo-depth-filter:40:2.5";
  plan = planTestFaults(o);
  EXPECT_EQ(plan.kill_node, kEstimator);
  EXPECT_EQ(plan.kill_after_poses, 25);
  EXPECT_EQ(plan.pause_node, kDepthFilter);
  EXPECT_EQ(plan.pause_after_poses, 40);
  EXPECT_EQ(plan.pause_s, 2.5);
}

TEST(LaunchArgs, MissingProgramsAreNamed) {
  const fs::path dir = tempDir("programs");
  for (const std::string& name : allPrograms()) {
    if (name == kLogger) continue;  // missing
    const fs::path p = dir / name;
    std::ofstream(p) << "#!/bin/sh\n";
    fs::permissions(p, fs::perms::owner_all);
  }
  std::ofstream(dir / kPlayer) << "";  // not executable any more
  fs::permissions(dir / kPlayer, fs::perms::owner_read | fs::perms::owner_write);
  const std::vector<std::string> missing = missingPrograms(dir.string());
  ASSERT_EQ(missing.size(), 2u);
  EXPECT_EQ(missing[0].rfind((dir / kLogger).string() + ": ", 0), 0u) << missing[0];
  EXPECT_EQ(missing[1].rfind((dir / kPlayer).string() + ": ", 0), 0u) << missing[1];
  fs::remove_all(dir);
}

TEST(LaunchUrl, Parse) {
  LcmUrl u = parseLcmUrl("udpm://239.255.76.67:7667?ttl=1&recv_buf_size=1000");
  ASSERT_TRUE(u.valid) << u.error;
  EXPECT_EQ(u.provider, "udpm");
  EXPECT_EQ(u.address, "239.255.76.67");
  EXPECT_EQ(u.port, 7667);
  EXPECT_EQ(u.ttl, 1);
  u = parseLcmUrl("udpm://");
  ASSERT_TRUE(u.valid);
  EXPECT_EQ(u.ttl, 0);
  EXPECT_FALSE(parseLcmUrl("udpm://192.168.1.2:7667").valid);  // not multicast
  EXPECT_FALSE(parseLcmUrl("udpm://239.255.76.67:99999").valid);
  EXPECT_FALSE(parseLcmUrl("nonsense").valid);
  EXPECT_TRUE(parseLcmUrl("memq://").valid);
}

TEST(LaunchUrl, Policy) {
  LaunchOptions o;
  o.isolated = true;
  UrlDecision d = decideLcmUrl(o, "memq://");  // the host's variable is not used inside
  EXPECT_EQ(d.url, kIsolatedUrl);
  EXPECT_TRUE(d.errors.empty());
  EXPECT_TRUE(d.warnings.empty());
  o.lcm_url = "udpm://239.255.76.67:7667?ttl=1";
  d = decideLcmUrl(o, nullptr);
  ASSERT_EQ(d.errors.size(), 1u);  // --isolated refuses a URL that would leave lo
  EXPECT_NE(d.errors[0].find("loopback"), std::string::npos);
  o.isolated = false;
  d = decideLcmUrl(o, nullptr);
  EXPECT_TRUE(d.errors.empty());
  ASSERT_EQ(d.warnings.size(), 1u);  // ttl > 0 on the host: warned
  EXPECT_NE(d.warnings[0].find("ttl=1"), std::string::npos);
  EXPECT_NE(d.warnings[0].find("frames, depth maps and features stay"), std::string::npos);
  o.single_url = true;
  d = decideLcmUrl(o, nullptr);
  ASSERT_EQ(d.warnings.size(), 1u);
  EXPECT_NE(d.warnings[0].find("every channel leaves this host"), std::string::npos);
  o.single_url = false;
  o.lcm_url.clear();
  d = decideLcmUrl(o, "memq://");
  ASSERT_EQ(d.errors.size(), 1u);  // memq cannot connect processes
  EXPECT_NE(d.errors[0].find("pplvo-run"), std::string::npos);
  d = decideLcmUrl(o, "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_TRUE(d.errors.empty());
  EXPECT_TRUE(d.warnings.empty());
  EXPECT_EQ(d.url, "udpm://239.255.76.67:7667?ttl=0");
  d = decideLcmUrl(o, "file:///tmp/x.lcmlog");
  EXPECT_EQ(d.errors.size(), 1u);
}

TEST(LaunchUrl, ReceiveBufferFromRmemMax) {
  LaunchOptions o;
  o.isolated = true;
  UrlDecision d = decideLcmUrl(o, nullptr, 4194304);
  EXPECT_EQ(d.url, std::string(kIsolatedUrl) + "&recv_buf_size=4194304");
  EXPECT_FALSE(d.compress);
  EXPECT_TRUE(d.warnings.empty());
  d = decideLcmUrl(o, nullptr, int64_t{1} << 30);
  EXPECT_EQ(d.url, std::string(kIsolatedUrl) + "&recv_buf_size=16777216");  // capped
  d = decideLcmUrl(o, nullptr, 212992);  // a stock kernel: even compressed frames are lost
  EXPECT_TRUE(d.compress);
  ASSERT_EQ(d.warnings.size(), 1u);
  EXPECT_NE(d.warnings[0].find("212992"), std::string::npos);
  EXPECT_NE(d.warnings[0].find("sysctl -w net.core.rmem_max"), std::string::npos);
  d = decideLcmUrl(o, nullptr, 1536 * 1024);  // enough for compressed frames only
  EXPECT_TRUE(d.compress);
  ASSERT_EQ(d.warnings.size(), 1u);
  EXPECT_NE(d.warnings[0].find("compressed (lossless"), std::string::npos);
  o.lcm_url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=1000000";
  d = decideLcmUrl(o, nullptr, 4194304);
  EXPECT_EQ(d.url, o.lcm_url);  // the user's choice stays
  o.lcm_url = "udpm://239.255.76.67:7667";
  d = decideLcmUrl(o, nullptr, 4194304);
  EXPECT_EQ(d.url, "udpm://239.255.76.67:7667?recv_buf_size=4194304");
  o.lcm_url.clear();
  o.compress = true;
  const auto specs = buildProcessSpecs(o, d, "/B", "");
  EXPECT_EQ(specs[0].args.back(), "--compress");
  EXPECT_EQ(specs[4].args.back(), "zlib");
  EXPECT_TRUE(specs[4].log_path.empty());
}

TEST(LaunchSpecs, CommandLines) {
  LaunchOptions o;
  o.dataset_dir = "DATA";
  o.output = "traj.txt";
  o.lockstep = true;
  o.rate = 0;
  o.config = "c.yaml";
  o.features = "points,planes";
  o.set = {"frontend.points.max_points=500"};
  o.depth_model = "cgm";
  o.max_frames = 7;
  o.fps = 30;
  o.log = "run.lcmlog";
  o.single_url = true;
  o.preload = true;
  UrlDecision url = decideLcmUrl(o, nullptr);
  const auto specs = buildProcessSpecs(o, url, "/B", "/L");
  ASSERT_EQ(specs.size(), 5u);
  EXPECT_EQ(specs.back().name, kPlayer);  // started last
  auto joined = [](const ProcessSpec& s) {
    std::string j = s.path;
    for (const auto& a : s.args) j += " " + a;
    return j;
  };
  EXPECT_EQ(joined(specs[0]),
            std::string("/B/pplvo-depth-filter --lcm-url ") + kIsolatedUrl +
                " --depth-model cgm --config c.yaml --set frontend.points.max_points=500"
                " --overload-backlog 0");
  EXPECT_EQ(joined(specs[2]), std::string("/B/pplvo-estimator --lcm-url ") + kIsolatedUrl +
                                  " --config c.yaml --features points,planes --set "
                                  "frontend.points.max_points=500");
  EXPECT_NE(joined(specs[3]).find("--trajectory traj.txt"), std::string::npos);
  EXPECT_NE(joined(specs[3]).find("--output run.lcmlog"), std::string::npos);
  const std::string player = joined(specs[4]);
  for (const char* a :
       {"--dataset DATA", "--rate 0", "--lockstep", "--max-frames 7", "--fps 30", "--preload"}) {
    EXPECT_NE(player.find(a), std::string::npos) << a << " in " << player;
  }
  EXPECT_EQ(specs[1].log_path, "/L/pplvo-frontend.log");
  EXPECT_EQ(specs[1].env.at("LCM_DEFAULT_URL"), kIsolatedUrl);
  EXPECT_EQ(joined(specs[3]).find("--channels"), std::string::npos);  // every PPLVO_ channel
  // A compact recording: the player sends what the log keeps, the logger keeps frames and
  // what the run said of them.
  o.compact_log = true;
  const auto compact = buildProcessSpecs(o, url, "/B", "/L");
  EXPECT_NE(joined(compact[4]).find("--rgb-encoding jpeg --depth-encoding zlib"),
            std::string::npos)
      << joined(compact[4]);
  EXPECT_NE(joined(compact[3]).find("--channels PPLVO_(RGBD|POSE|ODOMETRY|STATUS|STREAM)"),
            std::string::npos)
      << joined(compact[3]);
  EXPECT_TRUE(parseLaunchArgs({"--dataset", "D", "--output", "t", "--log-mode", "compact"})
                  .options.compact_log);
  EXPECT_EQ(parseLaunchArgs({"--dataset", "D", "--output", "t", "--log-mode", "tiny"}).errors,
            std::vector<std::string>{"--log-mode: full or compact, not 'tiny'"});
  o.compact_log = false;

  // By default each frame channel gets its own port, handed to every process.
  o.single_url = false;
  o.isolated = true;
  url = decideLcmUrl(o, nullptr, 4194304);
  ASSERT_TRUE(url.errors.empty());
  const std::string options = "?ttl=0&recv_buf_size=4194304";
  ASSERT_EQ(url.routes,
            (std::vector<std::string>{"PPLVO_RGBD=udpm://239.255.76.67:7668" + options,
                                      "PPLVO_DEPTH_CGM=udpm://239.255.76.67:7669" + options,
                                      "PPLVO_DEPTH_FUSED=udpm://239.255.76.67:7670" + options,
                                      "PPLVO_FEATURES=udpm://239.255.76.67:7671" + options,
                                      "PPLVO_FEATURES_3D=udpm://239.255.76.67:7671" + options}));
  // The player preloads when free-running, not in lockstep, unless told.
  o.preload.reset();
  EXPECT_EQ(joined(buildProcessSpecs(o, url, "/B", "/L")[4]).find("--preload"), std::string::npos);
  o.lockstep = false;
  EXPECT_NE(joined(buildProcessSpecs(o, url, "/B", "/L")[4]).find("--preload"), std::string::npos);
  o.preload = false;
  EXPECT_EQ(joined(buildProcessSpecs(o, url, "/B", "/L")[4]).find("--preload"), std::string::npos);
  // Free-running, the depth filter keeps its load shedding (lockstep: off, above).
  EXPECT_EQ(joined(buildProcessSpecs(o, url, "/B", "/L")[0]).find("--overload-backlog"),
            std::string::npos);
  for (const ProcessSpec& s : buildProcessSpecs(o, url, "/B", "/L")) {
    const std::string j = joined(s);
    for (const std::string& r : url.routes) {
      EXPECT_NE(j.find("--route " + r), std::string::npos) << s.name;
    }
  }
}

TEST(LaunchUrl, FrameChannelRoutesNeedFreePorts) {
  std::string error;
  EXPECT_TRUE(frameChannelRoutes("udpm://239.255.76.67:65532", &error).empty());
  EXPECT_NE(error.find("65532"), std::string::npos);
  error.clear();
  EXPECT_EQ(frameChannelRoutes("udpm://239.255.76.67:65531", &error).size(), 5u);
  EXPECT_TRUE(error.empty());
  // Frames stay on the host whatever the main URL's reach; the other options are kept.
  EXPECT_EQ(frameChannelRoutes("udpm://239.255.76.67:7667?ttl=1&recv_buf_size=4194304", &error)
                .front(),
            "PPLVO_RGBD=udpm://239.255.76.67:7668?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(frameChannelRoutes("udpm://239.255.76.67:7667?recv_buf_size=9", &error).back(),
            "PPLVO_FEATURES_3D=udpm://239.255.76.67:7671?recv_buf_size=9");
  error.clear();
  EXPECT_TRUE(frameChannelRoutes("memq://", &error).empty());
  EXPECT_FALSE(error.empty());
  LaunchOptions o;
  o.lcm_url = "udpm://239.255.76.67:65532?ttl=0";
  const UrlDecision d = decideLcmUrl(o, nullptr);
  ASSERT_EQ(d.errors.size(), 1u);
  EXPECT_NE(d.errors[0].find("--single-url"), std::string::npos);
  o.single_url = true;
  EXPECT_TRUE(decideLcmUrl(o, nullptr).errors.empty());
}

/// scripts/isolated.sh writes the same routes into PPLVO_LCM_ROUTES for processes started by
/// hand (README: a live camera): they must stay the layout pplvo-launch hands its processes.
TEST(LaunchUrl, IsolatedScriptRoutesEqualTheLaunchLayout) {
  const char* source = std::getenv("PPLVO_SOURCE_DIR");
  if (source == nullptr) GTEST_SKIP() << "PPLVO_SOURCE_DIR not set (run through ctest)";
  const std::string command = "env -u PPLVO_LCM_ROUTES -u LCM_DEFAULT_URL_ISOLATED " +
                              std::string(source) +
                              "/scripts/isolated.sh sh -c 'printf \"%s\\n%s\\n\" "
                              "\"$LCM_DEFAULT_URL\" \"$PPLVO_LCM_ROUTES\"' 2>/dev/null";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buf[512];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) out += buf;
  const int status = ::pclose(pipe);
  if (status != 0) GTEST_SKIP() << "no private network namespace here (unshare refused)";
  std::istringstream lines(out);
  std::string url, routes;
  ASSERT_TRUE(std::getline(lines, url) && std::getline(lines, routes)) << out;
  std::string error;
  std::string expected;
  for (const std::string& r : frameChannelRoutes(url, &error)) {
    expected += (expected.empty() ? "" : ";") + r;
  }
  ASSERT_TRUE(error.empty()) << error;
  EXPECT_EQ(routes, expected) << "isolated.sh's URL: " << url;
}

// ---------------------------------------------------------------- report pieces

// The counts come from each process's node_status_t (matched by pid), not from the text of its
// log: a process whose last status was not its final one (killed) is marked.
TEST(LaunchReport, CountsNotFinalAreMarked) {
  LaunchReport r;
  LaunchReport::Process p;
  p.name = kFrontend;
  p.has_counts = true;
  p.counts.known = true;
  p.counts.final = true;
  p.counts.frames_in = 30;
  p.exit = ExitInfo{true, 0, false, 0};
  r.processes.push_back(p);
  EXPECT_EQ(r.text().find("counts not final"), std::string::npos) << r.text();
  r.processes[0].counts.final = false;
  r.processes[0].exit = ExitInfo{false, 0, true, 9};
  EXPECT_NE(r.text().find("counts not final"), std::string::npos) << r.text();
}

TEST(LaunchReport, StrayFramesAreAFault) {
  LaunchReport r;
  LaunchReport::Process p;
  p.name = kDepthFilter;
  p.has_counts = true;
  p.counts.known = p.counts.final = true;
  p.exit = ExitInfo{true, 0, false, 0};
  r.processes.push_back(p);
  EXPECT_TRUE(r.faults().empty());
  r.processes[0].counts.stray_frames = 2;
  ASSERT_EQ(r.faults().size(), 1u);
  EXPECT_NE(r.faults()[0].find("pplvo-depth-filter skipped 2 stray frame(s)"), std::string::npos);
  EXPECT_NE(r.text().find("launch.fault: pplvo-depth-filter skipped 2 stray"), std::string::npos);
}

TEST(LaunchReport, BlockedPublishesAreAFault) {
  LaunchReport r;
  LaunchReport::Process p;
  p.name = kPlayer;
  p.has_counts = true;
  p.counts.known = p.counts.final = true;
  p.exit = ExitInfo{true, 0, false, 0};
  r.processes.push_back(p);
  EXPECT_TRUE(r.faults().empty());
  r.processes[0].counts.blocked_publishes = 40;
  r.processes[0].counts.blocked_publish_max_ms = 912.4;
  ASSERT_EQ(r.faults().size(), 1u);
  EXPECT_NE(r.text().find("launch.fault: pplvo-player: 40 publish(es) blocked, up to 912 ms"),
            std::string::npos)
      << r.text();
}

TEST(LaunchReport, ProgressLine) {
  EXPECT_EQ(progressLine(120, 118, 2, 4.04),
            "[pplvo-launch] 120 frames published, 118 posed (98 %), 2 dropped, 4.0 s");
  EXPECT_EQ(progressLine(-1, 0, 0, 0.5), "[pplvo-launch] 0 posed, 0.5 s");
  EXPECT_FALSE(parseLaunchArgs({"--dataset", "D", "--output", "T"}).options.progress.has_value());
  EXPECT_EQ(parseLaunchArgs({"--dataset", "D", "--output", "T", "--progress"}).options.progress,
            true);
  EXPECT_EQ(parseLaunchArgs({"--dataset", "D", "--output", "T", "--no-progress"}).options.progress,
            false);
}

TEST(LaunchReport, OverloadFusions) {
  LaunchReport r;
  EXPECT_EQ(r.text().find("launch.overload_fusions"), std::string::npos);
  r.overload_fusions = 4;
  EXPECT_NE(r.text().find("launch.overload_fusions: 4"), std::string::npos) << r.text();
}

// Frames without a pose make a free-running launch "degraded" (not ok, not failed); a logger
// that wrote fewer poses than the launch saw fails it.
TEST(LaunchReport, DegradedAndLostPoses) {
  LaunchReport r;
  r.frames_published = 90;
  r.poses_seen = 60;
  r.trajectory_poses = 60;
  r.checkLoggerKeptEveryPose();
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.result(), "degraded");
  EXPECT_NE(r.text().find("launch.result: degraded"), std::string::npos) << r.text();
  r.trajectory_poses = r.frames_published = 90;
  EXPECT_EQ(r.result(), "ok");
  r.poses_seen = 92;
  r.checkLoggerKeptEveryPose();
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.failures.back(), "the logger's trajectory has 90 of the 92 poses the launch saw");
  EXPECT_NE(r.text().find("launch.result: FAILED"), std::string::npos);
}

TEST(LaunchReport, DrainRule) {
  DrainMonitor d(1.0);
  EXPECT_FALSE(d.drained(0.0, 3, 10));
  EXPECT_FALSE(d.drained(0.5, 4, 10));
  EXPECT_FALSE(d.drained(1.4, 4, 10));  // 0.9 s since the last new pose
  EXPECT_TRUE(d.drained(1.6, 4, 10));   // idle
  EXPECT_FALSE(d.allPosed());
  DrainMonitor e(100.0);
  EXPECT_FALSE(e.drained(0.0, 9, 10));
  EXPECT_TRUE(e.drained(0.1, 10, 10));  // every frame posed
  EXPECT_TRUE(e.allPosed());
  DrainMonitor f(1.0);
  EXPECT_FALSE(f.drained(0.0, 0, -1));  // unknown count: only idleness ends it
  EXPECT_TRUE(f.drained(1.5, 0, -1));
}

TEST(LaunchReport, TextAndTrajectoryCount) {
  const fs::path dir = tempDir("report");
  {
    std::ofstream t(dir / "traj.txt");
    t << "# pplvo trajectory\n1.0 0 0 0 0 0 0 1\n\n1.1 0 0 0 0 0 0 1\n";
  }
  EXPECT_EQ(countTrajectoryLines((dir / "traj.txt").string()), 2);
  EXPECT_EQ(countTrajectoryLines((dir / "none.txt").string()), -1);
  LaunchReport r;
  LaunchReport::Process p;
  p.name = kFrontend;
  p.has_counts = true;
  p.counts.known = true;
  p.counts.frames_in = 10;
  p.counts.frames_dropped = 2;
  p.exit = ExitInfo{true, 0, false, 0};
  r.processes.push_back(p);
  p.name = kEstimator;
  p.counts.frames_dropped = 1;
  r.processes.push_back(p);
  EXPECT_EQ(r.droppedTotal(), 3);
  EXPECT_TRUE(r.ok());
  EXPECT_NE(r.text().find("launch.dropped_total: 3"), std::string::npos) << r.text();
  r.failures.push_back("pplvo-estimator ended early (killed by signal 9)");
  EXPECT_NE(r.text().find("launch.result: FAILED"), std::string::npos);
  EXPECT_NE(r.text().find("launch.failure: pplvo-estimator"), std::string::npos);
  fs::remove_all(dir);
}

TEST(LaunchReport, CountsThatDoNotAddUpAreAFault) {
  LaunchReport r;
  LaunchReport::Process p;
  p.name = kFrontend;
  p.has_counts = true;
  p.counts.known = true;
  p.counts.frames_in = 10;
  p.counts.frames_out = 6;
  p.counts.frames_dropped = 1;
  p.counts.frames_skipped = 1;
  p.counts.frames_pending = 2;
  p.counts.frames_lost = 5;  // outside the sum: they never reached it
  r.processes.push_back(p);
  EXPECT_TRUE(r.faults().empty());
  const std::string text = r.text();
  EXPECT_NE(text.find("pending"), std::string::npos) << text;
  r.processes[0].counts.frames_dropped = 3;
  ASSERT_EQ(r.faults().size(), 1u);
  EXPECT_NE(r.faults()[0].find("pplvo-frontend's counts do not add up (in 10"), std::string::npos)
      << r.faults()[0];
}

TEST(LaunchReport, PlayerCountsAndLockstepTimeouts) {
  LaunchReport r;
  LaunchReport::Process player;
  player.name = kPlayer;
  player.counts.known = true;
  player.counts.frames_out = 40;
  player.counts.errors = 2;
  r.processes.push_back(player);
  r.takePlayerCounts();
  EXPECT_EQ(r.frames_published, 40);  // no END event: the player's count
  EXPECT_TRUE(r.ok());                // free-running: a timeout is not a lockstep failure
  r.frames_published = 38;            // from the END event: kept
  r.lockstep = true;
  r.takePlayerCounts();
  EXPECT_EQ(r.frames_published, 38);
  ASSERT_EQ(r.failures.size(), 1u);
  EXPECT_EQ(r.failures[0].rfind("2 lockstep timeout(s): poses lost", 0), 0u) << r.failures[0];
}

// ---------------------------------------------------------------- supervisor

TEST(Supervisor, ExitCodesLogsAndEnvironment) {
  const fs::path dir = tempDir("sup");
  Supervisor sup;
  ProcessSpec s;
  s.name = "three";
  s.path = "/bin/sh";
  s.args = {"-c", "echo out $PPLVO_X; echo err >&2; exit 3"};
  s.env["PPLVO_X"] = "forty-two";
  s.log_path = (dir / "three.log").string();
  const size_t i = sup.spawn(s);
  for (int k = 0; k < 500 && sup.child(i).running(); ++k) {
    sup.poll();
    usleep(10000);
  }
  ASSERT_TRUE(sup.child(i).exit.has_value());
  EXPECT_TRUE(sup.child(i).exit->exited);
  EXPECT_EQ(sup.child(i).exit->code, 3);
  EXPECT_FALSE(sup.child(i).exit->clean());
  EXPECT_EQ(sup.child(i).exit->text(), "exit code 3");
  const std::string log = readAll(s.log_path);
  EXPECT_NE(log.find("out forty-two"), std::string::npos) << log;
  EXPECT_NE(log.find("err"), std::string::npos) << log;
  fs::remove_all(dir);
}

TEST(Supervisor, ChildInheritsNoDescriptors) {
  const fs::path dir = tempDir("fds");
  // Not close-on-exec, like LCM's sockets; a high number, apart from the shell's own fds.
  const int opened = ::open("/dev/null", O_RDONLY);
  ASSERT_GE(opened, 3);
  const int leak = ::dup2(opened, 57);
  ::close(opened);
  ASSERT_EQ(leak, 57);
  Supervisor sup;
  ProcessSpec s;
  s.name = "fds";
  s.path = "/bin/sh";
  s.args = {"-c", "for f in /proc/$$/fd/*; do echo \"fd ${f##*/}\"; done"};
  s.log_path = (dir / "fds.log").string();
  const size_t i = sup.spawn(s);
  for (int k = 0; k < 500 && sup.child(i).running(); ++k) {
    sup.poll();
    usleep(10000);
  }
  ::close(leak);
  const std::string log = readAll(s.log_path);
  EXPECT_NE(log.find("fd 2\n"), std::string::npos) << log;
  EXPECT_EQ(log.find("fd " + std::to_string(leak) + "\n"), std::string::npos) << log;
  fs::remove_all(dir);
}

TEST(Supervisor, SpawnErrorsNameTheProgram) {
  Supervisor sup;
  ProcessSpec s;
  s.name = "ghost";
  s.path = "/nonexistent/pplvo-ghost";
  try {
    sup.spawn(s);
    FAIL() << "no SpawnError";
  } catch (const SpawnError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/pplvo-ghost"), std::string::npos);
  }
  // Executable bit set but not a valid program: the exec error comes back through the pipe.
  const fs::path dir = tempDir("badexec");
  const fs::path bad = dir / "bad";
  {
    std::ofstream f(bad);
    f << "\x7f"
         "ELF garbage";
  }
  fs::permissions(bad, fs::perms::owner_all);
  s.path = bad.string();
  EXPECT_THROW(sup.spawn(s), SpawnError);
  EXPECT_TRUE(sup.children().empty());
  fs::remove_all(dir);
}

TEST(Supervisor, StopIsCleanOrEscalates) {
  Supervisor sup;
  ProcessSpec polite;  // exits 0 on SIGINT, like the nodes
  polite.name = "polite";
  polite.path = "/bin/sh";
  polite.args = {"-c", "trap 'exit 0' INT; while :; do sleep 0.05; done"};
  ProcessSpec stubborn;  // ignores SIGINT
  stubborn.name = "stubborn";
  stubborn.path = "/bin/sh";
  stubborn.args = {"-c", "trap '' INT; while :; do sleep 0.05; done"};
  const size_t a = sup.spawn(polite);
  const size_t b = sup.spawn(stubborn);
  EXPECT_EQ(sup.runningIndices().size(), 2u);
  EXPECT_EQ(sup.find("stubborn"), b);
  usleep(200000);  // let the shells install their traps
  const auto t0 = std::chrono::steady_clock::now();
  sup.stop({a, b}, 1.0);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(sup.child(a).exit && sup.child(b).exit);
  EXPECT_TRUE(sup.child(a).exit->clean()) << sup.child(a).exit->text();
  EXPECT_FALSE(sup.child(a).killed);
  EXPECT_TRUE(sup.child(b).killed);
  EXPECT_TRUE(sup.child(b).exit->signaled);
  EXPECT_EQ(sup.child(b).exit->signal, SIGKILL);
  EXPECT_NE(sup.child(b).exit->text().find("SIGKILL"), std::string::npos);
  EXPECT_GE(s, 0.9);
  EXPECT_LT(s, 10.0);
  EXPECT_TRUE(sup.runningIndices().empty());
}

TEST(Supervisor, NoticesACrash) {
  Supervisor sup;
  ProcessSpec s;
  s.name = "crasher";
  s.path = "/bin/sh";
  s.args = {"-c", "kill -SEGV $$"};
  const size_t i = sup.spawn(s);
  std::vector<size_t> reaped;
  for (int k = 0; k < 500 && reaped.empty(); ++k) {
    reaped = sup.poll();
    usleep(10000);
  }
  ASSERT_EQ(reaped.size(), 1u);
  EXPECT_EQ(reaped[0], i);
  EXPECT_TRUE(sup.child(i).exit->signaled);
  EXPECT_EQ(sup.child(i).exit->signal, SIGSEGV);
}

TEST(Supervisor, NoticesAPauseAndItsLength) {
  // The supervisor's clock is the test's: the pause lasts exactly what the test says, however
  // long the machine takes to deliver the stop and the continue.
  Supervisor::Clock::time_point now{};
  Supervisor sup([&] { return now; });
  ProcessSpec s;
  s.name = "sleeper";
  s.path = "/bin/sleep";
  s.args = {"5"};
  const size_t i = sup.spawn(s);
  sup.signal(i, SIGSTOP);
  // Up to 10 s for the kernel to report the stop (a waited event, not a timed bound).
  for (int k = 0; k < 2000 && !sup.child(i).paused_since; ++k) {
    sup.poll();
    usleep(5000);
  }
  ASSERT_TRUE(sup.child(i).paused_since.has_value());
  EXPECT_TRUE(sup.child(i).running());  // stopped is not ended
  now += std::chrono::milliseconds(300);
  sup.poll();  // still stopped: nothing changes
  EXPECT_EQ(sup.child(i).pauses, 1);
  now += std::chrono::milliseconds(200);
  sup.signal(i, SIGCONT);
  for (int k = 0; k < 2000 && sup.child(i).paused_since; ++k) {
    sup.poll();
    usleep(5000);
  }
  EXPECT_FALSE(sup.child(i).paused_since.has_value());
  EXPECT_EQ(sup.child(i).pauses, 1);
  EXPECT_DOUBLE_EQ(sup.child(i).paused_s, 0.5);
  sup.stop({i}, 2.0);
  EXPECT_FALSE(sup.child(i).running());
}

TEST(Supervisor, DestructorLeavesNoChild) {
  pid_t pid = -1;
  {
    Supervisor sup;
    ProcessSpec s;
    s.name = "sleeper";
    s.path = "/bin/sleep";
    s.args = {"60"};
    pid = sup.child(sup.spawn(s)).pid;
    EXPECT_EQ(::kill(pid, 0), 0);
  }
  EXPECT_NE(::kill(pid, 0), 0);  // killed and reaped
}

// ---------------------------------------------------------------- namespace

namespace {

/// Enters the namespace in a forked child: 0 ok (and only lo visible, up), 4 unavailable,
/// 1 error (printed).
int isolationInChild() {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const IsolationResult r = enterIsolatedNetwork();
    if (!r.ok) {
      std::fprintf(stderr, "isolation: %s\n", r.detail.c_str());
      ::_exit(r.unavailable ? 4 : 1);
    }
    struct if_nameindex* ifs = if_nameindex();
    int n = 0;
    bool only_lo = true;
    for (struct if_nameindex* p = ifs; p && p->if_index != 0; ++p, ++n) {
      only_lo = only_lo && std::string(p->if_name) == "lo";
    }
    if_freenameindex(ifs);
    ::_exit(only_lo && n == 1 ? 0 : 1);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1;
}

/// The reason to skip the launch tests, or empty if the namespace works here.
std::string isolationUnavailable() {
  static const int code = isolationInChild();
  if (code == 4) {
    return "unprivileged user namespaces are unavailable on this machine, so pplvo-launch "
           "--isolated cannot run (and the launch tests never use the host network)";
  }
  return {};
}

}  // namespace

TEST(Isolation, PrivateNamespaceHasOnlyLoopback) {
  const int code = isolationInChild();
  if (code == 4) GTEST_SKIP() << isolationUnavailable();
  EXPECT_EQ(code, 0);
}

// ---------------------------------------------------------------- the program

namespace {

struct CommandRun {
  int code = -1;
  std::string out, err;
  double seconds = 0;
};

CommandRun runCommand(const std::string& cmd, const fs::path& dir, const std::string& tag) {
  const std::string out = (dir / (tag + ".out")).string();
  const std::string err = (dir / (tag + ".err")).string();
  const auto t0 = std::chrono::steady_clock::now();
  const int status = std::system((cmd + " >" + out + " 2>" + err).c_str());
  CommandRun r;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = readAll(out);
  r.err = readAll(err);
  return r;
}

int64_t reportValue(const std::string& report, const std::string& key) {
  const size_t at = report.find(key + ": ");
  if (at == std::string::npos) return -999;
  return std::stoll(report.substr(at + key.size() + 2));
}

/// Largest |difference| of translations and of quaternion coefficients between two TUM files
/// with the same stamps (ADD_FAILURE on a count or stamp mismatch).
std::pair<double, double> maxDifference(const fs::path& a_path, const fs::path& b_path,
                                        size_t expected) {
  const pplvo::TrajectoryReadResult a = pplvo::readTumTrajectory(a_path.string());
  const pplvo::TrajectoryReadResult b = pplvo::readTumTrajectory(b_path.string());
  EXPECT_EQ(b.skipped_lines, 0) << b.first_error;  // only pose lines (and the # header)
  EXPECT_EQ(a.poses.size(), expected);
  EXPECT_EQ(b.poses.size(), a.poses.size());
  double max_t = 0, max_q = 0;
  for (size_t k = 0; k < std::min(a.poses.size(), b.poses.size()); ++k) {
    const auto& pa = a.poses[k];
    const auto& pb = b.poses[k];
    EXPECT_EQ(pa.stamp_text, pb.stamp_text);
    max_t =
        std::max(max_t, (pa.T_w_c.translation() - pb.T_w_c.translation()).cwiseAbs().maxCoeff());
    const Eigen::Quaterniond qa(pa.T_w_c.rotation()), qb(pb.T_w_c.rotation());
    max_q = std::max(max_q, (qa.coeffs() - qb.coeffs()).cwiseAbs().maxCoeff());
  }
  return {max_t, max_q};
}

/// The synthetic sequences for all program tests: `seq` 640x480 (160x120 when the kernel's
/// net.core.rmem_max cannot hold 640x480 messages: see docs/launch.md), `small` 160x120.
class LaunchProgram : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(tempDir("program"));
    const int64_t rmem = readRmemMax();
    std::string size;
    if (rmem < kMinRawRecvBufBytes) {
      size = " --width 160 --height 120";
      std::printf(
          "note: net.core.rmem_max = %lld bytes is too small for 640x480 frames over "
          "UDP; the program tests use 160x120 frames (raise it to test full size)\n",
          static_cast<long long>(rmem));
    }
    CommandRun r = runCommand(
        binDir() + "/pplvo-synth --output " + (*dir_ / "seq").string() + " --frames 30" + size,
        *dir_, "synth");
    synth_ok_ = r.code == 0;
    if (!synth_ok_) std::fprintf(stderr, "pplvo-synth failed:\n%s\n", r.err.c_str());
    r = runCommand(binDir() + "/pplvo-synth --output " + (*dir_ / "small").string() +
                       " --frames 20 --width 160 --height 120",
                   *dir_, "synth_small");
    synth_ok_ = synth_ok_ && r.code == 0;
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  void SetUp() override {
    if (const std::string why = isolationUnavailable(); !why.empty()) GTEST_SKIP() << why;
    ASSERT_TRUE(synth_ok_);
  }
  /// The launch command; process logs go to the suite's temp dir (kept out of /tmp on failure).
  static std::string launch(const std::string& tag) {
    return binDir() + "/pplvo-launch --isolated --timeout 80 --node-logs " +
           (*dir_ / ("logs_" + tag)).string() + " ";
  }
  static fs::path seq() { return *dir_ / "seq"; }
  static fs::path* dir_;
  static bool synth_ok_;
};
fs::path* LaunchProgram::dir_ = nullptr;
bool LaunchProgram::synth_ok_ = false;

}  // namespace

TEST_F(LaunchProgram, LockstepEqualsPplvoRun) {
  const fs::path ref = *dir_ / "run_traj.txt";
  const CommandRun run = runCommand(
      binDir() + "/pplvo-run --quiet --dataset " + seq().string() + " --output " + ref.string(),
      *dir_, "run");
  ASSERT_EQ(run.code, 0) << run.err;
  const fs::path traj = *dir_ / "launch_traj.txt";
  const CommandRun l = runCommand(
      launch("lockstep") + "--lockstep --dataset " + seq().string() + " --output " + traj.string(),
      *dir_, "lockstep");
  std::printf("pplvo-launch --isolated --lockstep: %.1f s wall\n%s", l.seconds, l.out.c_str());
  ASSERT_EQ(l.code, 0) << l.out << l.err;
  EXPECT_NE(l.out.find("launch.result: ok"), std::string::npos);
  EXPECT_EQ(l.out.find("do not add up"), std::string::npos) << l.out;
  EXPECT_EQ(reportValue(l.out, "launch.frames_published"), 30);
  EXPECT_EQ(reportValue(l.out, "launch.dropped_total"), 0);
  EXPECT_EQ(reportValue(l.out, "launch.frames_not_received"), 0);
  EXPECT_EQ(reportValue(l.out, "launch.trajectory_poses"), 30);
  EXPECT_EQ(reportValue(l.out, "launch.lockstep_timeouts"), 0);
  // Every process ended with exit code 0 after the launcher's stop.
  for (const char* n : {kDepthFilter, kFrontend, kEstimator, kLogger, kPlayer}) {
    const size_t at = l.out.find(std::string("  ") + n + " ");
    ASSERT_NE(at, std::string::npos) << n;
    const std::string row = l.out.substr(at, l.out.find('\n', at) - at);
    EXPECT_NE(row.find("exit code 0"), std::string::npos) << row;
  }

  const auto [max_t, max_q] = maxDifference(ref, traj, 30);
  std::printf("lockstep vs pplvo-run: max |dt| %.3g m, max |dq| %.3g\n", max_t, max_q);
  EXPECT_LT(max_t, 1e-4);
  EXPECT_LT(max_q, 1e-4);
}

// The local map (its bundle adjustment runs on the pose loop when a keyframe is taken): the
// processes in lockstep give pplvo-run's trajectory, which is not the keyframe default's.
TEST_F(LaunchProgram, LockstepEqualsPplvoRunWithTheLocalMap) {
  const std::string local_map = " --set odometry.reference=local_map";
  const fs::path keyframes = *dir_ / "run_keyframes.txt";
  const fs::path ref = *dir_ / "run_local_map.txt";
  for (const auto& [out, extra] : {std::pair{keyframes, std::string()}, {ref, local_map}}) {
    const CommandRun run = runCommand(binDir() + "/pplvo-run --quiet --dataset " +
                                          seq().string() + extra + " --output " + out.string(),
                                      *dir_, "run_map");
    ASSERT_EQ(run.code, 0) << run.err;
  }
  const auto [kf_t, kf_q] = maxDifference(keyframes, ref, 30);
  EXPECT_GT(kf_t, 1e-6) << "the local map changed nothing: not exercised";
  const fs::path traj = *dir_ / "launch_local_map.txt";
  const CommandRun l = runCommand(launch("local_map") + "--lockstep" + local_map + " --dataset " +
                                      seq().string() + " --output " + traj.string(),
                                  *dir_, "lockstep_map");
  ASSERT_EQ(l.code, 0) << l.out << l.err;
  EXPECT_EQ(reportValue(l.out, "launch.trajectory_poses"), 30);
  const auto [max_t, max_q] = maxDifference(ref, traj, 30);
  std::printf("local map, lockstep vs pplvo-run: max |dt| %.3g m, max |dq| %.3g (keyframe "
              "default vs local map: %.3g m)\n",
              max_t, max_q, kf_t);
  EXPECT_LT(max_t, 1e-4);
  EXPECT_LT(max_q, 1e-4);
}

// The receive buffer of a stock kernel (net.core.rmem_max = 208 KiB, the usual CI value): small
// frames, compressed, still go through in lockstep and give pplvo-run's trajectory.
TEST_F(LaunchProgram, StockKernelReceiveBufferSmallFrames) {
  const fs::path small = *dir_ / "small";
  const fs::path ref = *dir_ / "small_run.txt";
  const CommandRun run = runCommand(
      binDir() + "/pplvo-run --quiet --dataset " + small.string() + " --output " + ref.string(),
      *dir_, "small_run");
  ASSERT_EQ(run.code, 0) << run.err;
  const fs::path traj = *dir_ / "small_launch.txt";
  const CommandRun l =
      runCommand(launch("small") +
                     "--lockstep --compress --single-url "
                     "--lcm-url 'udpm://239.255.76.67:7667?ttl=0&recv_buf_size=212992' "
                     "--dataset " +
                     small.string() + " --output " + traj.string(),
                 *dir_, "small_launch");
  std::printf("pplvo-launch --single-url, 208 KiB receive buffers, 160x120: %.1f s wall\n%s",
              l.seconds, l.out.c_str());
  ASSERT_EQ(l.code, 0) << l.out << l.err;
  EXPECT_EQ(reportValue(l.out, "launch.lockstep_timeouts"), 0);
  EXPECT_EQ(reportValue(l.out, "launch.frames_not_received"), 0);
  const auto [max_t, max_q] = maxDifference(ref, traj, 20);
  EXPECT_LT(max_t, 1e-4);
  EXPECT_LT(max_q, 1e-4);
}

TEST_F(LaunchProgram, FreeRunningAtRealTimeCompletes) {
  const fs::path traj = *dir_ / "free_traj.txt";
  const CommandRun l = runCommand(
      launch("free") + "--rate 1 --dataset " + seq().string() + " --output " + traj.string(), *dir_,
      "free");
  std::printf("pplvo-launch --isolated --rate 1: %.1f s wall\n%s", l.seconds, l.out.c_str());
  ASSERT_EQ(l.code, 0) << l.out << l.err;
  EXPECT_EQ(reportValue(l.out, "launch.frames_published"), 30);
  const int64_t dropped = reportValue(l.out, "launch.dropped_total");
  EXPECT_GE(dropped, 0);  // reported (a speed figure, not asserted)
  EXPECT_EQ(reportValue(l.out, "launch.trajectory_poses"), countTrajectoryLines(traj.string()));
}

TEST_F(LaunchProgram, MissingProgramIsNamed) {
  const fs::path bins = *dir_ / "partial_bin";
  fs::create_directories(bins);
  for (const std::string& n : allPrograms()) {
    if (n != kFrontend) fs::create_symlink(fs::absolute(binDir() + "/" + n), bins / n);
  }
  const CommandRun l = runCommand(launch("missing") + "--bin-dir " + bins.string() + " --dataset " +
                                      seq().string() + " --output " + (*dir_ / "x.txt").string(),
                                  *dir_, "missing");
  EXPECT_EQ(l.code, 1);
  EXPECT_NE(l.err.find("missing node program " + (bins / kFrontend).string()), std::string::npos)
      << l.err;
  EXPECT_FALSE(fs::exists(*dir_ / "x.txt"));  // nothing was started
}

TEST_F(LaunchProgram, KilledNodeIsReportedAndStopsTheLaunch) {
  const CommandRun l =
      runCommand(launch("kill") + "--lockstep --test-kill pplvo-estimator:5 --dataset " +
                     seq().string() + " --output " + (*dir_ / "killed.txt").string(),
                 *dir_, "kill");
  std::printf("killed estimator: exit %d after %.1f s\n%s", l.code, l.seconds, l.out.c_str());
  EXPECT_EQ(l.code, 1);
  EXPECT_LT(l.seconds, 60.0);  // well within --timeout 80: detected, not timed out
  EXPECT_NE(l.out.find("launch.failure: pplvo-estimator ended early (killed by signal 9"),
            std::string::npos)
      << l.out;
  EXPECT_EQ(l.out.find("launch.failure: timeout"), std::string::npos) << l.out;
  EXPECT_NE(l.err.find("FAILED: pplvo-estimator"), std::string::npos) << l.err;
}

TEST_F(LaunchProgram, BadPipelineKeyIsRefusedWithItsOwnError) {
  const CommandRun l = runCommand(launch("badkey") + "--set no.key=1 --dataset " + seq().string() +
                                      " --output " + (*dir_ / "badkey.txt").string(),
                                  *dir_, "badkey");
  EXPECT_EQ(l.code, 2) << l.err;
  EXPECT_NE(l.err.find("no: unknown key"), std::string::npos) << l.err;
  EXPECT_EQ(l.err.find("usage"), std::string::npos) << l.err;  // the error, not a node's help
  EXPECT_FALSE(fs::exists(*dir_ / "logs_badkey"));             // nothing was started
}

TEST_F(LaunchProgram, ReusedNodeLogFolderReportsOnlyThisRun) {
  // An earlier run's log of the frontend ends with its "done:" line; this run's frontend is
  // killed before it writes one: the report must not show the earlier counts.
  const fs::path logs = *dir_ / "logs_reused";
  fs::create_directories(logs);
  std::ofstream(logs / (std::string(kFrontend) + ".log"))
      << "[pplvo-frontend] done: in 195 out 81 dropped 0 skipped 0\n";
  const CommandRun l = runCommand(
      launch("reused") + "--lockstep --max-frames 10 --test-kill pplvo-frontend:3 --dataset " +
          seq().string() + " --output " + (*dir_ / "reused.txt").string(),
      *dir_, "reused");
  EXPECT_EQ(l.code, 1) << l.out << l.err;
  const size_t at = l.out.find(std::string("  ") + kFrontend + " ");
  ASSERT_NE(at, std::string::npos) << l.out;
  const std::string row = l.out.substr(at, l.out.find('\n', at) - at);
  EXPECT_EQ(row.find("195"), std::string::npos) << row;
  EXPECT_NE(row.find("killed by signal 9"), std::string::npos) << row;
}

// A stage stopped for 2 s (SIGSTOP, then SIGCONT) in a free-running launch at the sensor's rate:
// the pipeline resumes within a few frames (the frontend's and the estimator's waits are bounded
// by time as well as count; the estimator restarts at the newest frame when its reference does
// not come), and the report names the fault and the frames it cost. Before, no pose came after
// the pause for the frontend and the estimator (the frontend's full queue of frames waiting for
// fused depth dropped every new frame before extraction, for good).
namespace {

/// 300 frames of 160x120 at 30 Hz (stamps 1.0 + k / 30, 10 s): a free-running launch keeps
/// up, and a stage restarted on a loaded machine is up well before the end.
fs::path sequence300(const fs::path& dir) {
  const fs::path seq = dir / "small300";
  if (!fs::exists(seq)) {
    const CommandRun r = runCommand(binDir() + "/pplvo-synth --output " + seq.string() +
                                        " --frames 300 --width 160 --height 120",
                                    dir, "synth300");
    EXPECT_EQ(r.code, 0) << r.err;
  }
  return seq;
}

/// Poses of a TUM file whose stamp is at least `from_s`.
int posesFrom(const fs::path& traj, double from_s) {
  int n = 0;
  for (const auto& p : pplvo::readTumTrajectory(traj.string()).poses) {
    n += std::stod(p.stamp_text) >= from_s - 1e-6 ? 1 : 0;
  }
  return n;
}

}  // namespace

TEST_F(LaunchProgram, PausedStageCostsOnlyTheFramesItHeld) {
  const fs::path seq300 = sequence300(*dir_);
  constexpr int kFrames = 300, kPauseAfterPoses = 30, kLastFrames = 150;
  for (const char* node : {kDepthFilter, kFrontend, kEstimator}) {
    const fs::path traj = *dir_ / (std::string("paused_") + node + ".txt");
    const CommandRun l =
        runCommand(launch(std::string("pause_") + node) + "--rate 1 --test-pause " + node + ":" +
                       std::to_string(kPauseAfterPoses) + ":2 --dataset " + seq300.string() +
                       " --output " + traj.string(),
                   *dir_, std::string("pause_") + node);
    std::printf("%s stopped for 2 s: exit %d after %.1f s\n%s", node, l.code, l.seconds,
                l.out.c_str());
    EXPECT_EQ(reportValue(l.out, "launch.frames_published"), kFrames) << node;
    // The 2 s pause (60 frames at 30 Hz) starts after ~30 frames: the last 150 frames come well
    // after it. A majority of them must be posed (all were, 3 of 3 stages, on 150 frames here).
    EXPECT_GT(posesFrom(traj, 1.0 + (kFrames - kLastFrames) / 30.0), kLastFrames / 2)
        << node << "\n"
        << l.out;
    EXPECT_GE(posesFrom(traj, 0.0), kPauseAfterPoses) << node;
    // Frames were lost to the fault: said so, and the launch is not ok.
    EXPECT_NE(l.out.find(std::string("launch.fault: ") + node + " paused 1 time(s)"),
              std::string::npos)
        << l.out;
    EXPECT_NE(l.out.find("launch.failure: frames lost to a fault"), std::string::npos) << l.out;
    EXPECT_EQ(l.out.find("do not add up"), std::string::npos) << l.out;  // every frame's end
    EXPECT_EQ(l.code, 1) << node;
  }
}

// --restart: a stage killed (SIGKILL) after 30 poses is started again, the pipeline resumes (the
// estimator restarts tracking when its reference is lost with the dead stage; a restarted
// estimator starts a new world frame), and the report counts the restart and the frames lost.
TEST_F(LaunchProgram, KilledStageIsRestartedAndThePipelineResumes) {
  const fs::path seq300 = sequence300(*dir_);
  constexpr int kFrames = 300, kLastFrames = 150;
  for (const char* node : {kDepthFilter, kFrontend, kEstimator}) {
    const fs::path traj = *dir_ / (std::string("restarted_") + node + ".txt");
    const CommandRun l =
        runCommand(launch(std::string("restart_") + node) + "--rate 1 --restart 2 --test-kill " +
                       node + ":30 --dataset " + seq300.string() + " --output " + traj.string(),
                   *dir_, std::string("restart_") + node);
    std::printf("%s killed, --restart 2: exit %d after %.1f s\n%s", node, l.code, l.seconds,
                l.out.c_str());
    EXPECT_EQ(reportValue(l.out, "launch.frames_published"), kFrames) << node;
    EXPECT_EQ(reportValue(l.out, "launch.restarts"), 1) << node;
    EXPECT_GT(posesFrom(traj, 1.0 + (kFrames - kLastFrames) / 30.0), kLastFrames / 2)
        << node << "\n"
        << l.out;
    EXPECT_NE(l.out.find(std::string("launch.fault: ") + node + " ended early (killed by signal 9"),
              std::string::npos)
        << l.out;
    EXPECT_NE(l.out.find("launch.failure: frames lost to a fault"), std::string::npos) << l.out;
    EXPECT_EQ(l.code, 1) << node;
  }
}
