// pplvo-launch: the pipeline as separate processes on one LCM URL (see docs/launch.md).
// Process handling is in pplvo_launch (no LCM); this file adds the LCM side: it listens to
// PPLVO_STATUS (node counters, readiness), PPLVO_STREAM (the player's END) and PPLVO_POSE
// (poses seen, for the drain rule and --test-kill).
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <optional>
#include <pplvo_msgs/node_status_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "pplvo/launch/launch.h"
#include "pplvo/launch/supervisor.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/pipeline/pipeline_args.h"

namespace {

using namespace pplvo::launch;
using Clock = std::chrono::steady_clock;

volatile sig_atomic_t g_interrupted = 0;
void onSignal(int) { g_interrupted = 1; }

/// What the launcher hears on the bus. Handlers only copy numbers (no throw possible).
class BusMonitor {
 public:
  explicit BusMonitor(lcm::LCM& lcm) : lcm_(lcm) {
    lcm_.subscribe(pplvo::channels::kStatus, &BusMonitor::onStatus, this);
    lcm_.subscribe(pplvo::channels::kStream, &BusMonitor::onStream, this);
    lcm_.subscribe(pplvo::channels::kPose, &BusMonitor::onPose, this);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::node_status_t* m) {
    NodeCounts& c = status_[m->node];
    c.frames_in = m->frames_in;
    c.frames_out = m->frames_out;
    c.frames_dropped = m->frames_dropped;
    c.frames_skipped = m->frames_skipped;
    c.errors = m->errors;
    c.known = true;
    c.source = "status";
    ++reports_[m->node];
  }
  void onStream(const lcm::ReceiveBuffer*, const std::string&,
                const pplvo_msgs::stream_event_t* m) {
    if (m->event == pplvo_msgs::stream_event_t::EVENT_START) start_seen_ = true;
    if (m->event == pplvo_msgs::stream_event_t::EVENT_END ||
        m->event == pplvo_msgs::stream_event_t::EVENT_ERROR) {
      end_seen_ = true;
      end_published_ = m->frames_published;
    }
  }
  void onPose(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::pose_t*) {
    ++poses_;
  }
  /// Handles what arrived within `ms` milliseconds.
  void handle(int ms) {
    const auto until = Clock::now() + std::chrono::milliseconds(ms);
    while (true) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now());
      if (left.count() <= 0) break;
      if (lcm_.handleTimeout(static_cast<int>(left.count())) <= 0) break;
    }
  }
  bool hasStatus(const std::string& node) const { return reports_.count(node) > 0; }
  std::optional<NodeCounts> status(const std::string& node) const {
    auto it = status_.find(node);
    if (it == status_.end()) return std::nullopt;
    return it->second;
  }
  int64_t poses() const { return poses_; }
  bool endSeen() const { return end_seen_; }
  int64_t endPublished() const { return end_published_; }

 private:
  lcm::LCM& lcm_;
  std::map<std::string, NodeCounts> status_;
  std::map<std::string, int64_t> reports_;
  int64_t poses_ = 0;
  bool start_seen_ = false, end_seen_ = false;
  int64_t end_published_ = -1;
};

