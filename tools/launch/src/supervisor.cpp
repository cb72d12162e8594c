#include "pplvo/launch/supervisor.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <thread>

namespace pplvo::launch {

namespace {

std::string signalName(int sig) {
  const char* abbrev = sigabbrev_np(sig);
  const char* desc = strsignal(sig);
  std::string s = "signal " + std::to_string(sig);
  if (abbrev != nullptr)
    s += std::string(" (SIG") + abbrev + (desc ? std::string(", ") + desc : "") + ")";
  return s;
}

/// Writes all of `len` bytes (child side of the exec-error pipe); async-signal-safe.
void writeAll(int fd, const void* data, size_t len) {
  const char* p = static_cast<const char*>(data);
  while (len > 0) {
    const ssize_t n = ::write(fd, p, len);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    p += n;
    len -= static_cast<size_t>(n);
  }
}

}  // namespace

ExitInfo ExitInfo::fromWaitStatus(int status) {
  ExitInfo e;
  if (WIFEXITED(status)) {
    e.exited = true;
    e.code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    e.signaled = true;
    e.signal = WTERMSIG(status);
  }
  return e;
}

std::string ExitInfo::text() const {
  if (exited) return "exit code " + std::to_string(code);
  if (signaled) return "killed by " + signalName(signal);
  return "unknown end";
}

std::string checkExecutable(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    return std::string("not found (") + std::strerror(errno) + ")";
  if (!S_ISREG(st.st_mode)) return "not a regular file";
  if (::access(path.c_str(), X_OK) != 0) return "not executable";
  return {};
}

std::string selfExecutableDir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return ".";
  std::string p(buf, static_cast<size_t>(n));
  const size_t slash = p.rfind('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return p.substr(0, slash);
}

Supervisor::~Supervisor() {
  for (ChildState& c : children_) {
    if (!c.running()) continue;
    ::kill(-c.pid, SIGKILL);
    int status = 0;
    if (::waitpid(c.pid, &status, 0) == c.pid) c.exit = ExitInfo::fromWaitStatus(status);
  }
}

size_t Supervisor::spawn(const ProcessSpec& spec) {
  if (const std::string why = checkExecutable(spec.path); !why.empty()) {
    throw SpawnError(spec.name + ": cannot run " + spec.path + ": " + why);
  }
  // Everything the child needs is prepared before fork (no allocation after it).
  std::vector<std::string> env_strings;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string kv(*e);
    const std::string key = kv.substr(0, kv.find('='));
    if (spec.env.count(key) == 0) env_strings.push_back(kv);
  }
  for (const auto& [k, v] : spec.env) env_strings.push_back(k + "=" + v);
  std::vector<char*> envp;
  for (std::string& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::vector<std::string> argv_strings;
  argv_strings.push_back(spec.path);
  argv_strings.insert(argv_strings.end(), spec.args.begin(), spec.args.end());
  std::vector<char*> argv;
  for (std::string& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);

  int log_fd = -1;
  if (!spec.log_path.empty()) {
    log_fd = ::open(spec.log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (log_fd < 0) {
      throw SpawnError(spec.name + ": cannot open log " + spec.log_path + ": " +
                       std::strerror(errno));
    }
  }
  int null_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  int err_pipe[2];
  if (::pipe2(err_pipe, O_CLOEXEC) != 0) {
    if (log_fd >= 0) ::close(log_fd);
    if (null_fd >= 0) ::close(null_fd);
    throw SpawnError(spec.name + ": pipe: " + std::strerror(errno));
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    ::close(err_pipe[0]);
    ::close(err_pipe[1]);
    if (log_fd >= 0) ::close(log_fd);
    if (null_fd >= 0) ::close(null_fd);
    throw SpawnError(spec.name + ": fork: " + std::strerror(e));
  }
  if (pid == 0) {
    // Child: only async-signal-safe calls from here on.
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);  // the launcher already died
    // Default signal dispositions and an empty mask for the node.
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    ::signal(SIGPIPE, SIG_DFL);
    if (null_fd >= 0) ::dup2(null_fd, STDIN_FILENO);
    if (log_fd >= 0) {
      ::dup2(log_fd, STDOUT_FILENO);
      ::dup2(log_fd, STDERR_FILENO);
    }
    // No inherited descriptors (the launcher's LCM sockets are not close-on-exec) except the
    // exec-error pipe, which closes itself on a successful exec.
    if (err_pipe[1] > 3) ::close_range(3, static_cast<unsigned>(err_pipe[1]) - 1, 0);
    ::close_range(static_cast<unsigned>(err_pipe[1]) + 1, ~0U, 0);
    ::execve(argv[0], argv.data(), envp.data());
    const int e = errno;
    writeAll(err_pipe[1], &e, sizeof e);
    ::_exit(127);
  }
  ::setpgid(pid, pid);  // also from the parent: no window where a signal misses the group
  ::close(err_pipe[1]);
  if (log_fd >= 0) ::close(log_fd);
  if (null_fd >= 0) ::close(null_fd);
  int child_errno = 0;
  ssize_t n = 0;
  do {
    n = ::read(err_pipe[0], &child_errno, sizeof child_errno);
  } while (n < 0 && errno == EINTR);
  ::close(err_pipe[0]);
  ChildState c;
  c.spec = spec;
  c.pid = pid;
  c.started = now_();
  if (n == static_cast<ssize_t>(sizeof child_errno)) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    throw SpawnError(spec.name + ": cannot execute " + spec.path + ": " +
                     std::strerror(child_errno));
  }
  children_.push_back(std::move(c));
  return children_.size() - 1;
}

