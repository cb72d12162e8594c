// Per-stage timing and ground-truth accuracy of the 2D feature front end on the shared
// sequences (VGA, one thread). Not a unit test: prints figures for docs/features.md.
//
//   pplvo_features_bench [--detectors orb,orb-nogrid,akaze,sift,brisk] [--lines 0.4,0.4o,0.5f,1]
//                        [--oversample 2] [--orb-levels 4] [--orb-fast 12] [--ratio 0.85]
//                        [--gate 40] [--min-sep 0] [--max-lines 150] [--min-line-px 25]
//                        [--max-points 800] [--max-frames N] [--no-lines] [--no-points]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "match_judge.h"
#include "pplvo/core/allocator.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/features/line_extractor.h"
#include "pplvo/features/matching.h"
#include "pplvo/features/point_extractor.h"
#include "shared_sequence.h"

using namespace pplvo;
using namespace pplvo::features;
using namespace pplvo::features::testdata;

namespace {

/// CPU time of the calling thread (ms): with cv::setNumThreads(1) all work runs on this
/// thread, and it is far less sensitive than wall time to other processes sharing the cores.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

/// Wall and thread-CPU time since construction.
struct DualTimer {
  Stopwatch wall;
  double cpu0 = threadCpuMs();
  void restart() {
    wall.restart();
    cpu0 = threadCpuMs();
  }
  double cpuMs() const { return threadCpuMs() - cpu0; }
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

/// Match judging tolerance (px).
constexpr double kTolPx = 3.0;

struct Accum {
  double frames = 0, pairs = 0, features = 0, matches = 0, judged = 0, correct = 0;
  std::vector<double> detect_ms, match_ms, detect_cpu_ms, match_cpu_ms;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / v.size();
}

void printRow(const char* kind, const std::string& cfg, const std::string& seq, const Accum& a) {
  std::printf(
      "| %-5s | %-12s | %-28s | %7.0f | %7.0f | %6.1f%% | %6.3f | %7.2f | %7.2f | %7.2f | "
      "%7.2f | %7.2f |\n",
      kind, cfg.c_str(), seq.c_str(), a.features / std::max(1.0, a.frames),
      a.matches / std::max(1.0, a.pairs), 100.0 * a.judged / std::max(1.0, a.matches),
      a.correct / std::max(1.0, a.judged), median(a.detect_cpu_ms), mean(a.detect_cpu_ms),
      median(a.detect_ms), median(a.match_cpu_ms), median(a.match_ms));
}

struct BenchArgs {
  std::vector<std::string> detectors = {"orb", "orb-nogrid", "akaze", "sift", "brisk"};
  std::vector<std::string> line_cfgs = {"0.4", "0.5", "0.5f", "1"};
  int max_points = 800, max_frames = 1 << 30;
  double oversample = PointExtractorOptions{}.oversample;
  int orb_levels = PointExtractorOptions{}.orb_levels;
  int max_lines = LineExtractorOptions{}.max_lines;
  double min_line_px = LineExtractorOptions{}.min_length_px;
  double ratio = PointMatchOptions{}.ratio, gate = PointMatchOptions{}.max_px_distance;
  double min_sep = PointExtractorOptions{}.min_separation_px;
  int orb_fast = PointExtractorOptions{}.orb_fast_threshold;
  bool do_lines = true, do_points = true;
};

/// False (with a message) on an unknown argument.
bool parseArgs(int argc, char** argv, BenchArgs* b) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
    if (a == "--detectors")
      b->detectors = split(next());
    else if (a == "--lines")
      b->line_cfgs = split(next());
    else if (a == "--oversample")
      b->oversample = std::atof(next().c_str());
    else if (a == "--ratio")
      b->ratio = std::atof(next().c_str());
    else if (a == "--gate")
      b->gate = std::atof(next().c_str());
    else if (a == "--min-sep")
      b->min_sep = std::atof(next().c_str());
    else if (a == "--max-lines")
      b->max_lines = std::atoi(next().c_str());
    else if (a == "--min-line-px")
      b->min_line_px = std::atof(next().c_str());
    else if (a == "--orb-levels")
      b->orb_levels = std::atoi(next().c_str());
    else if (a == "--orb-fast")
      b->orb_fast = std::atoi(next().c_str());
    else if (a == "--max-points")
      b->max_points = std::atoi(next().c_str());
    else if (a == "--max-frames")
      b->max_frames = std::atoi(next().c_str());
    else if (a == "--no-lines")
      b->do_lines = false;
    else if (a == "--no-points")
      b->do_points = false;
    else {
      std::fprintf(stderr, "unknown argument %s\n", a.c_str());
      return false;
    }
  }
  return true;
}