/// The pipeline options as the frontend and estimator will read them (--config, --set,
/// --features, --depth-model): every error, so that a bad key is refused here with its own
/// message (exit 2) instead of ending a node at start-up.
std::vector<std::string> pipelineArgErrors(const LaunchOptions& o) {
  pplvo::pipeline::PipelineArgs args;
  args.config = o.config;
  args.overrides = o.set;
  if (!o.features.empty()) args.shortcuts.emplace_back("--features", o.features);
  if (!o.depth_model.empty()) args.shortcuts.emplace_back("--depth-model", o.depth_model);
  pplvo::pipeline::PipelineOptions options;
  pplvo::ArgParser parser;
  pplvo::pipeline::applyPipelineArgs(args, &options, &parser);
  return parser.errors();
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

int main(int argc, char** argv) {
  const auto t0 = Clock::now();
  const ParsedArgs parsed = parseLaunchArgs(std::vector<std::string>(argv + 1, argv + argc));
  if (parsed.help) {
    std::printf("%s", launchUsage().c_str());
    return 0;
  }
  std::vector<std::string> errors = parsed.errors;
  if (errors.empty()) errors = pipelineArgErrors(parsed.options);
  if (!errors.empty()) {
    for (const std::string& e : errors) std::fprintf(stderr, "pplvo-launch: %s\n", e.c_str());
    std::fprintf(stderr, "pplvo-launch: see --help\n");
    return 2;
  }
  LaunchOptions o = parsed.options;
  auto say = [&](const std::string& s) {
    if (!o.quiet) std::fprintf(stderr, "[pplvo-launch] %s\n", s.c_str());
  };

  // 1. Namespace first: unshare(CLONE_NEWUSER) needs a single-threaded process (no LCM yet).
  if (o.isolated) {
    const IsolationResult iso = enterIsolatedNetwork();
    if (!iso.ok) {
      std::fprintf(stderr, "pplvo-launch: --isolated: %s\n", iso.detail.c_str());
      return iso.unavailable ? 4 : 1;
    }
    say("isolated: " + iso.detail);
  }
  const UrlDecision url =
      decideLcmUrl(parsed.options, std::getenv("LCM_DEFAULT_URL"), readRmemMax());
  for (const std::string& w : url.warnings)
    std::fprintf(stderr, "pplvo-launch: warning: %s\n", w.c_str());
  if (!url.errors.empty()) {
    for (const std::string& e : url.errors) std::fprintf(stderr, "pplvo-launch: %s\n", e.c_str());
    return 2;
  }
  o.compress = o.compress || url.compress;

  // 2. Programs.
  const std::string bin_dir = o.bin_dir.empty() ? selfExecutableDir() : o.bin_dir;
  std::vector<std::string> missing;
  for (const std::string& name : allPrograms()) {
    const std::string why = checkExecutable(bin_dir + "/" + name);
    if (!why.empty()) missing.push_back(bin_dir + "/" + name + ": " + why);
  }
  if (!missing.empty()) {
    for (const std::string& m : missing) {
      std::fprintf(stderr, "pplvo-launch: missing node program %s\n", m.c_str());
    }
    std::fprintf(stderr,
                 "pplvo-launch: build the programs (cmake --build build --target pplvo-player "
                 "pplvo-depth-filter pplvo-frontend pplvo-estimator pplvo-logger) or pass "
                 "--bin-dir\n");
    return 1;
  }
  std::string log_dir = o.node_log_dir;
  bool temp_logs = false;
  if (log_dir.empty()) {
    char tmpl[] = "/tmp/pplvo-launch-XXXXXX";
    if (::mkdtemp(tmpl) == nullptr) {
      std::perror("pplvo-launch: mkdtemp");
      return 1;
    }
    log_dir = tmpl;
    temp_logs = true;
  } else {
    std::error_code ec;
    std::filesystem::create_directories(log_dir, ec);
  }

  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  ::signal(SIGPIPE, SIG_IGN);

  lcm::LCM lcm(url.url);
  if (!lcm.good()) {
    std::fprintf(stderr, "pplvo-launch: cannot open LCM at %s%s\n", url.url.c_str(),
                 o.isolated ? "" : " (no multicast route? try --isolated)");
    return 1;
  }
  BusMonitor bus(lcm);
  say("LCM " + url.url + ", programs from " + bin_dir + ", process logs in " + log_dir);
  for (const std::string& r : url.routes) say("route " + r);

  LaunchReport report;
  report.lockstep = o.lockstep;
  report.url = url.url;
  report.trajectory_path = o.output;
  const std::vector<ProcessSpec> specs = buildProcessSpecs(o, url, bin_dir, log_dir);
  // A reused --node-logs folder holds an earlier run's logs: the report must read this run's
  // counters only (a stage killed before its "done:" line would show the earlier one's).
  for (const ProcessSpec& spec : specs) {
    std::error_code ec;
    std::filesystem::remove(spec.log_path, ec);
  }
  const auto deadline = t0 + std::chrono::duration<double>(o.timeout_s);
  auto seconds = [&] { return std::chrono::duration<double>(Clock::now() - t0).count(); };

  // Killed (--test-kill) and failures.
  std::string kill_name;
  int64_t kill_after = -1;
  if (!o.test_kill.empty()) {
    const size_t colon = o.test_kill.rfind(':');
    kill_name = o.test_kill.substr(0, colon);
    kill_after = std::stoll(o.test_kill.substr(colon + 1));
  }
  bool test_killed = false;
  std::string pause_name;
  int64_t pause_after = -1;
  double pause_s = 0.0;
  if (!o.test_pause.empty()) {
    const size_t second = o.test_pause.rfind(':');
    const size_t first = o.test_pause.rfind(':', second - 1);
    pause_name = o.test_pause.substr(0, first);
    pause_after = std::stoll(o.test_pause.substr(first + 1, second - first - 1));
    pause_s = std::stod(o.test_pause.substr(second + 1));
  }
  std::optional<Clock::time_point> paused_at;  // --test-pause: when the SIGSTOP was sent
  bool pause_done = false;
  std::vector<std::string>& failures = report.failures;
  std::string failed_process;  // whose log to show

  {
    Supervisor sup;
    // Checks every child; returns false (and records why) if one ended when it should not.
    // --restart: stages that died and when to start them again; restarts done per stage.
    std::map<std::string, Clock::time_point> restart_at;
    std::map<std::string, int> restarts_of;
    std::set<size_t> restarted;  // children that died and were (or will be) replaced
    auto mayRestart = [&](const std::string& name) {
      return name == kDepthFilter || name == kFrontend || name == kEstimator;
    };
    auto checkChildren = [&](bool player_may_end) {
      for (size_t i : sup.poll()) {
        const ChildState& c = sup.child(i);
        if (c.stop_requested) continue;
        if (c.spec.name == kPlayer && player_may_end) continue;
        const std::string& name = c.spec.name;
        if (mayRestart(name) && restarts_of[name] < o.restart_limit) {
          const double backoff = o.restart_backoff_s * (1 << std::min(restarts_of[name], 16));
          say(name + " ended (" + c.exit->text() + "); restarting it in " +
              std::to_string(backoff) + " s");
          restart_at[name] = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(backoff));
          restarted.insert(i);
          continue;
        }
        failures.push_back(name + " ended early (" + c.exit->text() + ")" +
                           (restarts_of[name] > 0
                                ? " after " + std::to_string(restarts_of[name]) + " restart(s)"
                                : ""));
        if (failed_process.empty()) failed_process = name;
      }
      for (auto it = restart_at.begin(); it != restart_at.end();) {
        if (Clock::now() < it->second) {
          ++it;
          continue;
        }
        const ProcessSpec spec = sup.child(*sup.find(it->first)).spec;
        const size_t i = sup.spawn(spec);  // the same command line; its log is appended to
        ++restarts_of[it->first];
        ++report.restarts;
        say("restarted " + it->first + " (pid " + std::to_string(sup.child(i).pid) + ")");
        it = restart_at.erase(it);
      }
      return failures.empty();
    };
    auto checkLimits = [&](const char* phase) {
      if (g_interrupted) {
        failures.push_back(std::string("interrupted (SIGINT/SIGTERM) during ") + phase);
        return false;
      }
      if (Clock::now() > deadline) {
        failures.push_back("timeout: --timeout " + std::to_string(o.timeout_s) +
                           " s reached during " + phase);
        return false;
      }
      return true;
    };
    auto maybeTestKill = [&] {
      if (test_killed || kill_after < 0 || bus.poses() < kill_after) return;
      if (auto i = sup.find(kill_name); i && sup.child(*i).running()) {
        say("--test-kill: SIGKILL " + kill_name + " after " + std::to_string(bus.poses()) +
            " poses");
        sup.signal(*i, SIGKILL);
        test_killed = true;
      }
    };

    auto maybeTestPause = [&] {
      if (pause_done || pause_after < 0) return;
      const std::optional<size_t> i = sup.find(pause_name);
      if (!i || !sup.child(*i).running()) return;
      if (!paused_at && bus.poses() >= pause_after) {
        say("--test-pause: SIGSTOP " + pause_name + " after " + std::to_string(bus.poses()) +
            " poses for " + std::to_string(pause_s) + " s");
        sup.signal(*i, SIGSTOP);
        paused_at = Clock::now();
      } else if (paused_at && Clock::now() - *paused_at >= std::chrono::duration<double>(pause_s)) {
        say("--test-pause: SIGCONT " + pause_name);
        sup.signal(*i, SIGCONT);
        pause_done = true;
      }
    };

    try {
      // 3. Nodes and logger, then wait until each node published its first status (proof that
      // it is up and its LCM is subscribed; statuses come about once a second).
      for (size_t k = 0; k + 1 < specs.size(); ++k) {
        const size_t i = sup.spawn(specs[k]);
        say("started " + specs[k].name + " (pid " + std::to_string(sup.child(i).pid) + ")");
      }
      const auto startup_deadline =
          Clock::now() + std::chrono::duration<double>(o.startup_timeout_s);
      bool ready = false;
      while (!ready && checkChildren(false) && checkLimits("start-up")) {
        bus.handle(20);
        ready = true;
        for (const std::string& n : statusNodes()) ready = ready && bus.hasStatus(n);
        if (!ready && Clock::now() > startup_deadline) {
          std::string silent;
          for (const std::string& n : statusNodes()) {
            if (!bus.hasStatus(n)) silent += " " + n;
          }
          failures.push_back("no status message within " + std::to_string(o.startup_timeout_s) +
                             " s from" + silent + " (LCM multicast not delivered? try --isolated)");
          break;
        }
      }
      if (ready) {
        // The logger publishes nothing: it was started together with the nodes, is still
        // alive (checked above), and subscribes right after opening LCM.
        say("nodes subscribed after " + std::to_string(seconds()) + " s; starting the player");
        sup.spawn(specs.back());
        // 4. Until the player ends.
        const size_t player = *sup.find(kPlayer);
        while (sup.child(player).running() && checkChildren(true) && checkLimits("the run")) {
          bus.handle(20);
          maybeTestKill();
          maybeTestPause();
        }
        if (failures.empty()) {
          const ExitInfo& pe = *sup.child(player).exit;
          if (!pe.clean()) {
            failures.push_back(std::string(kPlayer) + " failed (" + pe.text() + ")");
            failed_process = kPlayer;
          } else {
            say("player ended at " + std::to_string(seconds()) + " s; draining");
          }
        }
        // 5. Drain: all published frames posed, or no new pose for --drain-idle.
        if (failures.empty()) {
          DrainMonitor drain(o.drain_idle_s);
          while (checkChildren(true) && checkLimits("the drain")) {
            bus.handle(20);
            maybeTestKill();
            maybeTestPause();
            int64_t published = bus.endSeen() ? bus.endPublished() : -1;
            if (published < 0) {
              if (auto s = bus.status(kPlayer)) published = s->frames_out;
            }
            if (drain.drained(seconds(), bus.poses(), published)) break;
          }
          if (failures.empty()) {
            say("drained at " + std::to_string(seconds()) + " s: " +
                std::to_string(bus.poses()) + " poses seen");
          }
        }
      }
    } catch (const SpawnError& e) {
      failures.push_back(e.what());
    }

    // 6. Stop: nodes first (they publish a final status), the logger last so that it records
    // them; SIGKILL after the grace period. Everything is stopped on every path.
    if (paused_at && !pause_done) {  // never leave a stage stopped: it could not stop cleanly
      if (auto i = sup.find(pause_name)) sup.signal(*i, SIGCONT);
    }
    std::vector<size_t> nodes;
    for (const std::string& n : {std::string(kPlayer), std::string(kDepthFilter),
                                 std::string(kFrontend), std::string(kEstimator)}) {
      if (auto i = sup.find(n)) nodes.push_back(*i);
    }
    sup.stop(nodes, o.stop_grace_s, [&] { bus.handle(10); });
    bus.handle(300);
    // The logger writes each pose as it comes; give it (bounded) time to catch up with every
    // pose the launcher saw before it is stopped, so that no late pose is cut off.
    const auto logger_deadline = Clock::now() + std::chrono::seconds(3);
    while (countTrajectoryLines(o.output) < bus.poses() && Clock::now() < logger_deadline) {
      bus.handle(20);
    }
    if (auto i = sup.find(kLogger)) sup.stop({*i}, o.stop_grace_s, [&] { bus.handle(10); });
    bus.handle(50);
    if (test_killed && report.restarts == 0) {
      // A kill on request is still a failure of the launch; make sure it is named.
      bool named = false;
      for (const std::string& f : failures) named = named || f.rfind(kill_name, 0) == 0;
      if (!named) failures.push_back(kill_name + " was killed by --test-kill");
    }

    for (const ChildState& c : sup.children()) {
      LaunchReport::Process p;
      p.name = c.spec.name;
      p.exit = c.exit;
      p.stop_requested = c.stop_requested;
      p.killed = c.killed;
      p.has_counts = c.spec.name != kLogger;
      p.pauses = c.pauses;
      p.paused_s = c.paused_s;
      p.restarted = restarted.count(&c - sup.children().data()) > 0;
      // A replaced process shares its log with its successor, whose counts those are.
      if (p.restarted) p.has_counts = false;
      if (p.has_counts) {
        const std::string log = readFile(c.spec.log_path);
        if (auto d = parseDoneLine(log, c.spec.name)) p.counts = *d;
        if (c.spec.name == kDepthFilter) report.overload_fusions = parseOverloadFusions(log);
        if (auto s = bus.status(c.spec.name)) {
          // The final status has errors too; the done line is the final word on the counts.
          if (!p.counts.known) p.counts = *s;
          p.counts.errors = s->errors;
        }
      }
      if (c.killed && failures.empty()) {
        failures.push_back(c.spec.name + " did not stop within " + std::to_string(o.stop_grace_s) +
                           " s of SIGINT (killed)");
      }
      if (c.exit && !c.exit->clean() && !c.killed && !p.restarted) {
        const std::string f = c.spec.name + " ended with " + c.exit->text();
        bool dup = false;
        for (const std::string& x : failures) dup = dup || x.rfind(c.spec.name, 0) == 0;
        if (!dup) failures.push_back(f);
        if (failed_process.empty()) failed_process = c.spec.name;
      }
      report.processes.push_back(p);
    }
  }  // Supervisor destroyed: nothing survives it.

  report.frames_published = bus.endSeen() ? bus.endPublished() : -1;
  for (const auto& p : report.processes) {
    if (report.frames_published < 0 && p.name == kPlayer && p.counts.known) {
      report.frames_published = p.counts.frames_out;
    }
  }
  if (o.lockstep) {
    // A pose the player stopped waiting for was lost (UDP loss, a dead node): the lockstep
    // promise (trajectory equal to pplvo-run's) no longer holds, so the launch fails.
    for (const auto& p : report.processes) {
      if (p.name == kPlayer && p.counts.known && p.counts.errors > 0) {
        failures.push_back(std::to_string(p.counts.errors) +
                           " lockstep timeout(s): poses lost (receive buffers too small? see "
                           "docs/launch.md)");
      }
    }
  }
  report.poses_seen = bus.poses();
  report.trajectory_poses = countTrajectoryLines(o.output);
  report.checkFramesLostToFaults();
  report.wall_s = seconds();
  std::printf("%s", report.text().c_str());
  std::fflush(stdout);
  if (!report.ok()) {
    if (!failed_process.empty()) {
      const std::string path = log_dir + "/" + failed_process + ".log";
      std::fprintf(stderr, "pplvo-launch: last lines of %s:\n%s", path.c_str(),
                   tailOfFile(path, 15).c_str());
    }
    std::fprintf(stderr, "pplvo-launch: FAILED: %s; process logs kept in %s\n",
                 report.failures.front().c_str(), log_dir.c_str());
    return g_interrupted ? 130 : 1;
  }
  if (temp_logs) {
    std::error_code ec;
    std::filesystem::remove_all(log_dir, ec);
  }
  return 0;
}
