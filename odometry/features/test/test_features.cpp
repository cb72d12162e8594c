// Unit tests of pplvo_features on analytic scenes with known motion and depth.
#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <set>

#include "match_judge.h"
#include "pplvo/features/line_extractor.h"
#include "pplvo/features/matching.h"
#include "pplvo/features/point_extractor.h"
#include "pplvo/fixtures/textured_plane.h"

using namespace pplvo;
using namespace pplvo::features;
using namespace pplvo::features::testdata;
using pplvo::fixtures::PlaneScene;
using pplvo::fixtures::makeTexture;
using pplvo::fixtures::kinectVgaCamera;

namespace {

struct Pair {
  PinholeCamera cam;
  Pose3 T_w_c1, T_w_c2;
  cv::Mat gray1, gray2, depth1;
  Pose3 T_c2_c1() const { return T_w_c2.inverse() * T_w_c1; }
};

const PlaneScene& scene() {
  static const PlaneScene s = [] {
    PlaneScene p;
    p.texture = makeTexture(1024, 7);
    return p;
  }();
  return s;
}

/// Two views of the textured plane: a small hand-held motion at 30 Hz (1.5 deg, 5 cm).
Pair makePair(const PinholeCamera& cam, double motion_scale = 1.0) {
  Pair p;
  p.cam = cam;
  p.T_w_c1 = makePose(Eigen::Vector3d(0.05, -0.03, 0.0), Eigen::Quaterniond::Identity());
  const Eigen::Quaterniond q(Eigen::AngleAxisd(motion_scale * 1.5 * M_PI / 180,
                                               Eigen::Vector3d(0.3, 1.0, 0.2).normalized()));
  p.T_w_c2 =
      p.T_w_c1 * makePose(Eigen::Vector3d(motion_scale * Eigen::Vector3d(0.03, -0.02, 0.04)), q);
  scene().render(cam, p.T_w_c1, 2.0, 11, &p.gray1, &p.depth1);
  scene().render(cam, p.T_w_c2, 2.0, 12, &p.gray2, nullptr);
  return p;
}

struct Precision {
  int judged = 0, correct = 0;
  double value() const { return judged > 0 ? double(correct) / judged : 0.0; }
};

Precision judgePoints(const Pair& p, const PointExtraction& a, const PointExtraction& b,
                      const MatchResult& m) {
  Precision pr;
  for (const auto& [i, j] : m.pairs) {
    const Verdict v = judgePointMatch(a.points[i].px, b.points[j].px, p.depth1, p.cam,
                                      p.T_c2_c1(), 3.0);
    if (v == Verdict::kUnjudged) continue;
    ++pr.judged;
    pr.correct += v == Verdict::kCorrect;
  }
  return pr;
}

Precision judgeLines(const Pair& p, const LineExtraction& a, const LineExtraction& b,
                     const MatchResult& m) {
  Precision pr;
  for (const auto& [i, j] : m.pairs) {
    const Verdict v = judgeLineMatch(a.lines[i].px1, a.lines[i].px2, b.lines[j].eq, p.depth1,
                                     p.cam, p.T_c2_c1(), 3.0);
    if (v == Verdict::kUnjudged) continue;
    ++pr.judged;
    pr.correct += v == Verdict::kCorrect;
  }
  return pr;
}

bool oneToOne(const MatchResult& m) {
  std::set<int> a, b;
  for (const auto& [i, j] : m.pairs) {
    if (!a.insert(i).second || !b.insert(j).second) return false;
  }
  return true;
}

}  // namespace

TEST(LineEquation, NormalisedAndThroughEndpoints) {
  const Eigen::Vector2d p1(10, 20), p2(200, 50);
  const Eigen::Vector3d l = lineEquation(p1, p2);
  EXPECT_NEAR(l.head<2>().norm(), 1.0, 1e-12);
  EXPECT_NEAR(l.dot(Eigen::Vector3d(p1.x(), p1.y(), 1)), 0.0, 1e-9);
  EXPECT_NEAR(l.dot(Eigen::Vector3d(p2.x(), p2.y(), 1)), 0.0, 1e-9);
  EXPECT_EQ(lineEquation(p1, p1), Eigen::Vector3d::Zero());
}

