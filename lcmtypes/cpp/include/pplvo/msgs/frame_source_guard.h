#pragma once
/// Which frames on a frame channel (PPLVO_RGBD) belong to the stream a node follows. LCM
/// carries no sender identity, so a stray publisher on the bus (a forged or misconfigured
/// frame, a second player or camera) would otherwise be taken for the source: a frame with
/// seq = 10^12 made every later frame "old" and derailed the pipeline (issue 39).
///
/// The followed stream is the first source heard. A frame continues it when it has the same
/// `source`, a larger seq at most `max_seq_gap` frames on, and a stamp at most
/// `max_stamp_gap_s` later (never earlier). Anything else is held as a candidate: when a
/// candidate stream continues for `restart_after` frames while the followed one stays silent,
/// the source restarted (a player started again, a camera reconnected) and the candidate is
/// followed from then on; while the followed stream goes on, the candidate is a second
/// source and its frames stay stray. Stray frames are for the caller to count and skip.
#include <cstdint>
#include <optional>
#include <string>

namespace pplvo::msgs {

struct FrameSourceGuardOptions {
  /// Frames lost in a row that still count as a loss of the same stream (33 s at 30 Hz).
  int64_t max_seq_gap = 1000;
  /// Stream time between two consecutive frames of the stream (s).
  double max_stamp_gap_s = 60.0;
  /// Consecutive frames of a candidate stream, with the followed one silent, that make it the
  /// followed one (a restarted source loses that many frames, minus one).
  int restart_after = 3;
};

enum class FrameVerdict {
  kFollow,   ///< continues the followed stream (or is its first frame)
  kRestart,  ///< the source restarted: this frame starts the followed stream anew
  kStray,    ///< not of the followed stream: skip it
};

class FrameSourceGuard {
 public:
  explicit FrameSourceGuard(const FrameSourceGuardOptions& options = {}) : options_(options) {}

  /// Judges one frame; `why` (if given) says what made a stray frame stray.
  FrameVerdict judge(const std::string& source, int64_t seq, int64_t utime,
                     std::string* why = nullptr);

  /// Whether a frame would continue the followed stream (or start it), without judging it:
  /// for a frame whose payload turned out bad, whose seq still counts as received.
  bool wouldFollow(const std::string& source, int64_t seq, int64_t utime) const {
    return !followed_ || continues(*followed_, source, seq, utime, nullptr);
  }

  /// Frames judged stray so far.
  int64_t strayFrames() const { return stray_; }

 private:
  struct Stream {
    std::string source;
    int64_t seq = -1;
    int64_t utime = 0;
    int frames = 0;  ///< frames in a row (candidate)
  };
  /// Whether (source, seq, utime) is the next frame of `s`; otherwise `why` says what breaks it.
  bool continues(const Stream& s, const std::string& source, int64_t seq, int64_t utime,
                 std::string* why) const;

  FrameSourceGuardOptions options_;
  std::optional<Stream> followed_;
  std::optional<Stream> candidate_;
  /// The followed stream sent a frame since the candidate appeared: the candidate is a second
  /// source, not a restart.
  bool followed_alive_ = false;
  int64_t stray_ = 0;
};

}  // namespace pplvo::msgs
