#pragma once
/// The vocabulary of a configuration schema, for the options structs of every library: a
/// value Range, the text of numbers and enums. No YAML and no I/O here, so a library can
/// declare its schema beside its options struct without any dependency:
///
///   struct CgmOptions { int threads = 1; ... };          // defaults: written once, here
///   template <class V> void visit(V& v, CgmOptions& o) {  // names, docs, ranges: once, here
///     v.field("threads", o.threads, "threads over bands of rows", config::atLeast(1));
///   }
///
/// A visitor V provides
///   field(key, T& value, doc, Range = {})   T: bool, int, int64_t, uint64_t, double,
///                                           std::string, an enum with EnumText<E>, or a type
///                                           with configText()/parseConfigValue() (ADL)
///   section(key, doc, body)                 a nested map whose fields `body` lists
///   forbid(key, reason)                     a key that must not appear there
/// The visitors (YAML reader, range validator, documented writer, flattener) are in
/// pplvo/core/config_visitor.h; docs/architecture.md follows one parameter end to end.
#include <cmath>
#include <limits>
#include <string>

namespace pplvo::config {

/// Allowed values of a number (checked by the validator, shown in the written comments).
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;

  bool any() const { return std::isinf(lo) && std::isinf(hi); }
  bool contains(double x) const {
    if (std::isnan(x)) return false;
    const bool above = lo_open ? x > lo : x >= lo;
    const bool below = hi_open ? x < hi : x <= hi;
    return above && below;
  }
};

inline Range anyValue() { return {}; }
/// x >= lo
inline Range atLeast(double lo) {
  return {lo, std::numeric_limits<double>::infinity(), false, false};
}
/// x > lo
inline Range greaterThan(double lo) {
  return {lo, std::numeric_limits<double>::infinity(), true, false};
}
/// x > 0
inline Range positive() { return greaterThan(0.0); }
/// lo <= x <= hi
inline Range between(double lo, double hi) { return {lo, hi, false, false}; }
/// lo < x <= hi
inline Range openClosed(double lo, double hi) { return {lo, hi, true, false}; }

/// The shortest %g text that reads back to the same double, always with a '.' so that every
/// YAML reader sees a float (0.02, 1.0e-05, 40.0); .nan, .inf, -.inf.
std::string formatNumber(double x);

/// "> 0.0", ">= 1", "[0.0, 1.0]", "(0.0, 180.0]"; integer bounds for integer fields; "" for
/// anyValue().
std::string describe(const Range& r, bool integer);

/// Text of an enum option. Specialise beside the enum's options schema:
///   template <> struct EnumText<MyEnum> {
///     static bool parse(const std::string& text, MyEnum* out);  // false: unknown text
///     static std::string name(MyEnum e);
///     static const char* choices();                             // "a, b, c"
///   };
template <typename E>
struct EnumText;

/// A command-line option that stands for one configuration key: "--window N" is
/// "--set depth_filter.ogm.max_window=N" (same parsing, same range check).
struct Shortcut {
  std::string flag;   ///< "--window"
  std::string key;    ///< "depth_filter.ogm.max_window"
  std::string usage;  ///< usage text after the flag ("N   O-GM sliding window, frames")
};

}  // namespace pplvo::config
