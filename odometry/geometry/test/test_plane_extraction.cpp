#include <gtest/gtest.h>

#include <map>

#include "pplvo/fixtures/box_room.h"
#include "pplvo/geometry/plane_extraction.h"

namespace pplvo::geometry {
namespace {

struct Check {
  int n_true_visible = 0;
  int n_found = 0;
  int n_spurious = 0;
  double max_angle_deg = 0, max_d_err_m = 0, min_purity = 1;
};

// Each extracted plane must be one true plane (majority of its pixels' surface ids) with
// normal < 2 deg and d < 2 cm from it; each true plane seen by >= min_px pixels must be found.
Check checkExtraction(const PlaneExtractionResult& res, const fixtures::Rendered& r,
                      const std::vector<fixtures::WorldPlane>& room, const Pose3& T_w_c,
                      int min_px) {
  Check c;
  std::vector<int> visible(room.size(), 0);
  for (int v = 0; v < r.surface_id.rows; ++v)
    for (int u = 0; u < r.surface_id.cols; ++u)
      if (r.surface_id.at<int>(v, u) >= 0) ++visible[r.surface_id.at<int>(v, u)];
  std::vector<int> found(room.size(), 0);
  for (const PlaneFeature& p : res.planes) {
    std::map<int, int> votes;
    int total = 0;
    for (int v = 0; v < res.labels.rows; ++v)
      for (int u = 0; u < res.labels.cols; ++u)
        if (res.labels.at<uint8_t>(v, u) == p.label) {
          ++votes[r.surface_id.at<int>(v, u)];
          ++total;
        }
    EXPECT_EQ(total, p.n_points);
    int best = -1, best_n = 0;
    for (const auto& [id, n] : votes)
      if (n > best_n) {
        best = id;
        best_n = n;
      }
    if (best < 0) {
      ++c.n_spurious;
      continue;
    }
    c.min_purity = std::min(c.min_purity, static_cast<double>(best_n) / total);
    const Eigen::Vector4d truth = fixtures::planeInCamera(room[best], T_w_c);
    const double ang = fixtures::angleDeg(p.plane.normal(), truth.head<3>());
    const double derr = std::abs(p.plane.d() - truth(3));
    if (ang > 2.0 || derr > 0.02 || found[best]) ++c.n_spurious;  // wrong or duplicate
    if (ang > 2.0 || derr > 0.02 || found[best] || best_n < 0.97 * total) {
      for (const auto& [id, nv] : votes) std::printf("  votes surface %d: %d\n", id, nv);
      std::printf(
          "  plane %d: %d px, surface %d (purity %.3f), angle %.3f deg, d err %.4f m, n [%.3f %.3f "
          "%.3f] d %.3f\n",
          p.label, total, best, static_cast<double>(best_n) / total, ang, derr,
          p.plane.normal().x(), p.plane.normal().y(), p.plane.normal().z(), p.plane.d());
    }
    found[best] = 1;
    c.max_angle_deg = std::max(c.max_angle_deg, ang);
    c.max_d_err_m = std::max(c.max_d_err_m, derr);
  }
  for (size_t k = 0; k < room.size(); ++k) {
    if (visible[k] >= min_px) {
      ++c.n_true_visible;
      c.n_found += found[k];
    }
  }
  return c;
}

TEST(PlaneExtraction, RoomCornerFindsEachPlane) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  const auto room = fixtures::boxRoom(-2, 2, -1.2, 1.5, -2, 3);
  for (int seed : {-1, 5, 6}) {  // noiseless and two noisy renders
    for (const Pose3& T : {fixtures::cornerView(), fixtures::cornerView(-50, -15, {0.2, 0.0, 0.5}),
                           fixtures::cornerView(10, 35, {-0.5, 0.8, -0.5})}) {
      const fixtures::Rendered r = fixtures::renderRoom(cam, T, room, seed);
      PlaneExtractor ex(cam);
      const PlaneExtractionResult res = ex.extract(r.depth);
      ASSERT_TRUE(res.stats.error.empty());
      const Check c = checkExtraction(res, r, room, T, 8000);
      std::printf(
          "seed %d: %d planes, %d/%d visible found, spurious %d, max angle %.3f deg, max d err "
          "%.4f m, purity %.4f\n",
          seed, static_cast<int>(res.planes.size()), c.n_found, c.n_true_visible, c.n_spurious,
          c.max_angle_deg, c.max_d_err_m, c.min_purity);
      EXPECT_GE(c.n_true_visible, 2);
      EXPECT_EQ(c.n_found, c.n_true_visible);
      EXPECT_EQ(c.n_spurious, 0);
      EXPECT_LT(c.max_angle_deg, 2.0);
      EXPECT_LT(c.max_d_err_m, 0.02);
      EXPECT_GT(c.min_purity, 0.9);  // slivers of unextracted surfaces next to a plane may join it
      for (size_t i = 0; i < res.planes.size(); ++i) {
        EXPECT_EQ(res.planes[i].label, static_cast<int>(i) + 1);
        EXPECT_GT(res.planes[i].plane.d(), 0.0);
        EXPECT_TRUE(res.planes[i].plane.cov.allFinite());
        if (i > 0) {
          EXPECT_GE(res.planes[i - 1].n_points, res.planes[i].n_points);
        }
      }
    }
  }
}

TEST(PlaneExtraction, ResultsDoNotDependOnTheThreadCount) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  const auto room = fixtures::boxRoom(-2, 2, -1.2, 1.5, -2, 3);
  const fixtures::Rendered r =
      fixtures::renderRoom(cam, fixtures::cornerView(-50, -15, {0.2, 0.0, 0.5}), room, 5);
  PlaneExtractionOptions o;
  o.threads = 1;
  const PlaneExtractionResult ref = PlaneExtractor(cam, o).extract(r.depth);
  ASSERT_GE(ref.planes.size(), 2u);
  for (int threads : {2, 3, 8}) {
    o.threads = threads;
    const PlaneExtractionResult res = PlaneExtractor(cam, o).extract(r.depth);
    ASSERT_EQ(res.planes.size(), ref.planes.size()) << threads;
    EXPECT_EQ(cv::countNonZero(res.labels != ref.labels), 0) << threads;
    for (size_t i = 0; i < ref.planes.size(); ++i) {
      EXPECT_EQ(res.planes[i].plane.hessian, ref.planes[i].plane.hessian) << threads;
      EXPECT_EQ(res.planes[i].plane.cov, ref.planes[i].plane.cov) << threads;
      EXPECT_EQ(res.planes[i].centroid, ref.planes[i].centroid) << threads;
      EXPECT_EQ(res.planes[i].n_points, ref.planes[i].n_points) << threads;
    }
    EXPECT_EQ(res.stats.n_planar_cells, ref.stats.n_planar_cells);
    EXPECT_EQ(res.stats.n_fit_rejected, ref.stats.n_fit_rejected);
  }
}