std::vector<size_t> Supervisor::poll() {
  std::vector<size_t> reaped;
  for (size_t i = 0; i < children_.size(); ++i) {
    ChildState& c = children_[i];
    if (!c.running()) continue;
    // A stop and a continue may both be pending: read state changes until there is none.
    for (int changes = 0; changes < 4; ++changes) {
      int status = 0;
      const pid_t r = ::waitpid(c.pid, &status, WNOHANG | WUNTRACED | WCONTINUED);
      const auto now = now_();
      if (r == c.pid && WIFSTOPPED(status)) {
        if (!c.paused_since) {
          c.paused_since = now;
          ++c.pauses;
        }
        continue;
      }
      if (r == c.pid && WIFCONTINUED(status)) {
        if (c.paused_since) {
          c.paused_s += std::chrono::duration<double>(now - *c.paused_since).count();
          c.paused_since.reset();
        } else {
          ++c.pauses;  // stopped and continued between two polls
        }
        continue;
      }
      if (r == c.pid) {
        c.exit = ExitInfo::fromWaitStatus(status);
        reaped.push_back(i);
      } else if (r < 0 && errno == ECHILD) {
        c.exit = ExitInfo{};  // reaped elsewhere: unknown end
        reaped.push_back(i);
      }
      break;
    }
    if (c.exit && c.paused_since) {
      c.paused_s += std::chrono::duration<double>(now_() - *c.paused_since).count();
      c.paused_since.reset();
    }
  }
  return reaped;
}

void Supervisor::signal(size_t index, int sig) {
  ChildState& c = children_.at(index);
  if (!c.running()) return;
  if (::kill(-c.pid, sig) != 0) ::kill(c.pid, sig);
}

std::vector<size_t> Supervisor::runningIndices() const {
  std::vector<size_t> r;
  for (size_t i = 0; i < children_.size(); ++i) {
    if (children_[i].running()) r.push_back(i);
  }
  return r;
}

std::optional<size_t> Supervisor::find(const std::string& name) const {
  for (size_t i = children_.size(); i-- > 0;) {
    if (children_[i].spec.name == name) return i;
  }
  return std::nullopt;
}

void Supervisor::stopBegin(const std::vector<size_t>& indices) {
  poll();
  for (size_t i : indices) {
    ChildState& c = children_.at(i);
    if (!c.running()) continue;
    c.stop_requested = true;
    signal(i, SIGINT);
  }
}

bool Supervisor::stopStillRunning(const std::vector<size_t>& indices) {
  poll();
  for (size_t i : indices) {
    if (children_.at(i).running()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      return true;
    }
  }
  return false;
}

void Supervisor::stopKill(const std::vector<size_t>& indices) {
  for (size_t i : indices) {
    ChildState& c = children_.at(i);
    if (!c.running()) continue;
    c.killed = true;
    signal(i, SIGKILL);
    int status = 0;
    // SIGKILL cannot be caught; the wait ends as soon as the kernel tears the process down.
    if (::waitpid(c.pid, &status, 0) == c.pid) c.exit = ExitInfo::fromWaitStatus(status);
  }
}

}  // namespace pplvo::launch
