#include "pplvo/eval/tum_file.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace pplvo {
namespace eval {
namespace {

// Splits on spaces, commas, tabs (TUM replaces ',' and '\t' by ' ') and also drops '\r'
// (Python's strip() removes it from the last field).
std::vector<std::string> splitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::string current;
  for (char c : line) {
    if (c == ' ' || c == ',' || c == '\t' || c == '\r' || c == '\v' || c == '\f') {
      if (!current.empty()) fields.push_back(current);
      current.clear();
    } else {
      current.push_back(c);
    }
  }
  if (!current.empty()) fields.push_back(current);
  return fields;
}

bool parseDouble(const std::string& text, double* value) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0') return false;
  // Overflow to inf is accepted like Python's float(); underflow to 0 too.
  *value = v;
  return true;
}

// A field quoted in a message: printable ASCII only, at most 40 characters.
std::string printable(const std::string& text) {
  std::string out;
  for (char c : text.substr(0, 40)) {
    out +=
        (static_cast<unsigned char>(c) >= 0x20 && static_cast<unsigned char>(c) < 0x7f) ? c : '?';
  }
  return text.size() > 40 ? out + "..." : out;
}

}  // namespace

TumReadResult parseTumFile(std::istream& in, const std::string& name,
                           const TumReadOptions& options) {
  TumReadResult result;
  result.file.name = name;
  if (!(options.fps >= 0.0) || !std::isfinite(options.fps)) {
    result.error = "invalid fps " + std::to_string(options.fps);
    return result;
  }
  bool all_integer = true;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line[0] == '#') {
      ++result.file.comment_lines;
      continue;
    }
    const std::vector<std::string> fields = splitFields(line);
    if (fields.empty()) continue;
    // A comment after leading blanks: TUM's scripts would fail on float('#'); we skip it.
    if (fields[0][0] == '#') {
      ++result.file.comment_lines;
      continue;
    }
    if (fields.size() < 8) {
      result.error = "'" + name + "' line " + std::to_string(line_no) + ": expected 8 fields " +
                     "'stamp tx ty tz qx qy qz qw', found " + std::to_string(fields.size());
      return result;
    }
    TumRow row;
    row.line_no = line_no;
    double stamp = 0.0;
    if (!parseDouble(fields[0], &stamp)) {
      result.error = "'" + name + "' line " + std::to_string(line_no) + ": stamp '" +
                     printable(fields[0]) + "' is not a number";
      return result;
    }
    for (int k = 0; k < 7; ++k) {
      if (!parseDouble(fields[k + 1], &row.values[k])) {
        result.error = "'" + name + "' line " + std::to_string(line_no) + ": field " +
                       std::to_string(k + 2) + " '" + printable(fields[k + 1]) +
                       "' is not a number";
        return result;
      }
    }
    if (!std::isfinite(stamp) || std::floor(stamp) != stamp) all_integer = false;
    row.stamp_s = options.fps > 0.0 ? stamp / options.fps : stamp;
    result.file.rows.push_back(row);
  }
  if (in.bad()) {
    result.error = "error while reading '" + name + "'";
    return result;
  }
  result.file.all_stamps_integer = all_integer && !result.file.rows.empty();
  result.ok = true;
  return result;
}

TumReadResult readTumFile(const std::string& path, const TumReadOptions& options) {
  std::ifstream in(path);
  if (!in) {
    TumReadResult result;
    result.file.name = path;
    result.error = "cannot read '" + path + "': " + std::strerror(errno);
    return result;
  }
  return parseTumFile(in, path, options);
}

}  // namespace eval
}  // namespace pplvo
