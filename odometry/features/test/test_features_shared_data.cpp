// Feature counts and ground-truth match precision on a few frames of each shared sequence.
// Skips (does not fail) when the shared data folder is absent.
#include <gtest/gtest.h>

#include <cstdio>

#include "match_judge.h"
#include "pplvo/features/line_extractor.h"
#include "pplvo/features/matching.h"
#include "pplvo/features/point_extractor.h"
#include "shared_sequence.h"

using namespace pplvo;
using namespace pplvo::features;
using namespace pplvo::features::testdata;

namespace {

struct Expect {
  const char* name;
  int min_points, min_lines;   // per frame
  double min_point_precision;  // over the judged matches of all pairs
  double min_line_precision;
};

class SharedData : public ::testing::TestWithParam<Expect> {};

}  // namespace

TEST_P(SharedData, CountsAndPrecision) {
  const Expect e = GetParam();
  const auto seq = loadSharedSequence(e.name);
  if (!seq) GTEST_SKIP() << "shared sequence " << e.name << " not found in " << sharedDataDir();
  ASSERT_TRUE(seq->camera.valid());
  // The judge checks descriptor matches at the detector's own positions (3 px). Sub-pixel
  // refinement moves a few percent of the keypoints to a response peak up to 1.5 px away
  // (judged precision 0.986 -> 0.953 on ICL, 0.978 -> 0.920 on TUM, while the pose improves:
  // docs/features.md), so it is off here.
  PointExtractorOptions po;
  po.subpixel_refinement = false;
  PointExtractor pex(po);
  LineExtractor lex;
  // Eight consecutive frames with ground truth from the middle of the sequence.
  const int start = static_cast<int>(seq->frames.size()) / 2;
  int judged_p = 0, correct_p = 0, judged_l = 0, correct_l = 0;
  FrameFeatures prev;
  cv::Mat prev_depth;
  for (int k = start; k < start + 8 && k < static_cast<int>(seq->frames.size()); ++k) {
    const auto& fr = seq->frames[k];
    const cv::Mat gray = loadGray(fr), depth = loadDepthM(fr);
    ASSERT_FALSE(gray.empty()) << fr.rgb_path;
    FrameFeatures cur;
    const auto ps = pex.extractInto(gray, seq->camera, cur);
    const auto ls = lex.extractInto(gray, seq->camera, cur);
    EXPECT_TRUE(ps.error.empty()) << ps.error;
    EXPECT_TRUE(ls.error.empty()) << ls.error;
    int pm = 0, lm = 0;
    if (k > start && fr.has_gt && seq->frames[k - 1].has_gt) {
      const Pose3 T_c2_c1 = fr.T_w_c.inverse() * seq->frames[k - 1].T_w_c;
      const MatchResult mp = matchPoints(prev, cur, {});
      const MatchResult ml = matchLines(prev, cur, {});
      pm = mp.stats.matches;
      lm = ml.stats.matches;
      for (const auto& [i, j] : mp.pairs) {
        const Verdict v = judgePointMatch(prev.points[i].px, cur.points[j].px, prev_depth,
                                          seq->camera, T_c2_c1, 3.0);
        judged_p += v != Verdict::kUnjudged;
        correct_p += v == Verdict::kCorrect;
      }
      for (const auto& [i, j] : ml.pairs) {
        const Verdict v = judgeLineMatch(prev.lines[i].px1, prev.lines[i].px2, cur.lines[j].eq,
                                         prev_depth, seq->camera, T_c2_c1, 3.0);
        judged_l += v != Verdict::kUnjudged;
        correct_l += v == Verdict::kCorrect;
      }
    }
    std::printf("%s frame %d: %zu points (%d candidates), %zu lines (%d LSD), matches %d points "
                "%d lines\n",
                e.name, k, cur.points.size(), ps.candidates, cur.lines.size(), ls.detected, pm,
                lm);
    EXPECT_GT(static_cast<int>(cur.points.size()), e.min_points);
    EXPECT_GT(static_cast<int>(cur.lines.size()), e.min_lines);
    prev = std::move(cur);
    prev_depth = depth;
  }
  const double pp = judged_p ? double(correct_p) / judged_p : 0;
  const double lp = judged_l ? double(correct_l) / judged_l : 0;
  std::printf("%s: point precision %.3f (%d judged), line precision %.3f (%d judged)\n", e.name,
              pp, judged_p, lp, judged_l);
  EXPECT_GT(judged_p, 500);
  EXPECT_GT(judged_l, 50);
  EXPECT_GE(pp, e.min_point_precision);
  EXPECT_GE(lp, e.min_line_precision);
}

// ICL: synthetic render with exact ground truth. TUM fr3/sitting_static: people move in front
// of the camera and the ground truth is interpolated mocap, so wrong-looking matches include
// true matches on moving people; bounds leave a margin below the measured values (bench).
INSTANTIATE_TEST_SUITE_P(
    Sequences, SharedData,
    ::testing::Values(Expect{"icl_living_room_kt0_short", 100, 20, 0.95, 0.95},
                      Expect{"tum_fr3_sitting_static_short", 100, 20, 0.93, 0.93}),
    [](const auto& p) { return std::string(p.param.name).substr(0, 3); });