/// Grey images and metric depth of a sequence's first frames, decoded once before timing.
struct DecodedFrames {
  std::vector<cv::Mat> gray, depth;
};
DecodedFrames decodeFrames(const SharedSequence& seq, int n) {
  DecodedFrames f;
  f.gray.resize(n);
  for (int k = 0; k < n; ++k) f.gray[k] = loadGray(seq.frames[k]);
  f.depth.resize(n);
  for (int k = 0; k < n; ++k) f.depth[k] = loadDepthM(seq.frames[k]);
  return f;
}

/// Extracts every frame and matches each consecutive pair with ground truth on both frames,
/// judging each match with the GT motion and the earlier frame's depth. `extract(gray)` gives
/// a frame's extraction, `count(extraction)` its features, `match(prev, cur)` a MatchResult
/// and `judge(prev, cur, i, j, depth, T_c2_c1)` a Verdict.
template <class Extract, class Count, class Match, class Judge>
Accum benchSequence(const SharedSequence& seq, const DecodedFrames& f, Extract extract, Count count,
                    Match match, Judge judge) {
  Accum acc;
  decltype(extract(f.gray[0])) prev;
  for (size_t k = 0; k < f.gray.size(); ++k) {
    DualTimer sw;
    auto cur = extract(f.gray[k]);
    acc.detect_ms.push_back(sw.wall.elapsedMs());
    acc.detect_cpu_ms.push_back(sw.cpuMs());
    acc.frames += 1;
    acc.features += count(cur);
    if (k > 0 && seq.frames[k].has_gt && seq.frames[k - 1].has_gt) {
      sw.restart();
      const MatchResult m = match(prev, cur);
      acc.match_ms.push_back(sw.wall.elapsedMs());
      acc.match_cpu_ms.push_back(sw.cpuMs());
      acc.pairs += 1;
      acc.matches += m.pairs.size();
      const Pose3 T_c2_c1 = seq.frames[k].T_w_c.inverse() * seq.frames[k - 1].T_w_c;
      for (const auto& [i, j] : m.pairs) {
        const Verdict v = judge(prev, cur, i, j, f.depth[k - 1], T_c2_c1);
        if (v == Verdict::kUnjudged) continue;
        acc.judged += 1;
        acc.correct += v == Verdict::kCorrect;
      }
    }
    prev = std::move(cur);
  }
  return acc;
}

/// One point detector configuration ("orb-nogrid": ORB without grid bucketing); nullopt for
/// an unknown detector.
std::optional<Accum> benchPoints(const BenchArgs& b, const std::string& det,
                                 const SharedSequence& seq, const DecodedFrames& f) {
  PointExtractorOptions po;
  po.max_points = b.max_points;
  po.oversample = b.oversample;
  po.orb_levels = b.orb_levels;
  po.min_separation_px = b.min_sep;
  po.orb_fast_threshold = b.orb_fast;
  std::string dname = det;
  if (det == "orb-nogrid") {
    po.grid_bucketing = false;
    dname = "orb";
  }
  if (!parsePointDetector(dname, &po.detector)) return std::nullopt;
  PointExtractor ex(po);
  PointMatchOptions mo;
  mo.ratio = b.ratio;
  mo.max_px_distance = b.gate;
  return benchSequence(
      seq, f, [&](const cv::Mat& gray) { return ex.extract(gray, seq.camera); },
      [](const PointExtraction& e) { return e.points.size(); },
      [&](const PointExtraction& prev, const PointExtraction& cur) {
        return matchPoints(prev.points, prev.descriptors, cur.points, cur.descriptors, mo);
      },
      [&](const PointExtraction& prev, const PointExtraction& cur, int i, int j,
          const cv::Mat& depth, const Pose3& T_c2_c1) {
        return judgePointMatch(prev.points[i].px, cur.points[j].px, depth, seq.camera, T_c2_c1,
                               kTolPx);
      });
}

