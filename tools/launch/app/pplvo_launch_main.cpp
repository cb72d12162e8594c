// pplvo-launch: the pipeline as separate processes on one LCM URL (see docs/launch.md).
// Process handling is in pplvo_launch (no LCM); this file adds the LCM side: it listens to
// PPLVO_STATUS (node counters, readiness), PPLVO_STREAM (the player's END) and PPLVO_POSE
// (poses seen, for the drain rule and --test-kill).
#include <signal.h>
#include <unistd.h>

#include <algorithm>
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

#include "pplvo/launch/isolation.h"
#include "pplvo/launch/launch_args.h"
#include "pplvo/launch/launch_report.h"
#include "pplvo/launch/lcm_url.h"
#include "pplvo/launch/process_specs.h"
#include "pplvo/launch/supervisor.h"
#include "pplvo/msgs/channels.h"
#include "pplvo/pipeline/pipeline_args.h"

namespace {

using namespace pplvo::launch;
using Clock = std::chrono::steady_clock;

volatile sig_atomic_t g_interrupted = 0;
void onSignal(int) { g_interrupted = 1; }

/// The counts a node_status_t carries (the depth filter's shortened fusions: the count of its
/// "ogm_shortened" stage).
NodeCounts countsOf(const pplvo_msgs::node_status_t& m) {
  NodeCounts c;
  c.frames_in = m.frames_in;
  c.frames_out = m.frames_out;
  c.frames_dropped = m.frames_dropped;
  c.frames_skipped = m.frames_skipped;
  c.frames_pending = m.frames_pending;
  c.frames_lost = m.frames_lost;
  c.messages_skipped = m.messages_skipped;
  c.errors = m.errors;
  c.known = true;
  c.final = m.at_exit;
  for (const pplvo_msgs::stage_timing_t& t : m.stages) {
    if (t.name == "ogm_shortened") c.shortened_fusions = t.count;
    if (t.name == "stray_frame") c.stray_frames = t.count;
    if (t.name.rfind("publish_blocked:", 0) == 0) {
      c.blocked_publishes += t.count;
      c.blocked_publish_max_ms = std::max(c.blocked_publish_max_ms, t.max_ms);
    }
  }
  return c;
}

/// What the launcher hears on the bus. Handlers only copy numbers (no throw possible).
class BusMonitor {
 public:
  explicit BusMonitor(lcm::LCM& lcm) : lcm_(lcm) {
    lcm_.subscribe(pplvo::channels::kStatus, &BusMonitor::onStatus, this);
    lcm_.subscribe(pplvo::channels::kStream, &BusMonitor::onStream, this);
    lcm_.subscribe(pplvo::channels::kPose, &BusMonitor::onPose, this);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&, const pplvo_msgs::node_status_t* m) {
    const NodeCounts c = countsOf(*m);
    status_[m->node] = c;
    by_pid_[m->pid] = c;
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
  /// The last status of the process `pid` (its final one if it published that).
  std::optional<NodeCounts> statusOf(pid_t pid) const {
    auto it = by_pid_.find(static_cast<int32_t>(pid));
    if (it == by_pid_.end()) return std::nullopt;
    return it->second;
  }
  int64_t poses() const { return poses_; }
  bool endSeen() const { return end_seen_; }
  int64_t endPublished() const { return end_published_; }

 private:
  lcm::LCM& lcm_;
  std::map<std::string, NodeCounts> status_;
  std::map<int32_t, NodeCounts> by_pid_;
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

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// The launcher's progress messages on stderr (none with --quiet).
struct Narrator {
  bool quiet = false;
  void operator()(const std::string& s) const {
    if (!quiet) std::fprintf(stderr, "[pplvo-launch] %s\n", s.c_str());
  }
};

/// Prints every error of the command line, or else of the pipeline options it carries;
/// true when there was one (exit 2).
bool reportArgErrors(const ParsedArgs& parsed) {
  std::vector<std::string> errors = parsed.errors;
  if (errors.empty()) errors = pipelineArgErrors(parsed.options);
  if (errors.empty()) return false;
  for (const std::string& e : errors) std::fprintf(stderr, "pplvo-launch: %s\n", e.c_str());
  std::fprintf(stderr, "pplvo-launch: see --help\n");
  return true;
}

/// Enters the private network namespace (--isolated); the exit status when that fails.
std::optional<int> enterIsolation(const Narrator& say) {
  const IsolationResult iso = enterIsolatedNetwork();
  if (!iso.ok) {
    std::fprintf(stderr, "pplvo-launch: --isolated: %s\n", iso.detail.c_str());
    return iso.unavailable ? 4 : 1;
  }
  say("isolated: " + iso.detail);
  return std::nullopt;
}

/// Prints the URL policy's warnings and errors; false when there were errors (exit 2).
bool reportUrlDecision(const UrlDecision& url) {
  for (const std::string& w : url.warnings)
    std::fprintf(stderr, "pplvo-launch: warning: %s\n", w.c_str());
  if (url.errors.empty()) return true;
  for (const std::string& e : url.errors) std::fprintf(stderr, "pplvo-launch: %s\n", e.c_str());
  return false;
}

/// False, with what to do, when a node program is missing from `bin_dir`.
bool checkPrograms(const std::string& bin_dir) {
  const std::vector<std::string> missing = missingPrograms(bin_dir);
  if (missing.empty()) return true;
  for (const std::string& m : missing) {
    std::fprintf(stderr, "pplvo-launch: missing node program %s\n", m.c_str());
  }
  std::fprintf(stderr,
               "pplvo-launch: build the programs (cmake --build build --target pplvo-player "
               "pplvo-depth-filter pplvo-frontend pplvo-estimator pplvo-logger) or pass "
               "--bin-dir\n");
  return false;
}

/// Where the processes' logs go: --node-logs, or a temporary folder that a successful launch
/// removes.
struct LogDir {
  std::string path;
  bool temporary = false;
};
std::optional<LogDir> makeLogDir(const std::string& node_log_dir) {
  LogDir dir{node_log_dir, false};
  if (dir.path.empty()) {
    char tmpl[] = "/tmp/pplvo-launch-XXXXXX";
    if (::mkdtemp(tmpl) == nullptr) {
      std::perror("pplvo-launch: mkdtemp");
      return std::nullopt;
    }
    dir = {tmpl, true};
  } else {
    std::error_code ec;
    std::filesystem::create_directories(dir.path, ec);
  }
  return dir;
}

/// SIGINT/SIGTERM end the launch through g_interrupted (the children are still stopped in
/// order); a reader that went away must not kill the launcher (SIGPIPE).
void installSignalHandlers() {
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
}

/// One supervised run (steps 3-6 of main): starts the processes, watches them and the bus
/// through start-up, the sequence and the drain, stops them all and puts each into the
/// report. The Supervisor stops every child that is left when the run is destroyed.
class SupervisedRun {
 public:
  SupervisedRun(const LaunchOptions& o, BusMonitor& bus, Narrator say, Clock::time_point t0,
                LaunchReport& report)
      : o_(o),
        bus_(bus),
        say_(say),
        t0_(t0),
        deadline_(t0 + std::chrono::duration<double>(o.timeout_s)),
        faults_(planTestFaults(o)),
        report_(report),
        failures_(report.failures),
        show_progress_(o.progress.value_or(!o.quiet && ::isatty(STDERR_FILENO) == 1)) {}

  /// `specs` in start order, the player last.
  void run(const std::vector<ProcessSpec>& specs) {
    try {
      if (startNodesAndWaitUntilReady(specs)) {
        playSequence(specs.back());
        drain();
      }
    } catch (const SpawnError& e) {
      failures_.push_back(e.what());
    }
    stopAll();
    nameTestKill();
    reportProcesses();
  }
  /// The first process that failed, whose log main shows ("" when none did).
  const std::string& failedProcess() const { return failed_process_; }

 private:
  double seconds() const { return secondsSince(t0_); }

  static bool mayRestart(const std::string& name) {
    return name == kDepthFilter || name == kFrontend || name == kEstimator;
  }

  /// Checks every child; returns false (and records why) if one ended when it should not.
  /// --restart: a dead stage is scheduled for a restart after its backoff instead, and the
  /// stages whose time has come are started again.
  bool checkChildren(bool player_may_end) {
    for (size_t i : sup_.poll()) {
      const ChildState& c = sup_.child(i);
      if (c.stop_requested) continue;
      if (c.spec.name == kPlayer && player_may_end) continue;
      const std::string& name = c.spec.name;
      if (mayRestart(name) && restarts_of_[name] < o_.restart_limit) {
        const double backoff = o_.restart_backoff_s * (1 << std::min(restarts_of_[name], 16));
        say_(name + " ended (" + c.exit->text() + "); restarting it in " + std::to_string(backoff) +
             " s");
        restart_at_[name] = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                               std::chrono::duration<double>(backoff));
        restarted_.insert(i);
        continue;
      }
      failures_.push_back(name + " ended early (" + c.exit->text() + ")" +
                          (restarts_of_[name] > 0
                               ? " after " + std::to_string(restarts_of_[name]) + " restart(s)"
                               : ""));
      if (failed_process_.empty()) failed_process_ = name;
    }
    for (auto it = restart_at_.begin(); it != restart_at_.end();) {
      if (Clock::now() < it->second) {
        ++it;
        continue;
      }
      const ProcessSpec spec = sup_.child(*sup_.find(it->first)).spec;
      const size_t i = sup_.spawn(spec);  // the same command line; its log is appended to
      ++restarts_of_[it->first];
      ++report_.restarts;
      say_("restarted " + it->first + " (pid " + std::to_string(sup_.child(i).pid) + ")");
      it = restart_at_.erase(it);
    }
    return failures_.empty();
  }

  /// False (and why) once interrupted or past --timeout.
  bool checkLimits(const char* phase) {
    if (g_interrupted) {
      failures_.push_back(std::string("interrupted (SIGINT/SIGTERM) during ") + phase);
      return false;
    }
    if (Clock::now() > deadline_) {
      failures_.push_back("timeout: --timeout " + std::to_string(o_.timeout_s) +
                          " s reached during " + phase);
      return false;
    }
    return true;
  }

  /// --test-kill: SIGKILL the stage once enough poses were seen.
  void maybeTestKill() {
    if (test_killed_ || faults_.kill_after_poses < 0 || bus_.poses() < faults_.kill_after_poses)
      return;
    if (auto i = sup_.find(faults_.kill_node); i && sup_.child(*i).running()) {
      say_("--test-kill: SIGKILL " + faults_.kill_node + " after " + std::to_string(bus_.poses()) +
           " poses");
      sup_.signal(*i, SIGKILL);
      test_killed_ = true;
    }
  }

  /// --test-pause: SIGSTOP the stage once enough poses were seen, SIGCONT it after the pause.
  void maybeTestPause() {
    if (pause_done_ || faults_.pause_after_poses < 0) return;
    const std::optional<size_t> i = sup_.find(faults_.pause_node);
    if (!i || !sup_.child(*i).running()) return;
    if (!paused_at_ && bus_.poses() >= faults_.pause_after_poses) {
      say_("--test-pause: SIGSTOP " + faults_.pause_node + " after " +
           std::to_string(bus_.poses()) + " poses for " + std::to_string(faults_.pause_s) + " s");
      sup_.signal(*i, SIGSTOP);
      paused_at_ = Clock::now();
    } else if (paused_at_ &&
               Clock::now() - *paused_at_ >= std::chrono::duration<double>(faults_.pause_s)) {
      say_("--test-pause: SIGCONT " + faults_.pause_node);
      sup_.signal(*i, SIGCONT);
      pause_done_ = true;
    }
  }

  /// 3. Nodes and logger, then wait until each node published its first status (proof that
  /// it is up and its LCM is subscribed; statuses come about once a second). True when all
  /// are ready.
  bool startNodesAndWaitUntilReady(const std::vector<ProcessSpec>& specs) {
    for (size_t k = 0; k + 1 < specs.size(); ++k) {
      const size_t i = sup_.spawn(specs[k]);
      say_("started " + specs[k].name + " (pid " + std::to_string(sup_.child(i).pid) + ")");
    }
    const auto startup_deadline =
        Clock::now() + std::chrono::duration<double>(o_.startup_timeout_s);
    bool ready = false;
    while (!ready && checkChildren(false) && checkLimits("start-up")) {
      bus_.handle(20);
      ready = true;
      for (const std::string& n : statusNodes()) ready = ready && bus_.hasStatus(n);
      if (!ready && Clock::now() > startup_deadline) {
        std::string silent;
        for (const std::string& n : statusNodes()) {
          if (!bus_.hasStatus(n)) silent += " " + n;
        }
        failures_.push_back("no status message within " + std::to_string(o_.startup_timeout_s) +
                            " s from" + silent + " (LCM multicast not delivered? try --isolated)");
        break;
      }
    }
    return ready;
  }

  /// 4. The player, until it ends; its exit must be clean.
  void playSequence(const ProcessSpec& player_spec) {
    // The logger publishes nothing: it was started together with the nodes, is still
    // alive (checked above), and subscribes right after opening LCM.
    say_("nodes subscribed after " + std::to_string(seconds()) + " s; starting the player");
    sup_.spawn(player_spec);
    const size_t player = *sup_.find(kPlayer);
    auto last_progress = Clock::now();
    while (sup_.child(player).running() && checkChildren(true) && checkLimits("the run")) {
      bus_.handle(20);
      maybeTestKill();
      maybeTestPause();
      if (show_progress_ && Clock::now() - last_progress > std::chrono::milliseconds(500)) {
        last_progress = Clock::now();
        printProgress(false);
      }
    }
    if (show_progress_) printProgress(true);
    if (failures_.empty()) {
      const ExitInfo& pe = *sup_.child(player).exit;
      if (!pe.clean()) {
        failures_.push_back(std::string(kPlayer) + " failed (" + pe.text() + ")");
        failed_process_ = kPlayer;
      } else {
        say_("player ended at " + std::to_string(seconds()) + " s; draining");
      }
    }
  }

  /// The player's frames out (its last status) against the poses heard, on one line.
  void printProgress(bool last) const {
    const std::optional<NodeCounts> player = bus_.status(kPlayer);
    int64_t dropped = 0;
    for (const char* node : {kDepthFilter, kFrontend, kEstimator}) {
      if (const auto c = bus_.status(node)) dropped += c->frames_dropped;
    }
    // The player reports about once a second, poses come every frame: never fewer published
    // than posed.
    const int64_t published = player ? std::max(player->frames_out, bus_.poses()) : -1;
    std::fprintf(stderr, "\r%s\033[K%s",
                 progressLine(published, bus_.poses(), dropped, seconds()).c_str(),
                 last ? "\n" : "");
  }

  /// 5. Drain: all published frames posed, or no new pose for --drain-idle.
  void drain() {
    if (!failures_.empty()) return;
    DrainMonitor drain(o_.drain_idle_s);
    while (checkChildren(true) && checkLimits("the drain")) {
      bus_.handle(20);
      maybeTestKill();
      maybeTestPause();
      int64_t published = bus_.endSeen() ? bus_.endPublished() : -1;
      if (published < 0) {
        if (auto s = bus_.status(kPlayer)) published = s->frames_out;
      }
      if (drain.drained(seconds(), bus_.poses(), published)) break;
    }
    if (failures_.empty()) {
      say_("drained at " + std::to_string(seconds()) + " s: " + std::to_string(bus_.poses()) +
           " poses seen");
    }
  }

  /// 6. Stop: nodes first (they publish a final status), the logger last so that it records
  /// them; SIGKILL after the grace period. Everything is stopped on every path.
  void stopAll() {
    if (paused_at_ && !pause_done_) {  // never leave a stage stopped: it could not stop cleanly
      if (auto i = sup_.find(faults_.pause_node)) sup_.signal(*i, SIGCONT);
    }
    std::vector<size_t> nodes;
    for (const std::string& n : {std::string(kPlayer), std::string(kDepthFilter),
                                 std::string(kFrontend), std::string(kEstimator)}) {
      if (auto i = sup_.find(n)) nodes.push_back(*i);
    }
    sup_.stop(nodes, o_.stop_grace_s, [&] { bus_.handle(10); });
    bus_.handle(300);
    // The logger writes each pose as it comes; give it (bounded) time to catch up with every
    // pose the launcher saw before it is stopped, so that no late pose is cut off.
    const auto logger_deadline = Clock::now() + std::chrono::seconds(3);
    while (countTrajectoryLines(o_.output) < bus_.poses() && Clock::now() < logger_deadline) {
      bus_.handle(20);
    }
    if (auto i = sup_.find(kLogger)) sup_.stop({*i}, o_.stop_grace_s, [&] { bus_.handle(10); });
    bus_.handle(50);
  }

  /// A kill on request (without a restart) is still a failure of the launch; make sure it is
  /// named.
  void nameTestKill() {
    if (!test_killed_ || report_.restarts != 0) return;
    bool named = false;
    for (const std::string& f : failures_) named = named || f.rfind(faults_.kill_node, 0) == 0;
    if (!named) failures_.push_back(faults_.kill_node + " was killed by --test-kill");
  }

  /// Each process into the report: exit, faults, counts (its final node_status_t, else its last
  /// one, marked as not final), and the failures not yet named.
  void reportProcesses() {
    for (const ChildState& c : sup_.children()) {
      LaunchReport::Process p;
      p.name = c.spec.name;
      p.exit = c.exit;
      p.stop_requested = c.stop_requested;
      p.killed = c.killed;
      p.has_counts = c.spec.name != kLogger;
      p.pauses = c.pauses;
      p.paused_s = c.paused_s;
      p.restarted = restarted_.count(&c - sup_.children().data()) > 0;
      // Each process's own statuses (by pid): a restarted stage's predecessor keeps its own.
      if (p.has_counts) {
        if (auto s = bus_.statusOf(c.pid)) p.counts = *s;
        if (c.spec.name == kDepthFilter && !p.restarted && p.counts.known) {
          report_.overload_fusions = p.counts.shortened_fusions;
        }
      }
      if (c.killed && failures_.empty()) {
        failures_.push_back(c.spec.name + " did not stop within " +
                            std::to_string(o_.stop_grace_s) + " s of SIGINT (killed)");
      }
      if (c.exit && !c.exit->clean() && !c.killed && !p.restarted) {
        const std::string f = c.spec.name + " ended with " + c.exit->text();
        bool dup = false;
        for (const std::string& x : failures_) dup = dup || x.rfind(c.spec.name, 0) == 0;
        if (!dup) failures_.push_back(f);
        if (failed_process_.empty()) failed_process_ = c.spec.name;
      }
      report_.processes.push_back(p);
    }
  }

  const LaunchOptions& o_;
  BusMonitor& bus_;
  const Narrator say_;
  const Clock::time_point t0_;
  // t0 + --timeout, in double seconds as the comparison with Clock::now() always was.
  const decltype(Clock::time_point() + std::chrono::duration<double>()) deadline_;
  const TestFaultPlan faults_;
  LaunchReport& report_;
  std::vector<std::string>& failures_;
  const bool show_progress_;
  std::string failed_process_;  // whose log to show
  Supervisor sup_;
  // --restart: stages that died and when to start them again; restarts done per stage.
  std::map<std::string, Clock::time_point> restart_at_;
  std::map<std::string, int> restarts_of_;
  std::set<size_t> restarted_;  // children that died and were (or will be) replaced
  bool test_killed_ = false;
  std::optional<Clock::time_point> paused_at_;  // --test-pause: when the SIGSTOP was sent
  bool pause_done_ = false;
};

/// The report's totals once every process has been stopped.
void finishReport(LaunchReport& report, const BusMonitor& bus, const std::string& trajectory,
                  Clock::time_point t0) {
  report.frames_published = bus.endSeen() ? bus.endPublished() : -1;
  report.takePlayerCounts();
  report.poses_seen = bus.poses();
  report.trajectory_poses = countTrajectoryLines(trajectory);
  report.checkFramesLostToFaults();
  report.checkLoggerKeptEveryPose();
  report.wall_s = secondsSince(t0);
}

/// Prints the report (stdout) and, on failure, the failed process's last log lines; removes a
/// temporary log folder after a success. Returns the exit status.
int printOutcome(const LaunchReport& report, const std::string& failed_process,
                 const LogDir& logs) {
  std::printf("%s", report.text().c_str());
  std::fflush(stdout);
  if (!report.ok()) {
    if (!failed_process.empty()) {
      const std::string path = logs.path + "/" + failed_process + ".log";
      std::fprintf(stderr, "pplvo-launch: last lines of %s:\n%s", path.c_str(),
                   tailOfFile(path, 15).c_str());
    }
    std::fprintf(stderr, "pplvo-launch: FAILED: %s; process logs kept in %s\n",
                 report.failures.front().c_str(), logs.path.c_str());
    return g_interrupted ? 130 : 1;
  }
  if (logs.temporary) {
    std::error_code ec;
    std::filesystem::remove_all(logs.path, ec);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const auto t0 = Clock::now();
  const ParsedArgs parsed = parseLaunchArgs(std::vector<std::string>(argv + 1, argv + argc));
  if (parsed.help) {
    std::printf("%s", launchUsage().c_str());
    return 0;
  }
  if (reportArgErrors(parsed)) return 2;
  LaunchOptions o = parsed.options;
  const Narrator say{o.quiet};

  // 1. Namespace first: unshare(CLONE_NEWUSER) needs a single-threaded process (no LCM yet).
  if (o.isolated) {
    if (const std::optional<int> status = enterIsolation(say)) return *status;
  }
  const UrlDecision url =
      decideLcmUrl(parsed.options, std::getenv("LCM_DEFAULT_URL"), readRmemMax());
  if (!reportUrlDecision(url)) return 2;
  o.compress = o.compress || url.compress;

  // 2. Programs, log folder, signals, bus.
  const std::string bin_dir = o.bin_dir.empty() ? selfExecutableDir() : o.bin_dir;
  if (!checkPrograms(bin_dir)) return 1;
  const std::optional<LogDir> logs = makeLogDir(o.node_log_dir);
  if (!logs) return 1;
  installSignalHandlers();
  lcm::LCM lcm(url.url);
  if (!lcm.good()) {
    std::fprintf(stderr, "pplvo-launch: cannot open LCM at %s%s\n", url.url.c_str(),
                 o.isolated ? "" : " (no multicast route? try --isolated)");
    return 1;
  }
  BusMonitor bus(lcm);
  say("LCM " + url.url + ", programs from " + bin_dir + ", process logs in " + logs->path);
  for (const std::string& r : url.routes) say("route " + r);

  LaunchReport report;
  report.lockstep = o.lockstep;
  report.url = url.url;
  report.trajectory_path = o.output;
  const std::vector<ProcessSpec> specs = buildProcessSpecs(o, url, bin_dir, logs->path);
  // A reused --node-logs folder holds an earlier run's logs: the report must read this run's
  // counters only (a stage killed before its "done:" line would show the earlier one's).
  for (const ProcessSpec& spec : specs) {
    std::error_code ec;
    std::filesystem::remove(spec.log_path, ec);
  }

  // 3-6. Start, run, drain, stop.
  std::string failed_process;
  {
    SupervisedRun run(o, bus, say, t0, report);
    run.run(specs);
    failed_process = run.failedProcess();
  }  // Supervisor destroyed: nothing survives it.

  finishReport(report, bus, o.output, t0);
  return printOutcome(report, failed_process, *logs);
}
