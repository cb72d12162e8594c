#pragma once
/// Names of enum values from one table. A module writes its values and their spellings once,
///   constexpr EnumName<DepthModel> kDepthModelNames[] = {
///       {DepthModel::kSensor, "sensor"}, {DepthModel::kCgm, "cgm"}, {DepthModel::kOgm, "ogm"}};
/// and its public parse/toString functions read that table through enumName(), parseEnum() and
/// enumChoices(), so that the parser, the printer and the list of choices cannot disagree.
/// A value may appear more than once (aliases, e.g. "jpeg" and "jpg"): the first entry is its
/// name, every entry parses.
#include <cctype>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace pplvo {

/// One {value, name} row of a table.
template <typename E>
struct EnumName {
  E value;
  const char* name;
};

/// How parseEnum() compares the text with the names (ASCII case folding only).
enum class EnumCase { kExact, kIgnore };

/// The name of `value` (its first row), or `unknown` when the table does not list it.
template <typename E, std::size_t N>
constexpr const char* enumName(const EnumName<E> (&table)[N], E value, const char* unknown = "?") {
  for (const EnumName<E>& row : table) {
    if (row.value == value) return row.name;
  }
  return unknown;
}

namespace detail {
inline bool enumTextEquals(std::string_view a, std::string_view b, EnumCase c) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto x = static_cast<unsigned char>(a[i]), y = static_cast<unsigned char>(b[i]);
    if (c == EnumCase::kIgnore ? std::tolower(x) != std::tolower(y) : x != y) return false;
  }
  return true;
}
}  // namespace detail

/// The value whose name (or alias) is `text`; nullopt when no row matches.
template <typename E, std::size_t N>
std::optional<E> parseEnum(const EnumName<E> (&table)[N], std::string_view text,
                           EnumCase c = EnumCase::kExact) {
  for (const EnumName<E>& row : table) {
    if (detail::enumTextEquals(text, row.name, c)) return row.value;
  }
  return std::nullopt;
}

/// parseEnum() in the out-parameter form of the existing parse functions: *out is set only on
/// success.
template <typename E, std::size_t N>
bool parseEnum(const EnumName<E> (&table)[N], std::string_view text, E* out,
               EnumCase c = EnumCase::kExact) {
  const std::optional<E> v = parseEnum(table, text, c);
  if (v) *out = *v;
  return v.has_value();
}

/// The names of the values in table order, one per value (aliases left out), joined by
/// `separator`: "sensor|cgm|ogm".
template <typename E, std::size_t N>
std::string enumChoices(const EnumName<E> (&table)[N], std::string_view separator = "|") {
  std::string out;
  for (std::size_t i = 0; i < N; ++i) {
    bool alias = false;
    for (std::size_t j = 0; j < i; ++j) alias = alias || table[j].value == table[i].value;
    if (alias) continue;
    if (!out.empty()) out += separator;
    out += table[i].name;
  }
  return out;
}

}  // namespace pplvo
