#pragma once
/// Reading trajectory files the way the TUM RGB-D benchmark scripts do (evaluate_ate.py's
/// read_file_list and evaluate_rpe.py's read_trajectory). See docs/evaluation.md.
#include <array>
#include <iosfwd>
#include <string>
#include <vector>

namespace pplvo {
namespace eval {

/// One data line: `stamp tx ty tz qx qy qz qw` (camera-to-world, T_w_c), fields separated by
/// any mix of spaces, commas and tabs. Fields after the eighth are ignored (as TUM does).
struct TumRow {
  double stamp_s = 0.0;            ///< first column in seconds (divided by fps when fps > 0)
  std::array<double, 7> values{};  ///< tx ty tz [m], qx qy qz qw (not normalised)
  int line_no = 0;                 ///< 1-based line number in the file
};

struct TumReadOptions {
  /// > 0: the first column is a frame index (ICL-NUIM) and stamp_s = index / fps.
  /// 0: the first column is already in seconds.
  double fps = 0.0;
};

/// A whole file, rows in file order (duplicate stamps kept here; the evaluators apply TUM's
/// dict semantics: the last line with a given stamp wins).
struct TumFile {
  std::string name;  ///< path or label, used in messages
  std::vector<TumRow> rows;
  int comment_lines = 0;            ///< lines whose first character is '#'
  bool all_stamps_integer = false;  ///< every stamp as written is an integer (before fps)
};

/// Result of reading: `ok == false` with a message naming the file and line on failure
/// (unreadable file, a line with 1..7 fields, a field that is not a number).
struct TumReadResult {
  bool ok = false;
  std::string error;
  TumFile file;
};

/// Parses TUM text. `name` is only used in messages.
TumReadResult parseTumFile(std::istream& in, const std::string& name,
                           const TumReadOptions& options = {});
/// Reads a TUM file from disk; an unreadable file gives ok == false with the name and reason.
TumReadResult readTumFile(const std::string& path, const TumReadOptions& options = {});

}  // namespace eval
}  // namespace pplvo
