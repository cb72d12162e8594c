#include "pplvo/msgs/node_runtime.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <stdexcept>

namespace pplvo::msgs {
namespace {
// Signal handlers can only reach process-wide state; this flag is the one global of the nodes.
std::atomic<bool> g_shutdown{false};
extern "C" void onSignal(int) { g_shutdown.store(true); }
}  // namespace

void installShutdownHandlers() {
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool shutdownRequested() { return g_shutdown.load(); }
void requestShutdown() { g_shutdown.store(true); }

std::unique_ptr<lcm::LCM> openLcm(const std::string& url) {
  auto lcm = std::make_unique<lcm::LCM>(url);
  if (!lcm->good()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    throw std::runtime_error("cannot initialise LCM at '" +
                             (url.empty() ? std::string(env ? env : "(LCM default)") : url) +
                             "': check the URL, and for udpm that a multicast route exists "
                             "(see docs/networking.md)");
  }
  return lcm;
}

void reportProblem(NodeCounters& counters, const std::string& node, const std::string& warning) {
  counters.last_warning = warning;
  const int64_t n = counters.errors + counters.frames_skipped + counters.messages_skipped;
  if (n <= 5 || n % 100 == 0) {
    std::fprintf(stderr, "[%s] %s (%lld so far)\n", node.c_str(), warning.c_str(),
                 static_cast<long long>(n));
  }
}

namespace detail {

void countUndecodable(NodeCounters& counters, const std::string& node, const std::string& channel,
                      const std::string& error) {
  ++counters.messages_skipped;  // no frame to attribute it to: its seq is unreadable
  reportProblem(counters, node, "skipped undecodable packet on " + channel + ": " + error);
}

void countEscaped(NodeCounters& counters, const std::string& node, const std::string& what) {
  ++counters.errors;
  reportProblem(counters, node, "error: " + what);
}

}  // namespace detail

int64_t spin(const Bus& bus, const std::function<bool()>& done,
             const std::function<void()>& periodic, double period_s,
             const std::function<int()>& wait_ms) {
  return spinOn([&bus](int timeout_ms) { return bus.handleTimeout(timeout_ms); }, done, periodic,
                period_s, wait_ms);
}

int64_t spinOn(const std::function<int(int timeout_ms)>& handle_timeout,
               const std::function<bool()>& done, const std::function<void()>& periodic,
               double period_s, const std::function<int()>& wait_ms) {
  using Clock = std::chrono::steady_clock;
  auto next = Clock::now() + std::chrono::duration<double>(period_s);
  int64_t handled = 0;
  while (!shutdownRequested() && !(done && done())) {
    const int rc = handle_timeout(wait_ms ? std::max(0, wait_ms()) : kSpinWaitMs);
    if (rc > 0) ++handled;
    // A signal (Ctrl-C) interrupts the wait with EINTR: that is a shutdown, not a failure.
    if (rc < 0) {
      if (shutdownRequested()) break;
      throw std::runtime_error("LCM handle failed");
    }
    if (periodic && Clock::now() >= next) {
      periodic();
      next = Clock::now() + std::chrono::duration<double>(period_s);
    }
  }
  if (periodic) periodic();
  return handled;
}

}  // namespace pplvo::msgs
