// Depth moved from its capture instant to the colour instant (depth_time_alignment.h), against
// hand-computed projections.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "../src/forward_warp.h"  // closeCracks, for the per-point reference warp
#include "pplvo/depth_filter/depth_time_alignment.h"
#include "pplvo/fixtures/cameras.h"

namespace pplvo::depth_filter {
namespace {

PinholeCamera smallCamera() {
  PinholeCamera c;
  c.width = 64;
  c.height = 48;
  c.fx = c.fy = 50;
  c.cx = 31.5;
  c.cy = 23.5;
  return c;
}

Pose3 translation(double x, double y, double z) {
  Pose3 T = Pose3::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

/// Bitwise equality of two CV_32FC1 maps (NaN and -0 included).
bool bitIdentical(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int v = 0; v < a.rows; ++v) {
    if (std::memcmp(a.ptr(v), b.ptr(v), a.cols * a.elemSize()) != 0) return false;
  }
  return true;
}

/// The nearest-pixel warp written per point with Eigen and PinholeCamera::project (what
/// warpDepth computed before its rows were vectorised), crack closing included.
cv::Mat nearestWarpPerPoint(const PinholeCamera& cam, const cv::Mat& depth, const Pose3& T) {
  cv::Mat out(cam.height, cam.width, CV_32FC1,
              cv::Scalar(std::numeric_limits<float>::infinity()));
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) {
      const double z = depth.at<float>(v, u);
      if (!(z > 0) || !std::isfinite(z)) continue;
      const double rx = (u - cam.cx) / cam.fx, ry = (v - cam.cy) / cam.fy;
      const Eigen::Vector3d p = T.linear() * Eigen::Vector3d(rx * z, ry * z, z) + T.translation();
      if (!(p.z() > 0)) continue;
      const Eigen::Vector2d px = cam.project(p);
      const long ut = std::lround(px.x()), vr = std::lround(px.y());
      if (ut < 0 || vr < 0 || ut >= cam.width || vr >= cam.height) continue;
      float& d = out.at<float>(static_cast<int>(vr), static_cast<int>(ut));
      d = std::min(d, static_cast<float>(p.z()));
    }
  }
  cv::Mat closed;
  detail::closeCracks(out, nullptr, &closed, nullptr);
  return closed;
}

TEST(WarpDepth, VectorisedRowsEqualThePerPointWarpBitForBit) {
  // A VGA camera with TUM-like intrinsics, rough depth (steps, holes, NaN, infinity, points
  // behind the target camera) and motions from tiny to large: the vectorised row pass must
  // round every operation as the per-point code does, and the splat keep its order.
  PinholeCamera cam = fixtures::tumFr1Camera();
  cam.distortion = {};  // time alignment works on rectified depth
  cam.fy = -cam.fy;     // mirrored models (ICL-NUIM) too
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> depth(0.3f, 6.0f);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  cv::Mat d(cam.height, cam.width, CV_32FC1);
  for (int v = 0; v < d.rows; ++v) {
    for (int u = 0; u < d.cols; ++u) {
      const int kind = static_cast<int>(rng() % 100);
      float z = (u / 40 + v / 30) % 3 == 0 ? 1.5f + 0.001f * u : depth(rng);
      if (kind == 0) z = 0.0f;
      if (kind == 1) z = std::numeric_limits<float>::quiet_NaN();
      if (kind == 2) z = std::numeric_limits<float>::infinity();
      if (kind == 3) z = -1.0f;
      d.at<float>(v, u) = z;
    }
  }
  for (const double scale : {1e-4, 0.01, 0.3, 2.0}) {
    Pose3 T = Pose3::Identity();
    T.linear() = Eigen::AngleAxisd(scale * 0.5 * unit(rng),
                                   Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized())
                     .toRotationMatrix();
    T.translation() = scale * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    const cv::Mat fast = warpDepth(cam, d, T);
    EXPECT_TRUE(bitIdentical(nearestWarpPerPoint(cam, d, T), fast)) << "motion scale " << scale;
    // Not vacuous: most points land (a few thousand still under the largest motion).
    EXPECT_GT(cv::countNonZero(fast), scale < 1 ? cam.width * cam.height / 4 : 5000)
        << "motion scale " << scale;
  }
}

