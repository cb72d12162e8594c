#include "pplvo/msgs/frame_source_guard.h"

namespace pplvo::msgs {

bool FrameSourceGuard::continues(const Stream& s, const std::string& source, int64_t seq,
                                 int64_t utime, std::string* why) const {
  auto fail = [&](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  if (source != s.source) return fail("another source '" + source + "'");
  if (seq <= s.seq) {
    return fail("seq " + std::to_string(seq) + " not after " + std::to_string(s.seq));
  }
  if (seq - s.seq - 1 > options_.max_seq_gap) {
    return fail("seq " + std::to_string(seq) + " jumps " + std::to_string(seq - s.seq) +
                " frames after " + std::to_string(s.seq));
  }
  const int64_t dt = utime - s.utime;
  if (dt < 0) return fail("stamp earlier than the previous frame's");
  if (static_cast<double>(dt) > options_.max_stamp_gap_s * 1e6) {
    return fail("stamp " + std::to_string(dt / 1000000) + " s after the previous frame's");
  }
  return true;
}

FrameVerdict FrameSourceGuard::judge(const std::string& source, int64_t seq, int64_t utime,
                                     std::string* why) {
  if (!followed_) {
    followed_ = Stream{source, seq, utime, 1};
    return FrameVerdict::kFollow;
  }
  std::string reason;
  if (continues(*followed_, source, seq, utime, &reason)) {
    *followed_ = Stream{source, seq, utime, followed_->frames + 1};
    if (candidate_) followed_alive_ = true;
    return FrameVerdict::kFollow;
  }
  // Not the followed stream: a restart of the source, or a stray publisher.
  if (candidate_ && continues(*candidate_, source, seq, utime, nullptr)) {
    *candidate_ = Stream{source, seq, utime, candidate_->frames + 1};
  } else {
    candidate_ = Stream{source, seq, utime, 1};
    followed_alive_ = false;
  }
  if (!followed_alive_ && candidate_->frames >= options_.restart_after) {
    followed_ = *candidate_;
    candidate_.reset();
    return FrameVerdict::kRestart;
  }
  ++stray_;
  if (why) {
    *why = reason + (followed_alive_ ? " (a second source on the channel)" : "");
  }
  return FrameVerdict::kStray;
}

}  // namespace pplvo::msgs
