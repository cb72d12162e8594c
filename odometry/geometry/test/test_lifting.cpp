#include <gtest/gtest.h>

#include <random>

#include "../src/line_inliers.h"  // the RANSAC's vectorised distance test
#include "pplvo/fixtures/box_room.h"
#include "pplvo/geometry/lifting.h"

namespace pplvo::geometry {
namespace {

FrameFeatures frameWith(const PinholeCamera& cam) {
  FrameFeatures f;
  f.camera = cam;
  return f;
}

TEST(LiftPoints, BackprojectsNearestPixelAndNeighbourFallback) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  const Pose3 T = fixtures::cornerView();
  const fixtures::Rendered r =
      fixtures::renderRoom(cam, T, fixtures::boxRoom(-2, 2, -1.2, 1.5, -2, 3), -1);
  FrameFeatures f = frameWith(cam);
  PointFeature a;
  a.px = {200.3, 150.6};
  PointFeature b;
  b.px = {400.0, 300.0};
  PointFeature c;  // outside the image
  c.px = {-20.0, 5.0};
  f.points = {a, b, c};
  DepthWithVariance d = r.depth;
  d.depth_m.at<float>(300, 400) = 0.0f;  // missing: fallback to the 3x3 neighbourhood
  const LiftStats st = liftPoints(f, d);
  ASSERT_TRUE(st.error.empty()) << st.error;
  EXPECT_EQ(st.points_lifted, 2);
  EXPECT_EQ(st.points_no_depth, 1);
  ASSERT_TRUE(f.points[0].has_3d);
  const double z = r.depth.depth_m.at<float>(151, 200);
  EXPECT_LT((f.points[0].point.p - cam.backproject(200.3, 150.6, z)).norm(), 1e-9);
  EXPECT_TRUE(f.points[1].has_3d);
  EXPECT_NEAR(f.points[1].point.p.z(), r.depth.depth_m.at<float>(299, 400), 0.02);
  EXPECT_FALSE(f.points[2].has_3d);
  // Radius 0: the missing pixel is not replaced.
  LiftOptions o;
  o.point_search_radius_px = 0;
  liftPoints(f, d, o);
  EXPECT_FALSE(f.points[1].has_3d);
}

TEST(LiftPoints, KeypointsOnDepthDiscontinuitiesAreNotLifted) {
  // Left half a wall at 1.5 m, right half one at 3 m; a slanted floor-like gradient below.
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  DepthWithVariance d;
  d.depth_m = cv::Mat(480, 640, CV_32F, cv::Scalar(1.5f));
  d.depth_m(cv::Rect(320, 0, 320, 240)).setTo(3.0f);
  for (int v = 240; v < 480; ++v) d.depth_m.row(v).setTo(2.0f + 0.01f * (v - 240));  // 0.5 %/px
  d.var_m2 = cv::Mat(480, 640, CV_32F, cv::Scalar(1e-4f));
  FrameFeatures f = frameWith(cam);
  PointFeature on_edge, flat, slanted, near_edge;
  on_edge.px = {320.4, 100.0};
  flat.px = {100.0, 100.0};
  slanted.px = {300.0, 400.0};
  near_edge.px = {324.0, 100.0};  // 4 px from the edge: outside the 3 px radius
  f.points = {on_edge, flat, slanted, near_edge};
  LiftOptions o;
  o.point_max_depth_spread = 0.2;
  o.point_discontinuity_radius_px = 3;
  LiftStats st = liftPoints(f, d, o);
  EXPECT_EQ(st.points_on_discontinuity, 1);
  EXPECT_EQ(st.points_lifted, 3);
  EXPECT_FALSE(f.points[0].has_3d);
  EXPECT_TRUE(f.points[1].has_3d);
  EXPECT_TRUE(f.points[2].has_3d);
  EXPECT_TRUE(f.points[3].has_3d);
  EXPECT_NEAR(f.points[3].point.p.z(), 3.0, 1e-6);
  // Missing pixels do not count as a discontinuity.
  d.depth_m(cv::Rect(90, 95, 5, 10)).setTo(0.0f);
  st = liftPoints(f, d, o);
  EXPECT_TRUE(f.points[1].has_3d);
  // Disabled: every point with depth is lifted.
  o.point_max_depth_spread = 0.0;
  st = liftPoints(f, d, o);
  EXPECT_EQ(st.points_on_discontinuity, 0);
  EXPECT_EQ(st.points_lifted, 4);
}

TEST(LiftPoints, RejectsBadDepthInput) {
  FrameFeatures f = frameWith(fixtures::iclVgaCamera(true));
  f.points.resize(3);
  DepthWithVariance d;  // empty
  LiftStats st = liftPoints(f, d);
  EXPECT_FALSE(st.error.empty());
  EXPECT_EQ(st.points_no_depth, 3);
  d.depth_m = cv::Mat::zeros(240, 320, CV_32F);  // wrong size
  EXPECT_FALSE(liftPoints(f, d).error.empty());
  d.depth_m = cv::Mat::zeros(480, 640, CV_16U);  // wrong type
  EXPECT_FALSE(liftPoints(f, d).error.empty());
  d.depth_m = cv::Mat::zeros(480, 640, CV_32F);  // no depth at all
  st = liftPoints(f, d);
  EXPECT_TRUE(st.error.empty());
  EXPECT_EQ(st.points_lifted, 0);
  for (const auto& p : f.points) EXPECT_FALSE(p.has_3d);
}

// The projection of a true 3D segment lying on a wall; depth from the rendered (noisy) room.
TEST(LiftLines, RecoversSegmentOnWallAndAcrossDiscontinuity) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  const Pose3 T_w_c = Pose3::Identity();
  const auto room = fixtures::boxRoom(-2, 2, -1.5, 1.5, -1, 3);
  const fixtures::Rendered r = fixtures::renderRoom(cam, T_w_c, room, 11);
  FrameFeatures f = frameWith(cam);
  // Segment on the back wall z = 3 (camera frame == world frame).
  const Eigen::Vector3d A(-0.8, 0.4, 3.0), B(0.9, -0.3, 3.0);
  LineFeature l;
  l.px1 = cam.project(A);
  l.px2 = cam.project(B);
  // A segment crossing from the back wall onto the left wall x = -2 (a bent line: RANSAC keeps
  // the larger straight part).
  LineFeature bent;
  bent.px1 = cam.project(Eigen::Vector3d(-2.0, 0.0, 1.6));
  bent.px2 = cam.project(Eigen::Vector3d(-0.5, 0.0, 3.0));
  // Tiny segment (1 px) and one with fewer than 3 valid depth samples.
  LineFeature tiny;
  tiny.px1 = {100, 100};
  tiny.px2 = {100.8, 100};
  LineFeature sparse;
  sparse.px1 = {50, 400};
  sparse.px2 = {250, 400};
  f.lines = {l, bent, tiny, sparse};
  DepthWithVariance d = r.depth;
  for (int u = 45; u <= 255; ++u) {
    if (u != 60 && u != 200) d.depth_m.at<float>(400, u) = 0.0f;  // only 2 valid samples
  }
  const LiftStats st = liftLines(f, d);
  ASSERT_TRUE(st.error.empty());
  EXPECT_EQ(st.lines_lifted, 2);
  EXPECT_EQ(st.lines_too_few_samples, 2);
  ASSERT_TRUE(f.lines[0].has_3d);
  const Line3WithCov& L = f.lines[0].line;
  EXPECT_LT((L.p1 - A).norm(), 0.05);
  EXPECT_LT((L.p2 - B).norm(), 0.05);
  EXPECT_GT(f.lines[0].n_inliers, 70);  // 2 cm threshold vs sigma_z(3 m) = 1.3 cm
  EXPECT_TRUE(L.cov1.allFinite());
  EXPECT_GT(L.cov1.determinant(), 0.0 - 1e-30);
  ASSERT_TRUE(f.lines[1].has_3d);
  // The bent segment: the kept part lies on one of the two walls.
  const Line3WithCov& M = f.lines[1].line;
  const bool on_back = std::abs(M.p1.z() - 3.0) < 0.05 && std::abs(M.p2.z() - 3.0) < 0.05;
  const bool on_left = std::abs(M.p1.x() + 2.0) < 0.05 && std::abs(M.p2.x() + 2.0) < 0.05;
  EXPECT_TRUE(on_back || on_left) << M.p1.transpose() << " / " << M.p2.transpose();
  EXPECT_FALSE(f.lines[2].has_3d);
  EXPECT_FALSE(f.lines[3].has_3d);
  // Deterministic: same seed, same result.
  FrameFeatures g = f;
  liftLines(g, d);
  EXPECT_EQ((g.lines[1].line.p1 - f.lines[1].line.p1).norm(), 0.0);
}