TEST(LineGate, HandlesDirectionAmbiguityAngleAndRho) {
  const Eigen::Vector3d l = lineEquation({100, 100}, {300, 120});
  // Same line, segment drawn the other way: equation flips sign.
  const Eigen::Vector3d flipped = lineEquation({300, 120}, {100, 100});
  EXPECT_TRUE(lineGate(l, flipped, 10, 20));
  // Nearly horizontal lines whose directions straddle 0/180 degrees.
  EXPECT_TRUE(lineGate(lineEquation({0, 100}, {400, 101}), lineEquation({400, 99}, {0, 100}),
                       10, 20));
  // Rotated by 15 degrees about (200, 110): angle gate fails.
  const double a = 15 * M_PI / 180;
  const Eigen::Vector2d c(200, 110), d(std::cos(a), std::sin(a));
  EXPECT_FALSE(lineGate(lineEquation({0, 110}, {400, 110}), lineEquation(c - 100 * d, c + 100 * d),
                        10, 1000));
  const double b = 8 * M_PI / 180;
  const Eigen::Vector2d e(std::cos(b), std::sin(b));
  EXPECT_TRUE(lineGate(lineEquation({0, 110}, {400, 110}), lineEquation(c - 100 * e, c + 100 * e),
                       10, 1000));
  // Parallel, shifted by 30 px: rho gate.
  EXPECT_FALSE(lineGate(l, lineEquation({100, 130}, {300, 150}), 10, 20));
  EXPECT_TRUE(lineGate(l, lineEquation({100, 130}, {300, 150}), 10, 40));
  double theta, rho;
  lineHessian(lineEquation({0, 50}, {640, 50}), &theta, &rho);
  EXPECT_NEAR(std::abs(rho), 50.0, 1e-9);
}

TEST(SelectSpread, CapsAndSpreadsOverTheGrid) {
  std::vector<cv::KeyPoint> kps;
  // 400 strong points crowded in the top-left cell, 100 weak ones spread everywhere.
  for (int k = 0; k < 400; ++k) kps.emplace_back(cv::Point2f(k % 20, k / 20), 7, -1, 100.f + k);
  for (int k = 0; k < 100; ++k)
    kps.emplace_back(cv::Point2f(40 + (k % 10) * 60, 40 + (k / 10) * 44), 7, -1, 1.f);
  const auto idx = selectSpread(kps, 640, 480, 200, 8, 6);
  ASSERT_EQ(idx.size(), 200u);
  std::set<int> cells;
  int crowded = 0;
  for (int i : idx) {
    cells.insert(int(kps[i].pt.y * 6 / 480) * 8 + int(kps[i].pt.x * 8 / 640));
    crowded += i < 400;
  }
  EXPECT_GE(cells.size(), 40u);  // without bucketing all 200 would sit in one cell
  // First pass: quota 5 in the crowded cell (which also holds one weak point) and the 99 other
  // weak points; the 96 remaining slots go to the strongest leftovers (crowded ones).
  EXPECT_EQ(crowded, 5 + 96);
  EXPECT_EQ(selectSpread(kps, 640, 480, 0, 8, 6).size(), 0u);
}

class PlanePairTest : public ::testing::TestWithParam<double> {};

