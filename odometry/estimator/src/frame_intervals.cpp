#include "pplvo/estimator/frame_intervals.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace pplvo::estimator {

void FrameIntervals::add(int64_t utime_us) {
  if (last_us_ && utime_us > *last_us_) {
    intervals_us_.push_back(utime_us - *last_us_);
    while (intervals_us_.size() > kIntervals) intervals_us_.pop_front();
  } else if (last_us_) {
    intervals_us_.clear();
  }
  last_us_ = utime_us;
}

void FrameIntervals::reset() {
  last_us_.reset();
  intervals_us_.clear();
}

std::optional<double> FrameIntervals::period_s() const {
  if (intervals_us_.empty()) return std::nullopt;
  std::vector<int64_t> sorted(intervals_us_.begin(), intervals_us_.end());
  auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), mid, sorted.end());
  return 1e-6 * static_cast<double>(*mid);
}

int FrameIntervals::periodsUntil(int64_t utime_us) const {
  const std::optional<double> period = period_s();
  if (!period || !last_us_ || utime_us <= *last_us_) return 1;
  const double periods = 1e-6 * static_cast<double>(utime_us - *last_us_) / *period;
  // A paused source can leave any gap; beyond a minute the count means nothing more.
  constexpr double kMaxPeriods = 1e4;
  return std::max(1, static_cast<int>(std::lround(std::min(periods, kMaxPeriods))));
}

}  // namespace pplvo::estimator
