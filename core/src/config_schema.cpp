#include "pplvo/core/config_schema.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace pplvo::config {

std::string formatNumber(double x) {
  if (std::isnan(x)) return ".nan";
  if (std::isinf(x)) return x > 0 ? ".inf" : "-.inf";
  char buf[64];
  int precision = 1;
  for (; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof(buf), "%.*g", precision, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  const double magnitude = std::fabs(x);
  if (magnitude >= 1e-4 && magnitude < 1e15) {
    // Plain decimal notation with the same significant digits (40.0, not 4e+01).
    const int exponent = static_cast<int>(std::floor(std::log10(magnitude)));
    const int decimals = std::max(0, precision - 1 - exponent);
    char fixed[64];
    std::snprintf(fixed, sizeof(fixed), "%.*f", decimals, x);
    if (std::strtod(fixed, nullptr) == x) std::snprintf(buf, sizeof(buf), "%s", fixed);
  }
  std::string s = buf;
  const auto e = s.find('e');
  if (s.find('.') == std::string::npos) {
    if (e == std::string::npos)
      s += ".0";
    else
      s.insert(e, ".0");
  }
  return s;
}

std::string describe(const Range& r, bool integer) {
  if (r.any()) return "";
  auto num = [&](double x) {
    return integer ? std::to_string(static_cast<long long>(std::llround(x))) : formatNumber(x);
  };
  if (std::isinf(r.hi)) return (r.lo_open ? "> " : ">= ") + num(r.lo);
  if (std::isinf(r.lo)) return (r.hi_open ? "< " : "<= ") + num(r.hi);
  return std::string(r.lo_open ? "(" : "[") + num(r.lo) + ", " + num(r.hi) +
         (r.hi_open ? ")" : "]");
}

}  // namespace pplvo::config
