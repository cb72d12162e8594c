// Index files and association (TUM RGB-D layout).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "pplvo/dataset/dataset.h"

namespace fs = std::filesystem;

namespace pplvo::dataset {
namespace {

bool parseDouble(const std::string& s, double& out) {
  if (s.empty()) return false;
  char* end = nullptr;
  out = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(out);
}

/// True when the relative path has a directory component named `name` (e.g. "depth/0.png").
bool underDir(const std::string& rel, const std::string& name) {
  const fs::path p = fs::path(rel).lexically_normal();
  for (auto it = p.begin(); it != p.end(); ++it) {
    auto next = it;
    ++next;
    if (next == p.end()) break;  // last component is the file name
    if (it->string() == name) return true;
  }
  return false;
}

std::string joinPath(const std::string& dir, const std::string& rel) {
  return (fs::path(dir) / fs::path(rel)).lexically_normal().string();
}

bool fileExists(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

/// Integer frame indices (ICL-NUIM): every stamp integral, sorted steps >= 1, smallest step 1.
bool looksLikeFrameIndices(std::vector<double> stamps) {
  if (stamps.empty()) return false;
  for (double s : stamps) {
    if (s != std::floor(s) || s < 0) return false;
  }
  if (stamps.size() == 1) return true;
  std::sort(stamps.begin(), stamps.end());
  double min_step = 1e300;
  for (size_t i = 1; i < stamps.size(); ++i) {
    const double step = stamps[i] - stamps[i - 1];
    if (step < 1.0) return false;
    min_step = std::min(min_step, step);
  }
  return min_step == 1.0;
}

/// Entries listed after one with a later stamp.
int countOutOfOrder(const std::vector<double>& listed) {
  int n = 0;
  for (size_t i = 1; i < listed.size(); ++i) n += listed[i] < listed[i - 1] ? 1 : 0;
  return n;
}

/// Sorts the frames by colour stamp (stable: equal stamps keep their listed order) and drops
/// every frame whose stamp an earlier one has, counting them.
void sortAndDeduplicate(std::vector<DatasetEntry>* entries, IndexSummary* sum) {
  std::stable_sort(entries->begin(), entries->end(),
                   [](const DatasetEntry& a, const DatasetEntry& b) { return a.stamp < b.stamp; });
  std::vector<DatasetEntry> kept;
  kept.reserve(entries->size());
  for (DatasetEntry& e : *entries) {
    if (!kept.empty() && kept.back().stamp == e.stamp) {
      if (sum->duplicate_stamps++ == 0) sum->first_duplicate = e.stamp_text;
      continue;
    }
    kept.push_back(std::move(e));
  }
  *entries = std::move(kept);
}

/// The next line that holds data: CR stripped, blank and '#' comment lines skipped.
bool nextDataLine(std::istream& in, std::string& line) {
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    return true;
  }
  return false;
}

}  // namespace

IndexFile parseIndexFile(std::istream& in) {
  IndexFile out;
  std::string line;
  while (nextDataLine(in, line)) {
    std::istringstream ss(line);
    IndexEntry e;
    if (!(ss >> e.stamp_text >> e.path) || !parseDouble(e.stamp_text, e.stamp)) {
      ++out.malformed_lines;
      continue;
    }
    out.entries.push_back(std::move(e));
  }
  return out;
}

std::vector<std::pair<size_t, size_t>> associateStamps(const std::vector<double>& a,
                                                       const std::vector<double>& b,
                                                       double max_difference_s) {
  // Candidates within the window, found on sorted copies (O((n + m) log) rather than O(n m)).
  std::vector<size_t> ia(a.size()), ib(b.size());
  for (size_t i = 0; i < ia.size(); ++i) ia[i] = i;
  for (size_t i = 0; i < ib.size(); ++i) ib[i] = i;
  std::sort(ia.begin(), ia.end(), [&](size_t x, size_t y) { return a[x] < a[y]; });
  std::sort(ib.begin(), ib.end(), [&](size_t x, size_t y) { return b[x] < b[y]; });
  struct Candidate {
    double diff;
    size_t i, j;
  };
  std::vector<Candidate> cand;
  size_t lo = 0;
  for (size_t x : ia) {
    while (lo < ib.size() && b[ib[lo]] <= a[x] - max_difference_s) ++lo;
    for (size_t k = lo; k < ib.size() && b[ib[k]] < a[x] + max_difference_s; ++k) {
      const double d = std::abs(a[x] - b[ib[k]]);
      if (d < max_difference_s) cand.push_back({d, x, ib[k]});
    }
  }
  std::sort(cand.begin(), cand.end(), [&](const Candidate& p, const Candidate& q) {
    if (p.diff != q.diff) return p.diff < q.diff;
    if (a[p.i] != a[q.i]) return a[p.i] < a[q.i];
    return b[p.j] < b[q.j];
  });
  std::vector<char> used_a(a.size(), 0), used_b(b.size(), 0);
  std::vector<std::pair<size_t, size_t>> out;
  for (const auto& c : cand) {
    if (used_a[c.i] || used_b[c.j]) continue;
    used_a[c.i] = used_b[c.j] = 1;
    out.emplace_back(c.i, c.j);
  }
  std::sort(out.begin(), out.end(), [&](const auto& p, const auto& q) {
    return a[p.first] < a[q.first] || (a[p.first] == a[q.first] && p.first < q.first);
  });
  return out;
}

std::optional<int64_t> stampTextToUtime(const std::string& text) {
  if (text.empty()) return std::nullopt;
  int64_t whole = 0;
  int64_t frac_us = 0;
  size_t i = 0;
  bool any_digit = false;
  for (; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i) {
    if (whole > (INT64_MAX / 10 - 10) / 1000000) return std::nullopt;
    whole = whole * 10 + (text[i] - '0');
    any_digit = true;
  }
  if (i < text.size()) {
    if (text[i] != '.') return std::nullopt;
    ++i;
    int digits = 0;
    bool round_up = false;
    for (; i < text.size(); ++i) {
      const char ch = text[i];
      if (!std::isdigit(static_cast<unsigned char>(ch))) return std::nullopt;
      any_digit = true;
      if (digits < 6) {
        frac_us = frac_us * 10 + (ch - '0');
      } else if (digits == 6) {
        round_up = ch >= '5';
      }
      ++digits;
    }
    for (int d = digits; d < 6; ++d) frac_us *= 10;
    if (round_up) ++frac_us;
  }
  if (!any_digit) return std::nullopt;
  return whole * 1000000 + frac_us;
}

std::string IndexSummary::text() const {
  std::ostringstream s;
  s << source;
  if (!column_order.empty()) s << " (" << column_order << ")";
  s << ": " << listed << " entries";
  if (source != "associations.txt") s << " in rgb.txt, " << listed_depth << " in depth.txt";
  s << "; dropped " << missing_rgb_files << " missing colour and " << missing_depth_files
    << " missing depth files";
  if (!first_missing.empty()) s << " (first: " << first_missing << ")";
  if (unassociated_rgb > 0) s << "; " << unassociated_rgb << " colour images without depth";
  if (malformed_lines > 0) s << "; " << malformed_lines << " malformed lines ignored";
  if (unlisted_rgb_files > 0) s << "; " << unlisted_rgb_files << " files in rgb/ not listed";
  if (out_of_order > 0) s << "; " << out_of_order << " lines out of stamp order (sorted)";
  if (duplicate_stamps > 0) {
    s << "; " << duplicate_stamps << " duplicate stamps dropped (first: " << first_duplicate << ")";
  }
  if (index_stamps) s << "; stamps are frame indices at " << index_frame_rate_hz << " Hz";
  return s.str();
}

namespace {

/// What the index lines said beyond the entries: the colour files they mention (normalised
/// paths) and every listed colour stamp, in file order.
struct IndexListing {
  std::set<std::string> mentioned;
  std::vector<double> listed_stamps;
};

void noteMissing(IndexSummary& sum, const std::string& path) {
  if (sum.first_missing.empty()) sum.first_missing = path;
}

/// How the associations file ordered its columns, for the summary.
std::string columnOrderText(int n_rgb_first, int n_depth_first, int n_assumed) {
  const int kinds = (n_rgb_first > 0) + (n_depth_first > 0) + (n_assumed > 0);
  if (kinds > 1) {
    return "mixed (" + std::to_string(n_rgb_first) + " rgb-first, " +
           std::to_string(n_depth_first) + " depth-first, " + std::to_string(n_assumed) +
           " assumed rgb-first)";
  }
  if (n_depth_first > 0) return "depth-first";
  if (n_assumed > 0) return "rgb-first (assumed)";
  return "rgb-first";
}

/// associations.txt: one colour-depth pair a line, in either column order (the paths tell
/// which); pairs whose files are absent are counted and dropped.
void readAssociations(const std::string& dir, const std::string& assoc_path, DatasetIndex& index,
                      IndexListing& listing) {
  IndexSummary& sum = index.summary;
  sum.source = "associations.txt";
  std::ifstream in(assoc_path);
  if (!in) throw DatasetError("cannot read " + assoc_path);
  int n_rgb_first = 0, n_depth_first = 0, n_assumed = 0;
  std::string line;
  while (nextDataLine(in, line)) {
    std::istringstream ss(line);
    std::string t1, p1, t2, p2;
    double s1 = 0, s2 = 0;
    if (!(ss >> t1 >> p1 >> t2 >> p2) || !parseDouble(t1, s1) || !parseDouble(t2, s2)) {
      ++sum.malformed_lines;
      continue;
    }
    ++sum.listed;
    const bool depth_first = (underDir(p1, "depth") && !underDir(p2, "depth")) ||
                             (underDir(p2, "rgb") && !underDir(p1, "rgb"));
    const bool rgb_first = (underDir(p1, "rgb") && !underDir(p1, "depth")) ||
                           (underDir(p2, "depth") && !underDir(p2, "rgb"));
    if (depth_first && !rgb_first) {
      ++n_depth_first;
      std::swap(t1, t2);
      std::swap(p1, p2);
      std::swap(s1, s2);
    } else if (rgb_first) {
      ++n_rgb_first;
    } else {
      ++n_assumed;  // neither path says which it is: TUM's order (rgb first)
    }
    DatasetEntry e;
    e.stamp_text = t1;
    e.stamp = s1;
    e.depth_stamp_text = t2;
    e.rgb_path = joinPath(dir, p1);
    e.depth_path = joinPath(dir, p2);
    listing.listed_stamps.push_back(s1);
    listing.mentioned.insert(e.rgb_path);
    const bool rgb_ok = fileExists(e.rgb_path);
    const bool depth_ok = fileExists(e.depth_path);
    if (!rgb_ok) {
      ++sum.missing_rgb_files;
      noteMissing(sum, e.rgb_path);
    }
    if (!depth_ok) {
      ++sum.missing_depth_files;
      noteMissing(sum, e.depth_path);
    }
    if (rgb_ok && depth_ok) index.entries.push_back(std::move(e));
  }
  sum.column_order = columnOrderText(n_rgb_first, n_depth_first, n_assumed);
}

/// rgb.txt + depth.txt: each list read on its own, then colour and depth stamps associated
/// within options.max_association_dt_s.
void readRgbAndDepthLists(const std::string& dir, const std::string& rgb_path,
                          const std::string& depth_path, const DatasetOptions& options,
                          DatasetIndex& index, IndexListing& listing) {
  IndexSummary& sum = index.summary;
  sum.source = "rgb.txt+depth.txt";
  std::ifstream rin(rgb_path), din(depth_path);
  if (!rin) throw DatasetError("cannot read " + rgb_path);
  if (!din) throw DatasetError("cannot read " + depth_path);
  const IndexFile rgb = parseIndexFile(rin);
  const IndexFile depth = parseIndexFile(din);
  sum.listed = static_cast<int>(rgb.entries.size());
  sum.listed_depth = static_cast<int>(depth.entries.size());
  sum.malformed_lines = rgb.malformed_lines + depth.malformed_lines;
  // Drop entries whose files are absent before associating (TUM's depth.txt lists more
  // depth maps than an excerpt holds; a missing one must not take a colour image's pair).
  std::vector<IndexEntry> rgb_ok, depth_ok;
  for (const auto& e : rgb.entries) {
    listing.listed_stamps.push_back(e.stamp);
    const std::string p = joinPath(dir, e.path);
    listing.mentioned.insert(p);
    if (fileExists(p)) {
      rgb_ok.push_back(e);
    } else {
      ++sum.missing_rgb_files;
      noteMissing(sum, p);
    }
  }
  for (const auto& e : depth.entries) {
    const std::string p = joinPath(dir, e.path);
    if (fileExists(p)) {
      depth_ok.push_back(e);
    } else {
      ++sum.missing_depth_files;
      noteMissing(sum, p);
    }
  }
  std::vector<double> ta, tb;
  for (const auto& e : rgb_ok) ta.push_back(e.stamp);
  for (const auto& e : depth_ok) tb.push_back(e.stamp);
  const auto pairs = associateStamps(ta, tb, options.max_association_dt_s);
  sum.unassociated_rgb = static_cast<int>(rgb_ok.size() - pairs.size());
  for (const auto& [i, j] : pairs) {
    DatasetEntry e;
    e.stamp_text = rgb_ok[i].stamp_text;
    e.stamp = rgb_ok[i].stamp;
    e.depth_stamp_text = depth_ok[j].stamp_text;
    e.rgb_path = joinPath(dir, rgb_ok[i].path);
    e.depth_path = joinPath(dir, depth_ok[j].path);
    index.entries.push_back(std::move(e));
  }
}

/// Colour files that no index line mentions (e.g. the last image of the TUM excerpt).
int countUnlistedRgbFiles(const std::string& dir, const std::set<std::string>& mentioned) {
  int unlisted = 0;
  std::error_code ec;
  const fs::path rgb_dir = fs::path(dir) / "rgb";
  if (fs::is_directory(rgb_dir, ec)) {
    for (const auto& f : fs::directory_iterator(rgb_dir, ec)) {
      if (f.is_regular_file(ec) && !mentioned.count(f.path().lexically_normal().string())) {
        ++unlisted;
      }
    }
  }
  return unlisted;
}

/// Each entry's utime: from its stamp text (exact microseconds), or from frame-index stamps
/// (ICL-NUIM) at the index frame rate.
void assignUtimes(const std::vector<double>& listed_stamps, const DatasetOptions& options,
                  DatasetIndex& index) {
  IndexSummary& sum = index.summary;
  sum.index_stamps = looksLikeFrameIndices(listed_stamps);
  sum.index_frame_rate_hz =
      sum.index_stamps ? (options.index_frame_rate_hz > 0 ? options.index_frame_rate_hz : 30.0)
                       : 0.0;
  const auto toUtime = [&](const std::string& text, double value) {
    if (sum.index_stamps) {
      return static_cast<int64_t>(std::llround(value * 1e6 / sum.index_frame_rate_hz));
    }
    const auto us = stampTextToUtime(text);
    return us ? *us : static_cast<int64_t>(std::llround(value * 1e6));
  };
  for (auto& e : index.entries) {
    e.utime = toUtime(e.stamp_text, e.stamp);
    // The depth stamp parsed when the index was read; a text that is not a number (never
    // associated then) leaves the depth at the colour instant.
    const double depth_stamp = std::strtod(e.depth_stamp_text.c_str(), nullptr);
    e.depth_utime = std::isfinite(depth_stamp) && !e.depth_stamp_text.empty()
                        ? toUtime(e.depth_stamp_text, depth_stamp)
                        : e.utime;
  }
}

}  // namespace

DatasetIndex buildIndex(const std::string& dir, const DatasetOptions& options) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw DatasetError("dataset folder does not exist or is not a folder: " + dir);
  }
  if (!(options.max_association_dt_s > 0)) {
    throw DatasetError("max_association_dt_s must be positive");
  }
  if (options.index_frame_rate_hz < 0) {
    throw DatasetError("index_frame_rate_hz must be >= 0");
  }
  DatasetIndex index;
  IndexListing listing;
  const std::string assoc_path = joinPath(dir, "associations.txt");
  const std::string rgb_path = joinPath(dir, "rgb.txt");
  const std::string depth_path = joinPath(dir, "depth.txt");
  if (fileExists(assoc_path)) {
    readAssociations(dir, assoc_path, index, listing);
  } else if (fileExists(rgb_path) && fileExists(depth_path)) {
    readRgbAndDepthLists(dir, rgb_path, depth_path, options, index, listing);
  } else {
    throw DatasetError("no associations.txt and no rgb.txt + depth.txt in dataset folder " + dir);
  }
  index.summary.out_of_order = countOutOfOrder(listing.listed_stamps);
  sortAndDeduplicate(&index.entries, &index.summary);
  index.summary.unlisted_rgb_files = countUnlistedRgbFiles(dir, listing.mentioned);
  assignUtimes(listing.listed_stamps, options, index);
  return index;
}

}  // namespace pplvo::dataset