TEST(WarpDepth, FrontoParallelPlaneMovedAlongTheAxisChangesOnlyItsDepth) {
  const PinholeCamera cam = smallCamera();
  const cv::Mat depth(cam.height, cam.width, CV_32FC1, cv::Scalar(2.0f));
  // The target camera is 10 cm behind the source: every point is 10 cm farther. The plane
  // shrinks towards the principal point, so a border ring (pixels whose sources lie outside
  // the image) is empty and the inside is whole.
  const cv::Mat out = warpDepth(cam, depth, translation(0, 0, 0.1));
  EXPECT_FLOAT_EQ(out.at<float>(0, 0), 0.0f);
  for (int v = 4; v < cam.height - 4; ++v) {
    for (int u = 4; u < cam.width - 4; ++u) {
      ASSERT_NEAR(out.at<float>(v, u), 2.1f, 1e-5f) << u << "," << v;
    }
  }
}

TEST(WarpDepth, LateralMotionShiftsByFocalTimesTranslationOverDepth) {
  const PinholeCamera cam = smallCamera();
  cv::Mat depth(cam.height, cam.width, CV_32FC1, cv::Scalar(0.0f));
  depth.at<float>(20, 30) = 1.0f;
  // Points move by -4 cm in x in the target camera: 50 px/m * 0.04 m / 1 m = 2 px to the left.
  const cv::Mat out = warpDepth(cam, depth, translation(-0.04, 0, 0));
  EXPECT_FLOAT_EQ(out.at<float>(20, 28), 1.0f);
  EXPECT_EQ(cv::countNonZero(out), 1);
}

TEST(WarpDepth, NearestSurfaceWinsAndStepsStayOpen) {
  const PinholeCamera cam = smallCamera();
  cv::Mat depth(cam.height, cam.width, CV_32FC1, cv::Scalar(0.0f));
  // A 4 cm shift moves a point f * 0.04 / z pixels to the left: 2 px at 1 m, 4 px at 0.5 m,
  // 1 px at 2 m.
  depth.at<float>(10, 12) = 1.0f;  // to (10, 10)
  depth.at<float>(10, 11) = 0.5f;  // to (10, 7)
  depth.at<float>(10, 10) = 2.0f;  // to (10, 9)
  depth.at<float>(10, 9) = 1.0f;   // to (10, 7) as well, behind the 0.5 m point
  const cv::Mat out = warpDepth(cam, depth, translation(-0.04, 0, 0));
  EXPECT_FLOAT_EQ(out.at<float>(10, 7), 0.5f);  // 0.5 m and 1.0 m land here: the nearer wins
  EXPECT_FLOAT_EQ(out.at<float>(10, 10), 1.0f);
  EXPECT_FLOAT_EQ(out.at<float>(10, 9), 2.0f);
  // (10, 8) lies between 0.5 and 2.0 m: a step, not a crack, so it stays empty.
  EXPECT_FLOAT_EQ(out.at<float>(10, 8), 0.0f);
}

TEST(WarpDepth, OnePixelCrackOfAContinuousSurfaceIsClosed) {
  const PinholeCamera cam = smallCamera();
  // As a surface stretched by the motion leaves it: a one-pixel gap between two depths 0.5 %
  // apart (the identity warp keeps the samples where they are), closed with their mean.
  const Pose3 T = Pose3::Identity();
  cv::Mat stretched(cam.height, cam.width, CV_32FC1, cv::Scalar(0.0f));
  stretched.at<float>(10, 20) = 1.000f;
  stretched.at<float>(10, 22) = 1.005f;
  const cv::Mat out = warpDepth(cam, stretched, T);
  EXPECT_NEAR(out.at<float>(10, 21), 1.0025f, 1e-6f);
  EXPECT_FLOAT_EQ(out.at<float>(10, 20), 1.000f);
  EXPECT_FLOAT_EQ(out.at<float>(10, 22), 1.005f);
}

