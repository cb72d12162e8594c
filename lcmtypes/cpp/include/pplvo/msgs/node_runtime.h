#pragma once
/// What every pplvo process shares: LCM construction, clean shutdown on SIGINT/SIGTERM, a
/// handle loop with a periodic callback, and a guard that keeps exceptions inside handlers
/// (in LCM 1.3.1 an exception leaving a handler leaves lcm_handle's mutex locked).
#include <cstdio>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <optional>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <string>
#include <utility>

#include "pplvo/core/stage_timer.h"
#include "pplvo/msgs/bus.h"
#include "pplvo/msgs/convert.h"
#include "pplvo/msgs/frame_ledger.h"
#include "pplvo/msgs/frame_source_guard.h"

namespace pplvo::msgs {

/// Installs SIGINT/SIGTERM handlers that request shutdown (idempotent).
void installShutdownHandlers();
bool shutdownRequested();
void requestShutdown();

/// Opens LCM at `url` (empty: $LCM_DEFAULT_URL or LCM's default). Throws std::runtime_error
/// naming the URL when LCM cannot be initialised.
std::unique_ptr<lcm::LCM> openLcm(const std::string& url);

/// Handles messages (on every instance of `bus` this process subscribed on) until shutdown is
/// requested or `done()` returns true, calling `periodic` about every `period_s` seconds.
/// Each wait for a message lasts at most `wait_ms()` ms (50 without it): a node whose worker
/// finishes between messages asks for short waits so that `done()` sees the result soon.
/// Returns the number of handled messages.
int64_t spin(const Bus& bus, const std::function<bool()>& done,
             const std::function<void()>& periodic, double period_s = 1.0,
             const std::function<int()>& wait_ms = {});
/// spin()'s wait when the node asks for none (ms).
constexpr int kSpinWaitMs = 50;
/// spin() on any wait for messages: `handle_timeout(ms)` waits at most ms for one and returns
/// what lcm::LCM::handleTimeout returns (tests pass a fake that records the waits, so that
/// nothing depends on the machine's load).
int64_t spinOn(const std::function<int(int timeout_ms)>& handle_timeout,
               const std::function<bool()>& done, const std::function<void()>& periodic,
               double period_s = 1.0, const std::function<int()>& wait_ms = {});

/// Notes the arrival of frame `seq` from a source that numbers its published frames
/// consecutively (player, camera). A jump means frames were lost on the way (the socket buffer
/// overflowed: this node is slower than its input, or the network dropped them): they are
/// counted in frames_lost (they never reached the node), with a warning. A smaller seq (a
/// restarted source) is not a loss. Returns the number of frames lost before this one.
inline int64_t noteFrameSequence(NodeCounters& counters, int64_t seq) {
  int64_t lost = 0;
  if (counters.last_seq >= 0 && seq > counters.last_seq + 1) {
    lost = seq - counters.last_seq - 1;
    counters.frames_lost += lost;
    counters.last_warning = std::to_string(lost) + " frame(s) lost before frame " +
                            std::to_string(seq) +
                            " reached this node (input faster than the node, or network loss)";
  }
  counters.last_seq = seq;
  return lost;
}

/// Remembers `warning` as the node's last one and prints it to stderr, rate-limited by the
/// node's skips and errors so far (the first few, then every 100th). Count before calling.
void reportProblem(NodeCounters& counters, const std::string& node, const std::string& warning);

namespace detail {

/// The exception handling guarded() and guardedFrame() share: `bad_input()` counts a
/// MessageError and returns how the report names it, `failed()` does what an error needs
/// besides being counted; then the problem is reported. Never throws.
template <typename Body, typename BadInput, typename Failed>
bool runGuarded(NodeCounters& counters, const char* node, Body&& body, BadInput&& bad_input,
                Failed&& failed) noexcept {
  const char* kind = "error";
  std::string what;
  try {
    body();
    return true;
  } catch (const MessageError& e) {
    kind = bad_input();
    what = e.what();
  } catch (const std::exception& e) {
    ++counters.errors;
    failed();
    what = e.what();
  } catch (...) {
    ++counters.errors;
    failed();
    what = "unknown exception";
  }
  reportProblem(counters, node, std::string(kind) + ": " + what);
  return false;
}

}  // namespace detail

/// Runs `body`; any exception is counted in `counters` (in messages_skipped when it is a
/// MessageError: a bad message that served no frame; as an error otherwise), remembered as the
/// last warning and printed (rate-limited to the first few and then every 100th). Never throws.
/// For the handler of a node's frames use guardedFrame(), which closes the frame instead.
template <typename Body>
bool guarded(NodeCounters& counters, const char* node, Body&& body) noexcept {
  return detail::runGuarded(
      counters, node, std::forward<Body>(body),
      [&] {
        ++counters.messages_skipped;
        return "skipped bad message";
      },
      [] {});
}

/// guarded() for the step that handles frame `seq` of the node's frame stream, after
/// `ledger.arrived(seq)`: a MessageError skips that frame (bad input), any other exception
/// counts an error and drops it, when the step left it open. Never throws.
template <typename Body>
bool guardedFrame(FrameLedger& ledger, NodeCounters& counters, const char* node, int64_t seq,
                  Body&& body) noexcept {
  return detail::runGuarded(
      counters, node, std::forward<Body>(body),
      [&] {
        if (!ledger.skipped(seq)) ++counters.messages_skipped;
        return "skipped bad frame";
      },
      [&] { ledger.dropped(seq); });
}

/// The step every node that reads frames (PPLVO_RGBD: depth filter, frontend) runs on one,
/// after `ledger.arrived(msg.seq)`: `decode()` decodes and checks it (a MessageError is a
/// counted skip in guardedFrame(); a bad frame of the followed stream still arrived, so it is
/// not counted as lost), then a valid frame of a stray publisher (a forged seq or stamp, a
/// second source; FrameSourceGuard) is skipped in the ledger and counted in the `stray_frame`
/// stage, before it can make the followed stream's frames look old. Returns the decoded frame,
/// or nullopt for a stray one.
template <class Decode>
auto admitFrame(FrameSourceGuard& guard, FrameLedger& ledger, NodeCounters& counters,
                StageTimings& timings, const std::string& node,
                const pplvo_msgs::rgbd_frame_t& msg, Decode&& decode)
    -> std::optional<decltype(decode())> {
  std::optional<decltype(decode())> frame;
  try {
    frame = decode();
  } catch (const MessageError&) {
    if (guard.wouldFollow(msg.source, msg.seq, msg.utime)) noteFrameSequence(counters, msg.seq);
    throw;
  }
  std::string why;
  if (guard.judge(msg.source, msg.seq, msg.utime, &why) == FrameVerdict::kStray) {
    ledger.skipped(msg.seq);
    timings.add("stray_frame", 0.0);
    reportProblem(counters, node, "stray frame " + std::to_string(msg.seq) + " skipped: " + why);
    return std::nullopt;
  }
  noteFrameSequence(counters, msg.seq);
  return frame;
}

}  // namespace pplvo::msgs