TEST_P(PlanePairTest, PointMatchingPrecision) {
  const Pair p = makePair(kinectVgaCamera(GetParam()));
  PointExtractor ex;
  const PointExtraction a = ex.extract(p.gray1, p.cam), b = ex.extract(p.gray2, p.cam);
  ASSERT_GT(a.points.size(), 300u);
  EXPECT_LE(a.points.size(), size_t(PointExtractorOptions{}.max_points));
  ASSERT_EQ(a.descriptors.rows, int(a.points.size()));
  const MatchResult m = matchPoints(a.points, a.descriptors, b.points, b.descriptors, {});
  const Precision pr = judgePoints(p, a, b, m);
  std::printf("fy %+.0f: points %zu/%zu, matches %zu, judged %d, precision %.3f\n", p.cam.fy,
              a.points.size(), b.points.size(), m.pairs.size(), pr.judged, pr.value());
  EXPECT_GT(pr.judged, 150);
  EXPECT_GE(pr.value(), 0.95);
  EXPECT_TRUE(oneToOne(m));
  EXPECT_EQ(m.stats.matches, int(m.pairs.size()));
  EXPECT_GT(m.stats.candidates, 0);
}

TEST_P(PlanePairTest, LineMatchingPrecision) {
  const Pair p = makePair(kinectVgaCamera(GetParam()));
  LineExtractor ex;
  const LineExtraction a = ex.extract(p.gray1, p.cam), b = ex.extract(p.gray2, p.cam);
  ASSERT_GT(a.lines.size(), 40u);
  ASSERT_EQ(a.descriptors.rows, int(a.lines.size()));
  ASSERT_EQ(a.descriptors.type(), CV_8U);
  for (const auto& l : a.lines) {
    EXPECT_NEAR(l.eq.head<2>().norm(), 1.0, 1e-9);
    EXPECT_NEAR(l.eq.dot(l.px1.homogeneous()), 0.0, 1e-6);
    EXPECT_GE((l.px2 - l.px1).norm(), LineExtractorOptions{}.min_length_px - 1e-6);
  }
  const MatchResult m = matchLines(a.lines, a.descriptors, b.lines, b.descriptors, {});
  const Precision pr = judgeLines(p, a, b, m);
  std::printf("fy %+.0f: lines %zu/%zu, matches %zu, judged %d, precision %.3f\n", p.cam.fy,
              a.lines.size(), b.lines.size(), m.pairs.size(), pr.judged, pr.value());
  EXPECT_GT(pr.judged, 30);
  EXPECT_GE(pr.value(), 0.95);
  EXPECT_TRUE(oneToOne(m));
}

// fy > 0 and the mirrored (ICL-like) model with negative fy.
INSTANTIATE_TEST_SUITE_P(SignedFy, PlanePairTest, ::testing::Values(1.0, -1.0));

TEST(PointMatching, EveryDetectorMatchesAccurately) {
  const Pair p = makePair(kinectVgaCamera());
  for (auto det : {PointDetector::kOrb, PointDetector::kAkaze, PointDetector::kSift,
                   PointDetector::kBrisk}) {
    PointExtractorOptions o;
    o.detector = det;
    PointExtractor ex(o);
    const PointExtraction a = ex.extract(p.gray1, p.cam), b = ex.extract(p.gray2, p.cam);
    EXPECT_EQ(a.descriptors.type(), det == PointDetector::kSift ? CV_32F : CV_8U);
    EXPECT_EQ(descriptorNormOf(a.descriptors), ex.descriptorNorm());
    const MatchResult m = matchPoints(a.points, a.descriptors, b.points, b.descriptors, {});
    const Precision pr = judgePoints(p, a, b, m);
    std::printf("%s: points %zu, matches %zu, precision %.3f\n", pointDetectorName(det),
                a.points.size(), m.pairs.size(), pr.value());
    EXPECT_GT(pr.judged, 50) << pointDetectorName(det);
    // The default (ORB) must reach 95 %; the alternatives (measured 0.967-0.995 here) get a
    // looser bound: their coarse octaves localise to worse than the 3 px judge.
    EXPECT_GE(pr.value(), det == PointDetector::kOrb ? 0.95 : 0.93) << pointDetectorName(det);
  }
}

