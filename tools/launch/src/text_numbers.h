#pragma once
// Numbers in command lines and URLs (pplvo_launch's own: "3", "0.25", "1e3" whole, nothing
// trailing), and doubles back to text for the children's command lines.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace pplvo::launch::detail {

inline bool toDouble(const std::string& t, double* out) {
  try {
    size_t end = 0;
    const double v = std::stod(t, &end);
    if (end != t.size() || !std::isfinite(v)) return false;
    *out = v;
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

inline bool toInt(const std::string& t, int64_t* out) {
  try {
    size_t end = 0;
    const long long v = std::stoll(t, &end);
    if (end != t.size()) return false;
    *out = v;
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

inline std::string fmtDouble(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace pplvo::launch::detail