TEST(WarpDepth, RejectsDepthOfAnotherSize) {
  const PinholeCamera cam = smallCamera();
  EXPECT_THROW(warpDepth(cam, cv::Mat(10, 10, CV_32FC1, cv::Scalar(1.0f)), Pose3::Identity()),
               std::invalid_argument);
}

TEST(DepthTimeAligner, UsesTheVelocityOfPosesTwoFramesBackAndMovesDepthByIt) {
  const PinholeCamera cam = smallCamera();
  const cv::Mat depth(cam.height, cam.width, CV_32FC1, cv::Scalar(2.0f));
  DepthTimeAligner aligner;
  // Camera moving forward (+z) at 0.3 m/s, frames 1/30 s apart.
  const auto pose = [](int seq) { return translation(0, 0, 0.01 * seq); };
  const auto utime = [](int seq) { return int64_t{1000000} + seq * int64_t{33333}; };
  // Frame 2 with only frame 0's pose known: no velocity, left as is and counted.
  aligner.observePose(0, utime(0), pose(0), true);
  cv::Mat out = aligner.apply(cam, depth, 2, utime(2), utime(2) - 10000);
  EXPECT_EQ(out.data, depth.data);
  EXPECT_EQ(aligner.stats().frames_without_velocity, 1);
  aligner.observePose(1, utime(1), pose(1), true);
  aligner.observePose(2, utime(2), pose(2), true);  // too recent for frame 3 (lag 2)
  // Depth 10 ms before colour: the depth camera was 3 mm behind, so the scene is 3 mm nearer
  // at the colour instant.
  const std::optional<AlignmentMotion> m = aligner.colourFromDepth(3, utime(3), utime(3) - 10000);
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->T_colour_depth.translation().z(), -0.003, 1e-6);
  // What it says it did: -10 ms of the 33.3 ms motion into frame 1 (the pair (0, 1)).
  EXPECT_NEAR(m->alignment.scale, -0.3, 1e-3);
  EXPECT_EQ(m->alignment.motion_seq, 1);
  DepthTimeAlignment said;
  out = aligner.apply(cam, depth, 3, utime(3), utime(3) - 10000, &said);
  EXPECT_NEAR(out.at<float>(24, 32), 1.997f, 1e-5f);
  EXPECT_TRUE(said.moved());
  EXPECT_EQ(said.motion_seq, 1);
  EXPECT_EQ(aligner.stats().frames_aligned, 1);
  EXPECT_NEAR(aligner.stats().last_offset_ms, -10.0, 1e-9);
  // Same instant: nothing to do, no copy, and nothing moved.
  EXPECT_EQ(aligner.apply(cam, depth, 3, utime(3), utime(3), &said).data, depth.data);
  EXPECT_FALSE(said.moved());
  EXPECT_EQ(aligner.apply(cam, depth, 3, utime(3), 0).data, depth.data);
  // An offset beyond the bound is an association problem: left as is.
  EXPECT_EQ(aligner.apply(cam, depth, 3, utime(3), utime(3) - 200000).data, depth.data);
}

TEST(DepthTimeAligner, ALossBreaksTheVelocity) {
  DepthTimeAligner aligner;
  aligner.observePose(0, 0, translation(0, 0, 0), true);
  aligner.observePose(1, 33333, translation(0, 0, 0.01), false);  // lost
  EXPECT_FALSE(aligner.colourFromDepth(3, 100000, 90000));
  aligner.observePose(2, 66666, translation(0, 0, 0.02), true);
  aligner.observePose(3, 100000, translation(0, 0, 0.03), true);
  EXPECT_FALSE(aligner.colourFromDepth(4, 133333, 123333));  // (2, 3) too recent, (1, 2) lost
  EXPECT_TRUE(aligner.colourFromDepth(5, 166666, 156666));   // (2, 3)
  aligner.reset();
  EXPECT_FALSE(aligner.colourFromDepth(5, 166666, 156666));
}

}  // namespace
}  // namespace pplvo::depth_filter