TEST(PointMatching, PredictedPositionsGateTheSearch) {
  const Pair p = makePair(kinectVgaCamera(), 2.0);  // larger motion: ~40 px
  PointExtractor ex;
  const PointExtraction a = ex.extract(p.gray1, p.cam), b = ex.extract(p.gray2, p.cam);
  std::vector<Eigen::Vector2d> pred(a.points.size(), Eigen::Vector2d::Constant(NAN));
  std::vector<Eigen::Vector2d> wrong(a.points.size());
  int with_depth = 0;
  for (size_t i = 0; i < a.points.size(); ++i) {
    const double z = depthAt(p.depth1, a.points[i].px);
    wrong[i] = a.points[i].px + Eigen::Vector2d(120, 0);
    if (z <= 0) continue;
    pred[i] = p.cam.project(p.T_c2_c1() * p.cam.backproject(a.points[i].px.x(),
                                                            a.points[i].px.y(), z));
    ++with_depth;
  }
  ASSERT_GT(with_depth, 300);
  PointMatchOptions mo;
  const MatchResult plain = matchPoints(a.points, a.descriptors, b.points, b.descriptors, mo);
  const MatchResult predicted =
      matchPoints(a.points, a.descriptors, b.points, b.descriptors, mo, pred);
  const Precision pp = judgePoints(p, a, b, predicted);
  std::printf("large motion: plain %zu matches (precision %.3f), predicted %zu (%.3f)\n",
              plain.pairs.size(), judgePoints(p, a, b, plain).value(), predicted.pairs.size(),
              pp.value());
  EXPECT_GE(pp.value(), 0.95);
  EXPECT_GT(predicted.pairs.size(), plain.pairs.size());
  // The predicted gate is smaller: fewer candidates per query.
  EXPECT_LT(predicted.stats.candidates, plain.stats.candidates);
  // Predictions 120 px off: nothing inside the 15 px gates.
  const MatchResult off = matchPoints(a.points, a.descriptors, b.points, b.descriptors, mo, wrong);
  EXPECT_LT(off.pairs.size(), 5u);
  // A prediction vector of the wrong size is ignored.
  const MatchResult ignored = matchPoints(a.points, a.descriptors, b.points, b.descriptors, mo,
                                          std::vector<Eigen::Vector2d>(3));
  EXPECT_EQ(ignored.pairs, plain.pairs);
}

TEST(Undistortion, FeaturesAreUndistortedLikePinholeCamera) {
  PinholeCamera cam = kinectVgaCamera();
  cam.distortion = {0.12, -0.25, 0.001, -0.0015, 0.1};
  const Pair p = makePair(cam);
  PointExtractor ex;
  const PointExtraction a = ex.extract(p.gray1, cam), b = ex.extract(p.gray2, cam);
  ASSERT_GT(a.points.size(), 300u);
  double max_shift = 0;
  for (size_t i = 0; i < a.points.size(); ++i) {
    const Eigen::Vector2d raw(a.keypoints[i].pt.x, a.keypoints[i].pt.y);
    const Eigen::Vector2d und = cam.undistortPixel(raw);
    EXPECT_NEAR((a.points[i].px - und).norm(), 0.0, 1e-9);
    max_shift = std::max(max_shift, (und - raw).norm());
  }
  EXPECT_GT(max_shift, 5.0);  // the distortion is not negligible
  // Matches judged in undistorted geometry (pinhole projection of the truth).
  const MatchResult m = matchPoints(a.points, a.descriptors, b.points, b.descriptors, {});
  const Precision pr = judgePoints(p, a, b, m);
  EXPECT_GT(pr.judged, 150);
  EXPECT_GE(pr.value(), 0.95);
  // Lines: endpoints undistorted; matches judged against undistorted geometry.
  LineExtractor lex;
  const LineExtraction la = lex.extract(p.gray1, cam), lb = lex.extract(p.gray2, cam);
  ASSERT_GT(la.lines.size(), 30u);
  const MatchResult lm = matchLines(la.lines, la.descriptors, lb.lines, lb.descriptors, {});
  const Precision lp = judgeLines(p, la, lb, lm);
  EXPECT_GT(lp.judged, 20);
  EXPECT_GE(lp.value(), 0.95);
  // Without distortion the undistortion is the identity.
  const PinholeCamera plain = kinectVgaCamera();
  const PointExtraction c = ex.extract(p.gray1, plain);
  for (size_t i = 0; i < c.points.size(); ++i) {
    EXPECT_EQ(c.points[i].px.x(), double(c.keypoints[i].pt.x));
    EXPECT_EQ(c.points[i].px.y(), double(c.keypoints[i].pt.y));
  }
}