TEST(LiftLines, OutlineTakesTheNearerSurface) {
  // The outline of a near box (1.5 m, left) against a far wall (3 m): the segment lies on the
  // depth step, where the sampled pixel may fall on either surface (here mostly the far one).
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  DepthWithVariance d;
  d.depth_m = cv::Mat(480, 640, CV_32F, cv::Scalar(3.0f));
  d.depth_m(cv::Rect(0, 0, 320, 480)).setTo(1.5f);
  d.var_m2 = cv::Mat(480, 640, CV_32F, cv::Scalar(1e-6f));
  FrameFeatures f = frameWith(cam);
  LineFeature outline;
  outline.px1 = {320.0, 100.0};
  outline.px2 = {320.0, 380.0};
  f.lines = {outline};
  LiftOptions o;
  o.line_side_offset_px = 0;
  liftLines(f, d, o);
  ASSERT_TRUE(f.lines[0].has_3d);
  EXPECT_NEAR(f.lines[0].line.p1.z(), 3.0, 0.05);  // the far wall's depth: wrong for an outline
  o.line_side_offset_px = 3;
  o.line_max_depth_step = 0.2;
  liftLines(f, d, o);
  ASSERT_TRUE(f.lines[0].has_3d);
  EXPECT_NEAR(f.lines[0].line.p1.z(), 1.5, 0.05);
  EXPECT_NEAR(f.lines[0].line.p2.z(), 1.5, 0.05);
  // A line inside the far wall (no step across it) keeps its own depth.
  f.lines[0].px1 = {500.0, 100.0};
  f.lines[0].px2 = {500.0, 380.0};
  liftLines(f, d, o);
  ASSERT_TRUE(f.lines[0].has_3d);
  EXPECT_NEAR(f.lines[0].line.p1.z(), 3.0, 0.05);
}

