#pragma once
/// Summary statistics of a list of errors, with numpy's definitions (population std,
/// median = mean of the two middle values for an even count).
#include <vector>

namespace pplvo {
namespace eval {

struct ErrorStats {
  int count = 0;
  double rmse = 0.0;  ///< sqrt(sum(e^2) / n)
  double mean = 0.0;
  double median = 0.0;
  double std = 0.0;  ///< population standard deviation (numpy.std, ddof = 0)
  double min = 0.0;
  double max = 0.0;
};

/// Statistics of `errors` (all zero with count 0 when empty). Units are those of the input.
ErrorStats computeErrorStats(std::vector<double> errors);

/// The same statistics with every figure multiplied by `factor` (unit conversion).
ErrorStats scaled(const ErrorStats& stats, double factor);

}  // namespace eval
}  // namespace pplvo