TEST(Degenerate, BlankTinyAndOddImagesGiveEmptyResults) {
  const PinholeCamera cam = kinectVgaCamera();
  PointExtractor pex;
  LineExtractor lex;
  std::vector<cv::Mat> images = {cv::Mat(), cv::Mat::zeros(480, 640, CV_8UC1),
                                 cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)),
                                 cv::Mat::zeros(10, 10, CV_8UC1), cv::Mat::zeros(1, 1, CV_8UC1),
                                 cv::Mat::zeros(480, 1, CV_8UC1), cv::Mat::zeros(480, 640, CV_8UC3)};
  for (const auto& img : images) {
    const PointExtraction pe = pex.extract(img, cam);
    EXPECT_TRUE(pe.points.empty());
    EXPECT_EQ(pe.descriptors.rows, 0);
    const LineExtraction le = lex.extract(img, cam);
    EXPECT_TRUE(le.lines.empty());
    EXPECT_EQ(le.descriptors.rows, 0);
  }
  // 16-bit input: reported, not processed.
  const cv::Mat deep(480, 640, CV_16UC1, cv::Scalar(1000));
  EXPECT_FALSE(pex.extract(deep, cam).stats.error.empty());
  EXPECT_FALSE(lex.extract(deep, cam).stats.error.empty());
  // Tiny but above the minimum side: still fine.
  const cv::Mat small = scene().texture(cv::Rect(0, 0, 70, 70)).clone();
  EXPECT_NO_THROW(pex.extract(small, cam));
  EXPECT_NO_THROW(lex.extract(small, cam));
  // Colour input gives the same points as grey.
  const Pair p = makePair(cam);
  cv::Mat bgr;
  cv::cvtColor(p.gray1, bgr, cv::COLOR_GRAY2BGR);
  EXPECT_EQ(pex.extract(bgr, cam).points.size(), pex.extract(p.gray1, cam).points.size());
}

TEST(Degenerate, MatchingEmptyOrInconsistentInputs) {
  const Pair p = makePair(kinectVgaCamera());
  PointExtractor ex;
  const PointExtraction a = ex.extract(p.gray1, p.cam);
  const std::vector<PointFeature> none;
  EXPECT_TRUE(matchPoints(none, cv::Mat(), a.points, a.descriptors, {}).pairs.empty());
  EXPECT_TRUE(matchPoints(a.points, a.descriptors, none, cv::Mat(), {}).pairs.empty());
  // Descriptor rows that disagree with the feature count.
  EXPECT_TRUE(matchPoints(a.points, a.descriptors.rowRange(0, 10), a.points, a.descriptors, {})
                  .pairs.empty());
  // Different descriptor types (binary vs float).
  cv::Mat f;
  a.descriptors.convertTo(f, CV_32F);
  EXPECT_TRUE(matchPoints(a.points, a.descriptors, a.points, f, {}).pairs.empty());
  // Self-matching with zero motion: every point matches itself.
  PointMatchOptions mo;
  const MatchResult self = matchPoints(a.points, a.descriptors, a.points, a.descriptors, mo);
  int identity = 0;
  for (const auto& [i, j] : self.pairs) identity += i == j;
  EXPECT_GE(identity, int(0.95 * a.points.size()));
  const std::vector<LineFeature> no_lines;
  EXPECT_TRUE(matchLines(no_lines, cv::Mat(), no_lines, cv::Mat(), {}).pairs.empty());
  FrameFeatures fa, fb;
  EXPECT_TRUE(matchPoints(fa, fb, {}).pairs.empty());
  EXPECT_TRUE(matchLines(fa, fb, {}).pairs.empty());
}

