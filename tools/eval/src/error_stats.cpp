#include "pplvo/eval/error_stats.h"

#include <algorithm>
#include <cmath>

namespace pplvo {
namespace eval {

ErrorStats computeErrorStats(std::vector<double> errors) {
  ErrorStats s;
  s.count = static_cast<int>(errors.size());
  if (errors.empty()) return s;
  const double n = static_cast<double>(errors.size());
  double sum = 0.0, sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  s.rmse = std::sqrt(sum_sq / n);
  s.mean = sum / n;
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  std::sort(errors.begin(), errors.end());
  s.min = errors.front();
  s.max = errors.back();
  const std::size_t m = errors.size() / 2;
  s.median = errors.size() % 2 == 1 ? errors[m] : 0.5 * (errors[m - 1] + errors[m]);
  return s;
}

ErrorStats scaled(const ErrorStats& stats, double factor) {
  ErrorStats s = stats;
  s.rmse *= factor;
  s.mean *= factor;
  s.median *= factor;
  s.std *= std::abs(factor);
  s.min *= factor;
  s.max *= factor;
  return s;
}

}  // namespace eval
}  // namespace pplvo
