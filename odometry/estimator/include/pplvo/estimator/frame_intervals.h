#pragma once
/// The camera's frame period, read from the frame stamps, and how many periods a frame comes
/// after the last one: a dropped frame, a lossy link or a dataset played at every third frame
/// shows in the stamps, and the velocity model's prediction and its process noise must cover
/// the time that passed, not one nominal frame.
#include <cstdint>
#include <deque>
#include <optional>

namespace pplvo::estimator {

class FrameIntervals {
 public:
  /// Records the stamp (microseconds) of a frame. A stamp not after the last one (a restarted
  /// stream, a source without stamps) starts the record again.
  void add(int64_t utime_us);

  /// The stream's frame period: the median of the last intervals (seconds), which stamp jitter
  /// and the odd dropped frame leave alone; nullopt before the first interval.
  std::optional<double> period_s() const { return period_s_; }
  /// Whole periods between the last recorded frame and a frame stamped `utime_us`:
  /// max(1, round(dt / period)); 1 while either is unknown.
  int periodsUntil(int64_t utime_us) const;

 private:
  static constexpr size_t kIntervals = 31;  ///< odd: the median is one of them
  std::optional<int64_t> last_us_;
  std::deque<int64_t> intervals_us_;
  std::optional<double> period_s_;  ///< their median, updated by add()
};

}  // namespace pplvo::estimator