TEST(FrameFeatures, ExtractIntoFillsFields) {
  const Pair p = makePair(kinectVgaCamera());
  FrameFeatures f1, f2;
  PointExtractor pex;
  LineExtractor lex;
  const auto ps = pex.extractInto(p.gray1, p.cam, f1);
  const auto ls = lex.extractInto(p.gray1, p.cam, f1);
  pex.extractInto(p.gray2, p.cam, f2);
  lex.extractInto(p.gray2, p.cam, f2);
  EXPECT_EQ(ps.kept, int(f1.points.size()));
  EXPECT_EQ(ls.kept, int(f1.lines.size()));
  EXPECT_EQ(f1.point_descriptors.rows, int(f1.points.size()));
  EXPECT_EQ(f1.line_descriptors.rows, int(f1.lines.size()));
  FeatureMatches fm;
  fm.points = matchPoints(f1, f2, {}).pairs;
  fm.lines = matchLines(f1, f2, {}).pairs;
  EXPECT_GT(fm.points.size(), 150u);
  EXPECT_GT(fm.lines.size(), 20u);
}


TEST(PointMatching, GridBucketingEqualsBruteForce) {
  // Random points and float descriptors (no distance ties); reference: test every pair.
  cv::RNG rng(5);
  const int n = 600;
  std::vector<PointFeature> a(n), b(n);
  cv::Mat da(n, 32, CV_32F), db(n, 32, CV_32F);
  rng.fill(da, cv::RNG::UNIFORM, 0, 100);
  rng.fill(db, cv::RNG::UNIFORM, 0, 100);
  for (int i = 0; i < n; ++i) {
    a[i].px = {rng.uniform(-20.0, 660.0), rng.uniform(-20.0, 500.0)};
    b[i].px = a[i].px + Eigen::Vector2d(rng.gaussian(8), rng.gaussian(8));
    // Half the points keep a similar descriptor.
    if (i % 2 == 0) db.row(i) = da.row(i) + cv::Mat(1, 32, CV_32F, cv::Scalar(rng.uniform(0, 20)));
  }
  PointMatchOptions mo;
  mo.max_l2 = -1;
  std::vector<Eigen::Vector2d> pred(n, Eigen::Vector2d::Constant(NAN));
  for (int i = 0; i < n; i += 3) pred[i] = b[i].px + Eigen::Vector2d(3, -2);
  const std::vector<Eigen::Vector2d>* with_pred = &pred;
  for (const auto* p : {with_pred, static_cast<const std::vector<Eigen::Vector2d>*>(nullptr)}) {
    const MatchResult m = p ? matchPoints(a, da, b, db, mo, *p) : matchPoints(a, da, b, db, mo);
    // Reference.
    std::vector<std::pair<int, int>> ref;
    std::vector<int> best_of_curr(n, -1);
    std::vector<double> best_curr_d(n, 1e300);
    std::vector<int> best_j(n, -1);
    std::vector<double> d1(n, 1e300), d2(n, 1e300);
    int candidates = 0;
    for (int i = 0; i < n; ++i) {
      const bool use = p && (*p)[i].allFinite();
      const Eigen::Vector2d c = use ? (*p)[i] : a[i].px;
      const double r = use ? mo.predicted_max_px_distance : mo.max_px_distance;
      for (int j = 0; j < n; ++j) {
        if ((b[j].px - c).squaredNorm() >= r * r) continue;
        ++candidates;
        const double d = cv::norm(da.row(i), db.row(j), cv::NORM_L2);
        if (d < d1[i]) {
          d2[i] = d1[i];
          d1[i] = d;
          best_j[i] = j;
        } else if (d < d2[i]) {
          d2[i] = d;
        }
        if (d < best_curr_d[j]) {
          best_curr_d[j] = d;
          best_of_curr[j] = i;
        }
      }
    }
    for (int i = 0; i < n; ++i) {
      if (best_j[i] < 0) continue;
      if (d2[i] < 1e300 && !(d1[i] < mo.ratio * d2[i])) continue;
      if (best_of_curr[best_j[i]] != i) continue;
      ref.emplace_back(i, best_j[i]);
    }
    EXPECT_EQ(m.stats.candidates, candidates);
    EXPECT_EQ(m.pairs, ref);
    EXPECT_GT(ref.size(), 100u);
  }
}