TEST(LiftLines, NoDepthAndNanEndpoints) {
  FrameFeatures f = frameWith(fixtures::iclVgaCamera(true));
  LineFeature a;
  a.px1 = {10, 10};
  a.px2 = {300, 200};
  LineFeature b;
  b.px1 = {std::numeric_limits<double>::quiet_NaN(), 1};
  b.px2 = {30, 40};
  f.lines = {a, b};
  DepthWithVariance d;
  d.depth_m = cv::Mat::zeros(480, 640, CV_32F);
  const LiftStats st = liftLines(f, d);
  EXPECT_TRUE(st.error.empty());
  EXPECT_EQ(st.lines_lifted, 0);
  EXPECT_EQ(st.lines_too_few_samples, 2);
  EXPECT_FALSE(liftLines(f, DepthWithVariance{}).error.empty());
}

// The vectorised inlier test marks exactly what the Eigen expression it replaced marks, also
// for distances within rounding of the threshold, which a reordered formula would flip.
TEST(LineInliers, VectorisedTestMarksBitForBitWhatTheEigenExpressionMarks) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> coord(-3.0, 3.0), depth(0.3, 6.0);
  std::normal_distribution<double> off(0.0, 0.02);
  int boundary_cases = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 130);  // odd and even, shorter than a vector
    const Eigen::Vector3d a(coord(rng), coord(rng), depth(rng));
    const Eigen::Vector3d d = Eigen::Vector3d(coord(rng), coord(rng), coord(rng)) * 0.1;
    std::vector<Eigen::Vector3d> P(static_cast<size_t>(n));
    for (int q = 0; q < n; ++q) {
      const double t = coord(rng);
      P[static_cast<size_t>(q)] = a + t * d + Eigen::Vector3d(off(rng), off(rng), off(rng));
    }
    const double dn2 = d.squaredNorm();
    // Half the trials put the threshold exactly on one point's distance: strict < must hold.
    double thr2 = 0.02 * 0.02;
    if (trial % 2 == 1) {
      thr2 = (P[static_cast<size_t>(rng() % n)] - a).cross(d).squaredNorm() / dn2;
      ++boundary_cases;
    }
    detail::PointColumns columns;
    columns.assign(P);
    std::vector<char> marks(static_cast<size_t>(n), 7);
    const int count = detail::markLineInliers(columns, a, d, dn2, thr2, marks.data());
    int expected_count = 0;
    for (int q = 0; q < n; ++q) {
      const double dist2 = (P[static_cast<size_t>(q)] - a).cross(d).squaredNorm() / dn2;
      const char expected = dist2 < thr2;
      expected_count += expected;
      ASSERT_EQ(marks[static_cast<size_t>(q)], expected) << "trial " << trial << " point " << q;
    }
    EXPECT_EQ(count, expected_count);
  }
  EXPECT_EQ(boundary_cases, 100);
}

}  // namespace
}  // namespace pplvo::geometry
