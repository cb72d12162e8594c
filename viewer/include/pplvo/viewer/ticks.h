#pragma once
/// Axis ticks shared by the live panels and pplvo-plot.
#include <string>
#include <vector>

namespace pplvo {
namespace viewer {

/// "Nice" tick values (steps of 1, 2 or 5 x 10^k) inside [lo, hi], about `target` of them.
/// Returns an empty list when the range is not finite or empty.
std::vector<double> niceTicks(double lo, double hi, int target = 6);

/// Decimals needed to print the ticks distinctly (0..6).
int tickDecimals(const std::vector<double>& ticks);

/// A tick label with `decimals` decimals ("-0" printed as "0").
std::string formatTick(double value, int decimals);

}  // namespace viewer
}  // namespace pplvo