/// Counts the fields of a schema and can set one int field by name.
struct FieldCounter {
  int n = 0;
  std::string set_key;
  int set_value = 0;
  template <typename T>
  void field(const std::string& key, T& value, const std::string& doc,
             const config::Range& = config::anyValue()) {
    ++n;
    EXPECT_FALSE(doc.empty()) << key;
    if constexpr (std::is_same_v<T, int>) {
      if (key == set_key) value = set_value;
    }
  }
  void section(const std::string&, const std::string&, const std::function<void()>& body) {
    body();
  }
  void forbid(const std::string&, const std::string&) {}
};

TEST(Options, VisitListsEveryField) {
  // Counts fields and checks a visitor can modify them (the config loader's use).
  PointExtractorOptions po;
  FieldCounter c;
  visit(c, po);
  EXPECT_EQ(c.n, 18);
  FieldCounter set{0, "max_points", 123};
  visit(set, po);
  EXPECT_EQ(po.max_points, 123);
  LineExtractorOptions lo;
  c = FieldCounter();
  visit(c, lo);
  EXPECT_EQ(c.n, 5);
  c = FieldCounter();
  PointMatchOptions pm;
  visit(c, pm);
  EXPECT_EQ(c.n, 7);
  c = FieldCounter();
  LineMatchOptions lm;
  visit(c, lm);
  EXPECT_EQ(c.n, 6);
  PointDetector d;
  EXPECT_TRUE(parsePointDetector("AKAZE", &d));
  EXPECT_EQ(d, PointDetector::kAkaze);
  EXPECT_STREQ(pointDetectorName(d), "akaze");
  EXPECT_FALSE(parsePointDetector("surf", &d));
}

TEST(LineExtractor, ReducedScaleKeepsSubpixelEdgePosition) {
  // Step edges at x = 299.5 and y = 199.5 (pixel-centre coordinates); endpoints must come back
  // at full resolution without a scale-dependent offset.
  cv::Mat img(480, 640, CV_8UC1, cv::Scalar(50));
  img(cv::Rect(300, 200, 340, 280)).setTo(200);
  for (double scale : {1.0, 0.5, 0.4}) {
    LineExtractorOptions o;
    o.detection_scale = scale;
    const LineExtraction r = LineExtractor(o).extract(img, kinectVgaCamera());
    ASSERT_EQ(r.lines.size(), 2u) << scale;
    for (const auto& l : r.lines) {
      const bool vertical = std::abs(l.px1.x() - l.px2.x()) < 1.0;
      if (vertical) {
        EXPECT_NEAR(l.px1.x(), 299.5, 0.1) << scale;
        EXPECT_NEAR(l.px2.x(), 299.5, 0.1) << scale;
        EXPECT_NEAR(std::abs(l.eq.x()), 1.0, 1e-6);
      } else {
        EXPECT_NEAR(l.px1.y(), 199.5, 0.1) << scale;
        EXPECT_NEAR(l.px2.y(), 199.5, 0.1) << scale;
      }
      EXPECT_GT((l.px2 - l.px1).norm(), 270.0) << scale;
    }
  }
}

