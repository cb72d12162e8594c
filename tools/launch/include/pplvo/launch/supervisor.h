#pragma once
/// Process supervision for pplvo-launch, without LCM: spawning the node programs in their own
/// process groups with their output in per-node log files, noticing exits (waitpid), and
/// stopping them (SIGINT, then SIGKILL after a grace period). Unit-tested with ordinary
/// programs (/bin/sleep, /bin/sh); pplvo-launch (app/) adds the LCM monitoring.
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace pplvo::launch {

/// How a process ended (from waitpid's status).
struct ExitInfo {
  bool exited = false;    ///< returned from main / called exit()
  int code = 0;           ///< exit code when `exited`
  bool signaled = false;  ///< killed by a signal
  int signal = 0;         ///< the signal when `signaled`

  static ExitInfo fromWaitStatus(int status);
  /// 0 exit, or death by the signal the launcher itself sent to stop the process (SIGINT) is
  /// not clean: nodes catch SIGINT and exit 0; only a 0 exit code is clean.
  bool clean() const { return exited && code == 0; }
  /// "exit code 0", "exit code 1", "killed by signal 9 (SIGKILL)".
  std::string text() const;
};

/// One program to start.
struct ProcessSpec {
  std::string name;               ///< short name for reports, e.g. "pplvo-estimator"
  std::string path;               ///< executable (absolute or relative path; no PATH search)
  std::vector<std::string> args;  ///< arguments after argv[0] (argv[0] = path)
  std::map<std::string, std::string> env;  ///< variables set (or replaced) in the child
  std::string log_path;  ///< stdout+stderr of the child go here (empty: inherited)
};

/// A started process and what became of it.
struct ChildState {
  ProcessSpec spec;
  pid_t pid = -1;  ///< also its process group id (each child leads its own group)
  std::chrono::steady_clock::time_point started;
  std::optional<ExitInfo> exit;  ///< set once reaped
  bool stop_requested = false;   ///< SIGINT sent by stop()/stopAll()
  bool killed = false;           ///< SIGKILL sent after the grace period
  /// Times the child was stopped (SIGSTOP, SIGTSTP: by anyone) and seen so by poll(), and the
  /// time it spent stopped (up to now while it still is).
  int pauses = 0;
  double paused_s = 0.0;
  std::optional<std::chrono::steady_clock::time_point> paused_since;

  bool running() const { return pid > 0 && !exit.has_value(); }
};

/// Error starting a process (not executable, fork failed, log file unwritable), naming it.
class SpawnError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Checks that `path` is an executable regular file; returns an empty string or the reason.
std::string checkExecutable(const std::string& path);

/// Directory of the running executable (/proc/self/exe), without a trailing slash.
std::string selfExecutableDir();

/// Starts, watches and stops child processes. Not thread-safe; use from one thread. The
/// destructor kills (SIGKILL) and reaps whatever is still running, so no child outlives it.
class Supervisor {
 public:
  using Clock = std::chrono::steady_clock;
  /// The time that starts, pauses and their lengths are read from (tests inject their own, so
  /// that a measured pause does not depend on the machine's load).
  using Now = std::function<Clock::time_point()>;
  Supervisor() = default;
  explicit Supervisor(Now now) : now_(std::move(now)) {}
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;
  ~Supervisor();

  /// fork + execv with the child in its own process group, stdin from /dev/null, stdout and
  /// stderr appended to spec.log_path, and PR_SET_PDEATHSIG(SIGKILL) so that it dies with the
  /// launcher. An exec failure is reported back through a close-on-exec pipe and thrown as
  /// SpawnError (never a silent child that exits 127). Returns the index of the child.
  size_t spawn(const ProcessSpec& spec);

  /// Reaps every child that has ended (waitpid WNOHANG) and notes those stopped or continued
  /// since (ChildState::pauses). Returns the indices reaped now.
  std::vector<size_t> poll();

  /// Sends `sig` to the child's process group (no-op when it already ended).
  void signal(size_t index, int sig);

  /// Requests a clean stop (SIGINT) of the given children, waits for them up to
  /// `grace_s`, then sends SIGKILL to those still running and reaps them (bounded wait).
  /// `on_wait` (optional) is called every ~20 ms while waiting, e.g. to handle LCM.
  template <typename F>
  void stop(const std::vector<size_t>& indices, double grace_s, F&& on_wait);
  void stop(const std::vector<size_t>& indices, double grace_s) {
    stop(indices, grace_s, [] {});
  }

  /// Indices of all children still running.
  std::vector<size_t> runningIndices() const;

  const std::vector<ChildState>& children() const { return children_; }
  const ChildState& child(size_t index) const { return children_.at(index); }
  /// Index of the child called `name` (the newest, when a stage was started again), if any.
  std::optional<size_t> find(const std::string& name) const;

 private:
  void stopBegin(const std::vector<size_t>& indices);
  bool stopStillRunning(const std::vector<size_t>& indices);
  void stopKill(const std::vector<size_t>& indices);
  std::vector<ChildState> children_;
  Now now_ = [] { return Clock::now(); };
};

template <typename F>
void Supervisor::stop(const std::vector<size_t>& indices, double grace_s, F&& on_wait) {
  stopBegin(indices);
  const auto deadline = Clock::now() + std::chrono::duration<double>(grace_s);
  while (stopStillRunning(indices) && Clock::now() < deadline) on_wait();
  stopKill(indices);
}

}  // namespace pplvo::launch