TEST(PlaneExtraction, WithoutRefinementAndWithOtherCellSize) {
  const PinholeCamera cam = fixtures::iclVgaCamera(false);
  const auto room = fixtures::boxRoom(-2, 2, -1.2, 1.5, -2, 3);
  const Pose3 T = fixtures::cornerView();
  const fixtures::Rendered r = fixtures::renderRoom(cam, T, room, 8);
  for (int cell : {16, 24}) {
    for (bool refine : {false, true}) {
      PlaneExtractionOptions o;
      o.cell_size_px = cell;
      o.refine_boundaries = refine;
      PlaneExtractor ex(cam, o);
      const PlaneExtractionResult res = ex.extract(r.depth);
      const Check c = checkExtraction(res, r, room, T, 8000);
      EXPECT_EQ(c.n_found, c.n_true_visible) << cell << " " << refine;
      EXPECT_EQ(c.n_spurious, 0) << cell << " " << refine;
    }
  }
}

TEST(PlaneExtraction, DegenerateDepthMaps) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  PlaneExtractor ex(cam);
  DepthWithVariance d;
  d.depth_m = cv::Mat::zeros(480, 640, CV_32F);  // no depth at all
  PlaneExtractionResult r = ex.extract(d);
  EXPECT_TRUE(r.stats.error.empty());
  EXPECT_TRUE(r.planes.empty());
  ASSERT_FALSE(r.labels.empty());
  EXPECT_EQ(cv::countNonZero(r.labels), 0);
  // NaN everywhere.
  d.depth_m.setTo(std::numeric_limits<float>::quiet_NaN());
  r = ex.extract(d);
  EXPECT_TRUE(r.planes.empty());
  // Wrong size / type / empty.
  d.depth_m = cv::Mat::ones(100, 100, CV_32F);
  EXPECT_FALSE(ex.extract(d).stats.error.empty());
  d.depth_m = cv::Mat::ones(480, 640, CV_16U);
  EXPECT_FALSE(ex.extract(d).stats.error.empty());
  EXPECT_FALSE(ex.extract(DepthWithVariance{}).stats.error.empty());
  // Random depth (no planes): nothing spurious.
  d.depth_m = cv::Mat(480, 640, CV_32F);
  cv::RNG rng(3);
  rng.fill(d.depth_m, cv::RNG::UNIFORM, 0.5, 4.0);
  r = ex.extract(d);
  EXPECT_TRUE(r.planes.empty());
}

TEST(PlaneExtraction, FrameFeaturesConvenience) {
  const PinholeCamera cam = fixtures::iclVgaCamera(true);
  const auto room = fixtures::boxRoom(-2, 2, -1.2, 1.5, -2, 3);
  const fixtures::Rendered r = fixtures::renderRoom(cam, fixtures::cornerView(), room, 4);
  FrameFeatures f;
  f.camera = cam;
  const PlaneExtractionStats st = extractPlanes(f, r.depth);
  EXPECT_TRUE(st.error.empty());
  EXPECT_EQ(static_cast<int>(f.planes.size()), st.n_planes);
  EXPECT_GE(st.n_planes, 2);
  EXPECT_EQ(f.plane_labels.type(), CV_8UC1);
}

}  // namespace
}  // namespace pplvo::geometry