// Sub-pixel keypoints: the test texture translated by known fractions of a pixel (cubic
// resampling). Refined keypoints follow the shift better than integer FAST keypoints.
TEST(SubpixelRefinement, FollowsSubPixelShifts) {
  const PinholeCamera cam = kinectVgaCamera();
  cv::Mat texture;
  cv::GaussianBlur(scene().texture, texture, cv::Size(0, 0), 1.0);  // band-limit before shifting
  auto render = [&](double shift_px) {
    const cv::Mat A = (cv::Mat_<double>(2, 3) << 1, 0, 100 + shift_px, 0, 1, 100 + 0.5 * shift_px);
    cv::Mat img;
    cv::warpAffine(texture, img, A, cv::Size(cam.width, cam.height), cv::INTER_CUBIC);
    if (img.channels() == 3) cv::cvtColor(img, img, cv::COLOR_BGR2GRAY);
    return img;
  };
  auto meanShiftError = [&](bool refine, double shift) {
    PointExtractorOptions o;
    o.subpixel_refinement = refine;
    o.subpixel_window_px = 2;  // noiseless texture: the small window is the precise one
    o.orb_levels = 1;
    const PointExtractor ex(o);
    const PointExtraction a = ex.extract(render(0.0), cam), b = ex.extract(render(shift), cam);
    // Pair each keypoint of b with the nearest of a moved by the shift.
    double sum = 0;
    int n = 0;
    for (const PointFeature& q : b.points) {
      double best = 1e9;
      for (const PointFeature& p : a.points) {
        best = std::min(best, (q.px - (p.px + Eigen::Vector2d(shift, 0.5 * shift))).norm());
      }
      if (best < 1.0) {
        sum += best;
        ++n;
      }
    }
    EXPECT_GT(n, 100);
    return n > 0 ? sum / n : 1e9;
  };
  double refined = 0, integer = 0;
  for (double shift : {0.3, 0.5, 0.7}) {
    refined += meanShiftError(true, shift) / 3;
    integer += meanShiftError(false, shift) / 3;
  }
  std::printf("mean keypoint error under sub-pixel shifts: refined %.3f px, integer %.3f px\n",
              refined, integer);
  EXPECT_LT(refined, 0.8 * integer);
}

// Keypoints seen again from a keyframe-like baseline (3x the hand-held frame motion: the plane
// tilts and scales in the image, the sensor noise differs): the transfer error of the matched
// keypoints against the ground truth. The small, level-scaled window of the defaults localises
// the corner itself; the 11x11 window's peak moves with its surrounding texture as the view
// changes (docs/features.md, "Sub-pixel keypoints").
TEST(SubpixelRefinement, DefaultWindowKeepsKeypointsRepeatableAcrossAKeyframeBaseline) {
  const Pair p = makePair(kinectVgaCamera(), 3.0);
  auto transferRms = [&](const PointExtractorOptions& o) {
    const PointExtractor ex(o);
    const PointExtraction a = ex.extract(p.gray1, p.cam), b = ex.extract(p.gray2, p.cam);
    PointMatchOptions mo;
    std::vector<Eigen::Vector2d> pred(a.points.size(), Eigen::Vector2d::Constant(NAN));
    for (size_t i = 0; i < a.points.size(); ++i) {
      const double z = depthAt(p.depth1, a.points[i].px);
      if (z > 0) {
        pred[i] = p.cam.project(p.T_c2_c1() * p.cam.backproject(a.points[i].px.x(),
                                                                a.points[i].px.y(), z));
      }
    }
    const MatchResult m = matchPoints(a.points, a.descriptors, b.points, b.descriptors, mo, pred);
    double sum = 0;
    int n = 0;
    for (const auto& [i, j] : m.pairs) {
      if (!pred[i].allFinite()) continue;
      const double e = (b.points[j].px - pred[i]).norm();
      if (e > 3.0) continue;  // a wrong match, not a localisation error
      sum += e * e;
      ++n;
    }
    EXPECT_GT(n, 200);
    return n > 0 ? std::sqrt(sum / n) : 1e9;
  };
  const PointExtractorOptions defaults;
  PointExtractorOptions wide = defaults;
  wide.subpixel_window_px = 5;
  wide.subpixel_window_scales_with_octave = false;
  const double e_default = transferRms(defaults), e_wide = transferRms(wide);
  std::printf("keypoint transfer error over a keyframe baseline: defaults %.3f px, 11x11 %.3f px\n",
              e_default, e_wide);
  EXPECT_LT(e_default, 0.9 * e_wide);
}