/// One line configuration: detection scale with suffixes f = LBD at full resolution,
/// o = OpenCV's LSD and LBD (e.g. 0.4o, 0.5fo).
Accum benchLines(const BenchArgs& b, const std::string& lc, const SharedSequence& seq,
                 const DecodedFrames& f) {
  LineExtractorOptions lo;
  lo.detection_scale = std::atof(lc.c_str());
  lo.max_lines = b.max_lines;
  lo.min_length_px = b.min_line_px;
  LineDetectorVariant variant;
  variant.describe_full_resolution = lc.find('f') != std::string::npos;
  variant.use_opencv = lc.find('o') != std::string::npos;
  LineExtractor ex(lo, variant);
  LineMatchOptions mo;
  return benchSequence(
      seq, f, [&](const cv::Mat& gray) { return ex.extract(gray, seq.camera); },
      [](const LineExtraction& e) { return e.lines.size(); },
      [&](const LineExtraction& prev, const LineExtraction& cur) {
        return matchLines(prev.lines, prev.descriptors, cur.lines, cur.descriptors, mo);
      },
      [&](const LineExtraction& prev, const LineExtraction& cur, int i, int j, const cv::Mat& depth,
          const Pose3& T_c2_c1) {
        return judgeLineMatch(prev.lines[i].px1, prev.lines[i].px2, cur.lines[j].eq, depth,
                              seq.camera, T_c2_c1, kTolPx);
      });
}

void printHeader() {
  std::printf(
      "Columns: features/frame, matches/pair, %% of matches judged (depth present), "
      "precision of judged matches (GT pose + depth, %.0f px), detect+describe "
      "ms/frame (thread CPU median, CPU mean, wall median), matching ms/pair (CPU median, wall "
      "median). One thread.\n\n",
      kTolPx);
  std::printf("| kind  | config       | sequence                     | feat/fr | match/p | "
              "judged  | prec   | det cpu | det cpu mean | det wall | match cpu | match wall |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
}

}  // namespace

int main(int argc, char** argv) {
  pplvo::keepFrameBuffersMapped();  // frame-sized buffers: no page faults per frame
  BenchArgs b;
  if (!parseArgs(argc, argv, &b)) return 2;
  cv::setNumThreads(1);
  printHeader();
  for (const std::string name : {"icl_living_room_kt0_short", "tum_fr3_sitting_static_short"}) {
    const auto seq = loadSharedSequence(name);
    if (!seq) {
      std::printf("(sequence %s not found under %s)\n", name.c_str(), sharedDataDir().c_str());
      continue;
    }
    const DecodedFrames frames =
        decodeFrames(*seq, std::min<int>(b.max_frames, seq->frames.size()));
    if (b.do_points) {
      for (const auto& det : b.detectors) {
        const std::optional<Accum> acc = benchPoints(b, det, *seq, frames);
        if (!acc) {
          std::fprintf(stderr, "unknown detector %s\n", det.c_str());
          return 2;
        }
        printRow("point", det, name, *acc);
        std::fflush(stdout);
      }
    }
    if (b.do_lines) {
      for (const auto& lc : b.line_cfgs) {
        printRow("line", "lsd x" + lc, name, benchLines(b, lc, *seq, frames));
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
