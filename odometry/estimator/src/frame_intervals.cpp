#include "pplvo/estimator/frame_intervals.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace pplvo::estimator {

void FrameIntervals::add(int64_t utime_us) {
  if (last_us_ && utime_us > *last_us_) {
    intervals_us_.push_back(utime_us - *last_us_);
    while (intervals_us_.size() > kIntervals) intervals_us_.pop_front();
    std::vector<int64_t> sorted(intervals_us_.begin(), intervals_us_.end());
    auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
    std::nth_element(sorted.begin(), mid, sorted.end());
    period_s_ = 1e-6 * static_cast<double>(*mid);
  } else if (last_us_) {
    intervals_us_.clear();
    period_s_.reset();
  }
  last_us_ = utime_us;
}

int FrameIntervals::periodsUntil(int64_t utime_us) const {
  if (!period_s_ || !last_us_ || utime_us <= *last_us_) return 1;
  const double periods = 1e-6 * static_cast<double>(utime_us - *last_us_) / *period_s_;
  // A paused source can leave any gap; beyond 10^4 periods (minutes) the count means no more.
  constexpr double kMaxPeriods = 1e4;
  return std::max(1, static_cast<int>(std::lround(std::min(periods, kMaxPeriods))));
}

}  // namespace pplvo::estimator
