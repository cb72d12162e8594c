// O-GM temporal fusion (paper eqs. 7-8, section 3.4) on exact small cases and on an analytic
// noisy scene with known true depth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <opencv2/core.hpp>
#include <string>
#include <thread>
#include <vector>

#include "pplvo/depth_filter/cgm_filter.h"
#include "pplvo/depth_filter/ogm_fusion.h"
#include "pplvo/fixtures/analytic_scene.h"

namespace pplvo::depth_filter {
namespace {

using fixtures::AnalyticScene;
using fixtures::SceneFrame;
using fixtures::SceneOptions;

PinholeCamera smallCamera() {
  PinholeCamera c;
  c.width = 5;
  c.height = 5;
  c.fx = c.fy = 10.0;
  c.cx = c.cy = 2.0;
  return c;
}

DepthWithVariance uniform(const PinholeCamera& c, float z, float var) {
  DepthWithVariance d;
  d.depth_m = cv::Mat(c.height, c.width, CV_32FC1, cv::Scalar(z));
  d.var_m2 = cv::Mat(c.height, c.width, CV_32FC1, cv::Scalar(var));
  return d;
}

TEST(OgmFusion, InverseVarianceMeanAndGmVarianceEq7) {
  const PinholeCamera cam = smallCamera();
  OgmFusion ogm;
  ASSERT_TRUE(ogm.addFrame(0, cam, uniform(cam, 2.0f, 1e-4f)));
  ASSERT_TRUE(ogm.fuse(0, Pose3::Identity()).ok);
  ASSERT_TRUE(ogm.addFrame(1, cam, uniform(cam, 2.1f, 4e-4f)));
  const OgmResult res = ogm.fuse(1, Pose3::Identity());
  ASSERT_TRUE(res.ok);
  EXPECT_EQ(res.depth.window_length, 2);
  const double a = 1e-4, b = 4e-4;  // centre pixel: cos(alpha) = 1, range = depth
  const double sw = 1 / a + 1 / b;
  const double r = (2.0 / a + 2.1 / b) / sw;
  const double var = ((4.0 + a) / a + (2.1 * 2.1 + b) / b) / sw - r * r;
  EXPECT_NEAR(res.depth.depth_m.at<float>(2, 2), r, 1e-5);
  EXPECT_NEAR(res.depth.var_m2.at<float>(2, 2), var, 1e-6);
  // Off-centre pixel: depth -> range with 1/cos, variance with 1/cos^2 (eq. 7), and back.
  EXPECT_NEAR(res.depth.depth_m.at<float>(0, 0), r, 1e-4);
}

TEST(OgmFusion, ConsistencyGateRejectsOccludedOldPoints) {
  const PinholeCamera cam = smallCamera();
  OgmFusion::Options o;
  o.k_consistency = 2;
  OgmFusion ogm(o);
  const float zs[3] = {3.0f, 2.01f, 2.0f};  // oldest (an occluded background) to newest
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(ogm.addFrame(i, cam, uniform(cam, zs[i], 1e-4f)));
    ASSERT_TRUE(ogm.fuse(i, Pose3::Identity()).ok);
  }
  // The last fusion saw 2.0 (current), 2.01, then 3.0 gated: 25 pixels rejected. The earlier
  // fusion of frame 1 had only 2 points per pixel (no gate yet).
  EXPECT_EQ(ogm.stats().points_gated, 25);
  OgmFusion ogm_nogate(OgmFusion::Options{10, 5, 3.0, 1e-4, 0.05});
  for (int i = 0; i < 3; ++i) {
    ogm_nogate.addFrame(i, cam, uniform(cam, zs[i], 1e-4f));
    ogm_nogate.fuse(i, Pose3::Identity());
  }
  EXPECT_EQ(ogm_nogate.stats().points_gated, 0);
}

TEST(OgmFusion, WindowNeverExceedsMaxAndEvictsByUncertainty) {
  const PinholeCamera cam = smallCamera();
  OgmFusion::Options o;
  o.max_window = 3;
  o.max_translation_variance_m2 = 1e-4;
  OgmFusion ogm(o);
  for (int i = 0; i < 8; ++i) {
    ASSERT_TRUE(ogm.addFrame(i, cam, uniform(cam, 2.0f, 1e-4f)));
    const OgmResult r = ogm.fuse(i, Pose3::Identity());
    ASSERT_TRUE(r.ok);
    EXPECT_LE(ogm.windowSize(), 3);
    EXPECT_EQ(r.depth.window_length, std::min(i + 1, 3));
  }
  EXPECT_EQ(ogm.stats().evicted_capacity, 5);
  EXPECT_TRUE(ogm.contains(7) && ogm.contains(6) && ogm.contains(5));
  // Frame 5 too uncertain, frame 6 fine, unknown frame ignored, NaN counts as too uncertain.
  EXPECT_TRUE(ogm.setWindowUncertainty(5, 2e-4));
  EXPECT_FALSE(ogm.setWindowUncertainty(6, 5e-5));
  EXPECT_FALSE(ogm.setWindowUncertainty(42, 1.0));
  EXPECT_EQ(ogm.windowSize(), 2);
  ASSERT_TRUE(ogm.addFrame(8, cam, uniform(cam, 2.0f, 1e-4f)));
  EXPECT_EQ(ogm.fuse(8, Pose3::Identity()).depth.window_length, 3);
  EXPECT_TRUE(ogm.setWindowUncertainty(6, std::numeric_limits<double>::quiet_NaN()));
  EXPECT_EQ(ogm.stats().evicted_uncertainty, 2);
  ASSERT_TRUE(ogm.addFrame(9, cam, uniform(cam, 2.0f, 1e-4f)));
  EXPECT_EQ(ogm.fuse(9, Pose3::Identity()).depth.window_length, 3);  // 9, 8, 7
}

TEST(OgmFusion, VarianceStaysHonestWhenDepthErrorsAreCorrelatedOverTime) {
  // A still camera in front of a wall at 2 m: each pixel's depth error is partly (rho) the
  // same in every frame (a sensor's fixed pattern) and partly fresh, each input reported with
  // its full sensor variance s^2. Ten frames fused as independent measurements would claim
  // s^2 / 10; with rho = 1 the error of their mean is still s. O-GM's mixture variance
  // (eq. 8: the spread of the window around its mean plus the inputs' variance) must cover
  // the actual error at every rho (issue 18).
  PinholeCamera cam;
  cam.width = cam.height = 60;
  cam.fx = cam.fy = 60.0;
  cam.cx = cam.cy = 29.5;
  const double z = 2.0, s = 1.425e-3 * z * z;  // eq. 1 at 2 m: 5.7 mm
  for (const double rho : {1.0, 0.5}) {
    std::mt19937 rng(rho == 1.0 ? 3 : 4);
    std::normal_distribution<float> n01;
    cv::Mat fixed(cam.height, cam.width, CV_32FC1);
    for (int i = 0; i < fixed.rows * fixed.cols; ++i) {
      fixed.at<float>(i) = static_cast<float>(s * std::sqrt(rho)) * n01(rng);
    }
    OgmFusion ogm;
    OgmResult res;
    for (int f = 0; f < 10; ++f) {
      DepthWithVariance d = uniform(cam, static_cast<float>(z), static_cast<float>(s * s));
      for (int i = 0; i < fixed.rows * fixed.cols; ++i) {
        d.depth_m.at<float>(i) +=
            fixed.at<float>(i) + static_cast<float>(s * std::sqrt(1 - rho)) * n01(rng);
      }
      ASSERT_TRUE(ogm.addFrame(f, cam, d));
      res = ogm.fuse(f, Pose3::Identity());
      ASSERT_TRUE(res.ok);
    }
    ASSERT_EQ(res.depth.window_length, 10);
    // Centre region (cos(alpha) ~ 1, so range and depth errors are the same).
    int n = 0, inside = 0, inside_if_independent = 0;
    double sum_sq = 0, sum_var = 0;
    for (int v = 15; v < 45; ++v) {
      for (int u = 15; u < 45; ++u) {
        const double e = res.depth.depth_m.at<float>(v, u) - z;
        const double var = res.depth.var_m2.at<float>(v, u);
        ++n;
        sum_sq += e * e;
        sum_var += var;
        inside += std::abs(e) < 2 * std::sqrt(var);
        inside_if_independent += std::abs(e) < 2 * s / std::sqrt(10.0);
      }
    }
    std::printf("rho %.1f: RMS error %.2f mm, RMS fused sigma %.2f mm, inside 2 sigma %.3f "
                "(%.3f with s / sqrt(10))\n",
                rho, 1e3 * std::sqrt(sum_sq / n), 1e3 * std::sqrt(sum_var / n),
                static_cast<double>(inside) / n, static_cast<double>(inside_if_independent) / n);
    EXPECT_GE(sum_var / n, 0.9 * sum_sq / n) << rho;  // not over-confident
    EXPECT_GT(static_cast<double>(inside) / n, 0.9) << rho;
    if (rho == 1.0) {
      EXPECT_LT(static_cast<double>(inside_if_independent) / n, 0.6);  // what 1/N would claim
      EXPECT_LT(sum_var / n, 1.5 * sum_sq / n);  // and not uselessly large either
    }
  }
}

TEST(OgmFusion, BadInputsAreCountedNotFatal) {
  const PinholeCamera cam = smallCamera();
  OgmFusion ogm;
  // Pose for a frame never added.
  EXPECT_FALSE(ogm.fuse(99, Pose3::Identity()).ok);
  EXPECT_EQ(ogm.stats().unknown_frame_poses, 1);
  // All-zero frame into an empty window: empty output, no crash.
  ASSERT_TRUE(ogm.addFrame(0, cam, uniform(cam, 0.f, 0.f)));
  OgmResult r = ogm.fuse(0, Pose3::Identity());
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(cv::countNonZero(r.depth.depth_m), 0);
  // Then an all-zero frame after a valid one: filled from the window with its variance.
  ASSERT_TRUE(ogm.addFrame(1, cam, uniform(cam, 2.0f, 1e-4f)));
  ASSERT_TRUE(ogm.fuse(1, Pose3::Identity()).ok);
  ASSERT_TRUE(ogm.addFrame(2, cam, uniform(cam, 0.f, 0.f)));
  r = ogm.fuse(2, Pose3::Identity());
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(cv::countNonZero(r.depth.depth_m), 25);
  EXPECT_NEAR(r.depth.depth_m.at<float>(2, 2), 2.0, 1e-5);
  EXPECT_NEAR(r.depth.var_m2.at<float>(2, 2), 1e-4, 1e-6);
  EXPECT_EQ(ogm.stats().pixels_filled, 25);
  // NaN pose.
  ASSERT_TRUE(ogm.addFrame(3, cam, uniform(cam, 2.0f, 1e-4f)));
  Pose3 bad = Pose3::Identity();
  bad.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(ogm.fuse(3, bad).ok);
  EXPECT_EQ(ogm.stats().invalid_poses, 1);
  EXPECT_FALSE(ogm.contains(3));
  // NaN depth / variance pixels are treated as missing and counted.
  DepthWithVariance d = uniform(cam, 2.0f, 1e-4f);
  d.depth_m.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  d.var_m2.at<float>(1, 1) = std::numeric_limits<float>::quiet_NaN();
  ASSERT_TRUE(ogm.addFrame(4, cam, d));
  EXPECT_EQ(ogm.stats().invalid_pixels, 2);
  // Wrong size for the camera: rejected and counted.
  PinholeCamera big = cam;
  big.width = 8;
  EXPECT_FALSE(ogm.addFrame(5, big, uniform(cam, 2.0f, 1e-4f)));
  EXPECT_EQ(ogm.stats().invalid_inputs, 1);
  // A different frame size resets the window with a counted warning.
  EXPECT_GE(ogm.windowSize(), 2);
  ASSERT_TRUE(ogm.addFrame(6, big, uniform(big, 2.0f, 1e-4f)));
  EXPECT_EQ(ogm.stats().size_changes, 1);
  EXPECT_EQ(ogm.windowSize(), 1);
  r = ogm.fuse(6, Pose3::Identity());
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.depth.window_length, 1);
  EXPECT_EQ(ogm.stats().warnings, 4);  // unknown, NaN pose, bad size, size change
}

// ------------------------------------------------- parallel fusion: bands, same results ---

/// Outputs and stats of fusing frames 0..n-1 in turn (each fused on its pose).
struct ThreadRun {
  std::vector<DepthWithVariance> out;
  OgmStats stats;
};

ThreadRun fuseWithThreads(const PinholeCamera& cam, const std::vector<DepthWithVariance>& frames,
                          const std::vector<Pose3>& T_w_c, int threads) {
  OgmOptions o;
  o.threads = threads;
  OgmFusion ogm(o);
  EXPECT_EQ(ogm.options().threads, ogmThreads(o));  // 0 resolved
  ThreadRun run;
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_TRUE(ogm.addFrame(static_cast<int64_t>(i), cam, frames[i]));
    OgmResult r = ogm.fuse(static_cast<int64_t>(i), T_w_c[i]);
    EXPECT_TRUE(r.ok) << r.warning;
    run.out.push_back(r.depth);
  }
  run.stats = ogm.stats();
  return run;
}

/// Bit-identical outputs (no NaN or infinity, where a != b would hide nothing) and equal stats.
void expectIdentical(const ThreadRun& a, const ThreadRun& b, const std::string& what) {
  ASSERT_EQ(a.out.size(), b.out.size()) << what;
  for (size_t i = 0; i < a.out.size(); ++i) {
    const DepthWithVariance &x = a.out[i], &y = b.out[i];
    ASSERT_EQ(x.depth_m.size(), y.depth_m.size()) << what;
    ASSERT_EQ(x.var_m2.size(), y.var_m2.size()) << what;
    EXPECT_TRUE(cv::checkRange(x.depth_m, true) && cv::checkRange(x.var_m2, true)) << what;
    EXPECT_TRUE(cv::checkRange(y.depth_m, true) && cv::checkRange(y.var_m2, true)) << what;
    EXPECT_EQ(cv::countNonZero(x.depth_m != y.depth_m), 0) << what << ", frame " << i;
    EXPECT_EQ(cv::countNonZero(x.var_m2 != y.var_m2), 0) << what << ", frame " << i;
    EXPECT_EQ(x.window_length, y.window_length) << what;
  }
  const OgmStats &s = a.stats, &t = b.stats;
  EXPECT_EQ(s.frames_added, t.frames_added) << what;
  EXPECT_EQ(s.frames_fused, t.frames_fused) << what;
  EXPECT_EQ(s.window_resets, t.window_resets) << what;
  EXPECT_EQ(s.size_changes, t.size_changes) << what;
  EXPECT_EQ(s.unknown_frame_poses, t.unknown_frame_poses) << what;
  EXPECT_EQ(s.invalid_poses, t.invalid_poses) << what;
  EXPECT_EQ(s.invalid_inputs, t.invalid_inputs) << what;
  EXPECT_EQ(s.invalid_pixels, t.invalid_pixels) << what;
  EXPECT_EQ(s.evicted_capacity, t.evicted_capacity) << what;
  EXPECT_EQ(s.evicted_uncertainty, t.evicted_uncertainty) << what;
  EXPECT_EQ(s.points_projected, t.points_projected) << what;
  EXPECT_EQ(s.points_gated, t.points_gated) << what;
  EXPECT_EQ(s.pixels_filled, t.pixels_filled) << what;
  EXPECT_EQ(s.warnings, t.warnings) << what;
  EXPECT_EQ(s.last_warning, t.last_warning) << what;
  EXPECT_EQ(s.last_window_length, t.last_window_length) << what;
}

Pose3 rpyPose(double roll, double pitch, double yaw, const Eigen::Vector3d& t) {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ());
  return makePose(t, q);
}

/// Planes through the last camera's centre (the world origin, identity pose) seen edge-on by
/// it: plane j holds the points with y = m_j z, which it projects to image row cy + fy m_j,
/// here 119.5, 159.5, 239.5, 319.5 and 359.5, exactly between the last rows of one band and
/// the first of the next for 2, 3 and 4 threads (bands of 480 / n rows). Earlier frames see
/// them from above and behind, so all their points land in those boundary rows of the last
/// frame (many points per pixel, at different ranges: the gate decides, in order).
TEST(OgmParallel, PointsOnBandBoundaryRowsSameForAnyThreadCount) {
  const PinholeCamera cam = AnalyticScene().camera();  // 640x480, f 525, centre (319.5, 239.5)
  ASSERT_EQ(cam.height, 480);
  ASSERT_DOUBLE_EQ(cam.fy, 525.0);
  ASSERT_DOUBLE_EQ(cam.cy, 239.5);
  const double rows[5] = {119.5, 159.5, 239.5, 319.5, 359.5};
  constexpr int kN = 8;  // frames 0..6 from above, frame 7 (identity) sees the planes edge-on
  std::vector<Pose3> poses;
  for (int i = 0; i < kN - 1; ++i) {
    poses.push_back(rpyPose(0.02 * (i - 3), -(0.25 + 0.03 * i), 0.03 * (i - 3),
                            Eigen::Vector3d(0.05 * i - 0.15, -0.3 - 0.02 * i, -0.4 - 0.03 * i)));
  }
  poses.push_back(Pose3::Identity());
  std::vector<DepthWithVariance> frames;
  for (const Pose3& T : poses) {
    DepthWithVariance d;
    d.depth_m = cv::Mat::zeros(cam.height, cam.width, CV_32FC1);
    d.var_m2 = cv::Mat::zeros(cam.height, cam.width, CV_32FC1);
    const Eigen::Vector3d o = T.translation();
    for (int v = 0; v < cam.height; ++v) {
      for (int u = 0; u < cam.width; ++u) {
        const Eigen::Vector3d dir = T.linear() * cam.ray(u, v);  // camera z = 1: s is the depth
        double best = std::numeric_limits<double>::infinity();
        for (const double row : rows) {
          const double m = (row - cam.cy) / cam.fy;
          const double den = dir.y() - m * dir.z();
          if (std::abs(den) < 1e-9) continue;
          const double s = -(o.y() - m * o.z()) / den;
          if (s > 0.2 && s < 8.0 && (o + s * dir).z() > 0.3) best = std::min(best, s);
        }
        if (!std::isfinite(best)) continue;
        const double sigma = 1.425e-3 * best * best;
        d.depth_m.at<float>(v, u) = static_cast<float>(best);
        d.var_m2.at<float>(v, u) = static_cast<float>(sigma * sigma);
      }
    }
    frames.push_back(d);
  }
  ASSERT_EQ(cv::countNonZero(frames.back().depth_m), 0);  // edge-on: nothing seen
  ASSERT_GT(cv::countNonZero(frames.front().depth_m), 100000);

  const ThreadRun serial = fuseWithThreads(cam, frames, poses, 1);
  // Not vacuous: the last fusion fills (almost) only the boundary rows, with many points each,
  // and the gate rejects some of them.
  const cv::Mat& last = serial.out.back().depth_m;
  int in_rows = 0;
  for (const double row : rows) {
    for (const int v : {static_cast<int>(row - 0.5), static_cast<int>(row + 0.5)})
      in_rows += cv::countNonZero(last.row(v));
  }
  EXPECT_GT(in_rows, 2000);
  EXPECT_GT(in_rows, cv::countNonZero(last) * 9 / 10);
  EXPECT_GT(serial.stats.points_gated, 10000);
  for (const int threads : {0, 2, 3, 4}) {
    expectIdentical(serial, fuseWithThreads(cam, frames, poses, threads),
                    std::to_string(threads) + " threads");
  }
}

TEST(OgmThreads, ZeroLeavesOneHardwareThreadToTheRestOfThePipeline) {
  OgmOptions o;
  EXPECT_EQ(o.threads, 0);  // the default
  const int hardware = static_cast<int>(std::thread::hardware_concurrency());
  EXPECT_EQ(ogmThreads(o), std::max(1, hardware - 1));
  o.threads = 3;
  EXPECT_EQ(ogmThreads(o), 3);
  o.threads = 1;
  EXPECT_EQ(OgmFusion(o).options().threads, 1);
}

TEST(OgmParallel, MoreThreadsThanRows) {
  const PinholeCamera cam = smallCamera();  // 5 rows: 5 bands of one row
  std::vector<DepthWithVariance> frames;
  std::vector<Pose3> poses;
  for (int i = 0; i < 6; ++i) {
    frames.push_back(uniform(cam, 2.0f + 0.01f * static_cast<float>(i % 3), 1e-4f));
    poses.push_back(rpyPose(0.3 * i, 0.0, 0.0, Eigen::Vector3d(0.0, 0.05 * i, 0.0)));
  }
  const ThreadRun serial = fuseWithThreads(cam, frames, poses, 1);
  EXPECT_GT(serial.stats.points_projected, 50);
  expectIdentical(serial, fuseWithThreads(cam, frames, poses, 8), "8 threads, 5 rows");
}

// ---------------------------------------------------------------- analytic noisy scene ---

struct Errors {
  double sse = 0;
  int64_t n = 0;
  void add(double e) {
    sse += e * e;
    ++n;
  }
  double rmse() const { return n ? std::sqrt(sse / static_cast<double>(n)) : 0.0; }
};

struct FusedRun {
  std::vector<DepthWithVariance> out;  // per frame
};

constexpr int kFrames = 14;
constexpr int kFirstEval = 10;  // windows full from here on

class SceneTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SceneOptions o;
    o.moving_object = true;
    scene_ = new AnalyticScene(o);
    frames_ = new std::vector<SceneFrame>();
    for (int i = 0; i < kFrames; ++i) frames_->push_back(scene_->render(i));
    CgmFilter cgm;
    cgm_ = new std::vector<DepthWithVariance>();
    for (const SceneFrame& f : *frames_) cgm_->push_back(cgm.apply(f.depth_m));
    ogm5_ = new FusedRun(fuseAll(5));
    ogm10_ = new FusedRun(fuseAll(10));
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete frames_;
    delete cgm_;
    delete ogm5_;
    delete ogm10_;
  }
  static FusedRun fuseAll(int window) {
    OgmFusion::Options o;
    o.max_window = window;
    OgmFusion ogm(o);
    FusedRun run;
    for (int i = 0; i < kFrames; ++i) {
      EXPECT_TRUE(ogm.addFrame(i, scene_->camera(), (*cgm_)[i]));
      OgmResult r = ogm.fuse(i, (*frames_)[i].T_w_c);
      EXPECT_TRUE(r.ok);
      EXPECT_EQ(r.depth.window_length, std::min(i + 1, window));
      run.out.push_back(r.depth);
    }
    return run;
  }
  /// Pixels with raw and true depth: the same set for every method.
  static bool evaluable(const SceneFrame& f, int v, int u) {
    return f.depth_m.at<float>(v, u) > 0.f && f.depth_true_m.at<float>(v, u) > 0.f;
  }
  static cv::Mat flatWall(const SceneFrame& f) {
    // Wall pixels whose 9x9 neighbourhood is wall (away from box edges).
    cv::Mat m = cv::Mat::zeros(f.label.size(), CV_8UC1);
    for (int v = 4; v < m.rows - 4; ++v)
      for (int u = 4; u < m.cols - 4; ++u) {
        bool all = true;
        for (int dv = -4; dv <= 4 && all; ++dv)
          for (int du = -4; du <= 4 && all; ++du)
            all = f.label.at<uint8_t>(v + dv, u + du) == fixtures::kWall;
        m.at<uint8_t>(v, u) = all ? 255 : 0;
      }
    return m;
  }
  static cv::Mat discontinuities(const SceneFrame& f) {
    cv::Mat m = cv::Mat::zeros(f.label.size(), CV_8UC1);
    for (int v = 2; v < m.rows - 2; ++v)
      for (int u = 2; u < m.cols - 2; ++u) {
        float lo = 1e9f, hi = 0.f;
        for (int dv = -2; dv <= 2; ++dv)
          for (int du = -2; du <= 2; ++du) {
            const float z = f.depth_true_m.at<float>(v + dv, u + du);
            lo = std::min(lo, z);
            hi = std::max(hi, z);
          }
        m.at<uint8_t>(v, u) =
            (hi - lo > 0.1f && f.label.at<uint8_t>(v, u) != fixtures::kMoving) ? 255 : 0;
      }
    return m;
  }
  static double median(std::vector<float> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  }

  static AnalyticScene* scene_;
  static std::vector<SceneFrame>* frames_;
  static std::vector<DepthWithVariance>* cgm_;
  static FusedRun* ogm5_;
  static FusedRun* ogm10_;
};
AnalyticScene* SceneTest::scene_ = nullptr;
std::vector<SceneFrame>* SceneTest::frames_ = nullptr;
std::vector<DepthWithVariance>* SceneTest::cgm_ = nullptr;
FusedRun* SceneTest::ogm5_ = nullptr;
FusedRun* SceneTest::ogm10_ = nullptr;

/// A fusion limited to W frames of a longer window is the O-GM_W fusion of that frame, bit for
/// bit (frames are fused newest to oldest), and the frames it left out stay in the window: the
/// next unlimited fusion is the O-GM_10 one again.
TEST_F(SceneTest, WindowLimitFusesTheNewestFramesAndKeepsTheRest) {
  OgmFusion ogm;  // max_window 10
  const int limited = kFirstEval + 1;
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_TRUE(ogm.addFrame(i, scene_->camera(), (*cgm_)[i]));
    OgmResult r;
    ogm.fuse(i, (*frames_)[i].T_w_c, &r, i == limited ? 5 : 0);
    ASSERT_TRUE(r.ok);
    const DepthWithVariance& want = (i == limited ? ogm5_ : ogm10_)->out[static_cast<size_t>(i)];
    EXPECT_EQ(r.depth.window_length, want.window_length) << "frame " << i;
    EXPECT_EQ(cv::countNonZero(r.depth.depth_m != want.depth_m), 0) << "frame " << i;
    EXPECT_EQ(cv::countNonZero(r.depth.var_m2 != want.var_m2), 0) << "frame " << i;
    EXPECT_EQ(ogm.windowSize(), std::min(i + 1, 10));
  }
  EXPECT_EQ(ogm.stats().frames_fused_limited, 1);
  // Not vacuous: the shorter window gives another result.
  const size_t f = static_cast<size_t>(limited);
  EXPECT_GT(cv::countNonZero(ogm5_->out[f].depth_m != ogm10_->out[f].depth_m), 1000);
}

TEST_F(SceneTest, ThreadCountDoesNotChangeResults) {
  std::vector<Pose3> poses;
  for (const SceneFrame& f : *frames_) poses.push_back(f.T_w_c);
  const ThreadRun serial = fuseWithThreads(scene_->camera(), *cgm_, poses, 1);
  EXPECT_GT(serial.stats.points_gated, 0);
  for (const int threads : {2, 3}) {
    expectIdentical(serial, fuseWithThreads(scene_->camera(), *cgm_, poses, threads),
                    std::to_string(threads) + " threads");
  }
}

/// The same frames fused on poses far from the true ones: rolls of 90 and 180 degrees (rows
/// become columns or reverse), a 25 degree pitch (~250 rows), a 75 degree yaw and a camera 2.5 m
/// back (points near the image plane, no row bound), so that points cross every band.
TEST_F(SceneTest, LargeMotionAcrossBandsSameForAnyThreadCount) {
  const double kPi = 3.14159265358979323846;
  const Pose3 motions[] = {
      rpyPose(kPi / 2, 0.0, 0.0, Eigen::Vector3d(0.1, 0.0, 0.0)),
      rpyPose(kPi, 0.0, 0.0, Eigen::Vector3d::Zero()),
      rpyPose(0.0, 25 * kPi / 180, 0.0, Eigen::Vector3d(0.0, 0.4, 0.0)),
      rpyPose(0.1, 0.0, 75 * kPi / 180, Eigen::Vector3d(0.5, 0.0, 0.3)),
      rpyPose(0.0, 0.0, 0.0, Eigen::Vector3d(0.0, 0.0, -2.5)),
      rpyPose(-kPi / 3, -0.2, 0.3, Eigen::Vector3d(-0.3, 0.2, 0.5)),
  };
  std::vector<Pose3> poses;
  for (size_t i = 0; i < frames_->size(); ++i) {
    poses.push_back((*frames_)[i].T_w_c * motions[i % (sizeof(motions) / sizeof(motions[0]))]);
  }
  const ThreadRun serial = fuseWithThreads(scene_->camera(), *cgm_, poses, 1);
  EXPECT_GT(serial.stats.points_projected, 1000000);
  EXPECT_GT(serial.stats.points_gated, 0);
  for (const int threads : {2, 3}) {
    expectIdentical(serial, fuseWithThreads(scene_->camera(), *cgm_, poses, threads),
                    std::to_string(threads) + " threads");
  }
}

TEST_F(SceneTest, DepthRmseOgm10BelowCgmAndRaw) {
  Errors raw, cgm, o5, o10;
  for (int i = kFirstEval; i < kFrames; ++i) {
    const SceneFrame& f = (*frames_)[i];
    for (int v = 0; v < f.depth_m.rows; ++v)
      for (int u = 0; u < f.depth_m.cols; ++u) {
        if (!evaluable(f, v, u) || f.label.at<uint8_t>(v, u) == fixtures::kMoving) continue;
        const double t = f.depth_true_m.at<float>(v, u);
        raw.add(f.depth_m.at<float>(v, u) - t);
        cgm.add((*cgm_)[i].depth_m.at<float>(v, u) - t);
        o5.add(ogm5_->out[i].depth_m.at<float>(v, u) - t);
        o10.add(ogm10_->out[i].depth_m.at<float>(v, u) - t);
      }
  }
  std::printf("depth RMSE (static surfaces) mm: raw %.2f  C-GM %.2f  O-GM5 %.2f  O-GM10 %.2f\n",
              1e3 * raw.rmse(), 1e3 * cgm.rmse(), 1e3 * o5.rmse(), 1e3 * o10.rmse());
  EXPECT_LT(o10.rmse(), 0.9 * cgm.rmse());
  EXPECT_LT(o10.rmse(), 0.9 * raw.rmse());
}

TEST_F(SceneTest, PlanarResidualDecreasesRawOgm5Ogm10) {
  Errors raw, o5, o10;
  const PinholeCamera cam = scene_->camera();
  for (int i = kFirstEval; i < kFrames; ++i) {
    const SceneFrame& f = (*frames_)[i];
    const cv::Mat wall = flatWall(f);
    const Eigen::Vector4d pw = scene_->wallPlaneW();
    const Eigen::Vector3d n_c = f.T_w_c.linear().transpose() * pw.head<3>();
    const double d_c = pw.head<3>().dot(f.T_w_c.translation()) + pw[3];
    auto residual = [&](int v, int u, float z) { return n_c.dot(cam.backproject(u, v, z)) + d_c; };
    for (int v = 0; v < wall.rows; ++v)
      for (int u = 0; u < wall.cols; ++u) {
        if (!wall.at<uint8_t>(v, u) || !evaluable(f, v, u)) continue;
        raw.add(residual(v, u, f.depth_m.at<float>(v, u)));
        o5.add(residual(v, u, ogm5_->out[i].depth_m.at<float>(v, u)));
        o10.add(residual(v, u, ogm10_->out[i].depth_m.at<float>(v, u)));
      }
  }
  std::printf("wall planar residual RMSE mm: raw %.2f  O-GM5 %.2f  O-GM10 %.2f (%lld px)\n",
              1e3 * raw.rmse(), 1e3 * o5.rmse(), 1e3 * o10.rmse(), static_cast<long long>(raw.n));
  ASSERT_GT(raw.n, 10000);
  EXPECT_LT(o5.rmse(), 0.9 * raw.rmse());
  EXPECT_LT(o10.rmse(), 0.95 * o5.rmse());
}

TEST_F(SceneTest, UncertaintyCalibratedAndHigherAtEdgesAndMovingObject) {
  int64_t in2_raw = 0, in2_cgm = 0, in2_o10 = 0, n = 0;
  std::vector<float> wall_var, edge_var, moving_var, wall_var_cgm, edge_var_cgm;
  const QuadraticSensorModel sensor;
  for (int i = kFirstEval; i < kFrames; ++i) {
    const SceneFrame& f = (*frames_)[i];
    const cv::Mat wall = flatWall(f);
    const cv::Mat edges = discontinuities(f);
    const DepthWithVariance& o10 = ogm10_->out[i];
    for (int v = 0; v < f.depth_m.rows; ++v)
      for (int u = 0; u < f.depth_m.cols; ++u) {
        const double t = f.depth_true_m.at<float>(v, u);
        const float vc = (*cgm_)[i].var_m2.at<float>(v, u);
        const float vo = o10.var_m2.at<float>(v, u);
        if (evaluable(f, v, u) && f.label.at<uint8_t>(v, u) != fixtures::kMoving) {
          ++n;
          const float zr = f.depth_m.at<float>(v, u);
          in2_raw += std::abs(zr - t) < 2 * std::sqrt(sensor.varianceM2(zr));
          in2_cgm += std::abs((*cgm_)[i].depth_m.at<float>(v, u) - t) < 2 * std::sqrt(vc);
          in2_o10 += std::abs(o10.depth_m.at<float>(v, u) - t) < 2 * std::sqrt(vo);
        }
        if (t <= 0) continue;
        if (wall.at<uint8_t>(v, u) && o10.depth_m.at<float>(v, u) > 0) {
          wall_var.push_back(vo);
          if (vc > 0) wall_var_cgm.push_back(vc);
        }
        if (edges.at<uint8_t>(v, u) && o10.depth_m.at<float>(v, u) > 0) {
          edge_var.push_back(vo);
          if (vc > 0) edge_var_cgm.push_back(vc);
        }
        if (f.label.at<uint8_t>(v, u) == fixtures::kMoving && o10.depth_m.at<float>(v, u) > 0)
          moving_var.push_back(vo);
      }
  }
  const double nd = static_cast<double>(n);
  const double f_raw = in2_raw / nd, f_cgm = in2_cgm / nd, f_o10 = in2_o10 / nd;
  const double mw = median(wall_var), me = median(edge_var), mm = median(moving_var);
  auto mean = [](const std::vector<float>& v) {
    double a = 0;
    for (float x : v) a += x;
    return v.empty() ? 0.0 : a / static_cast<double>(v.size());
  };
  std::printf("rms sigma mm: wall O-GM10 %.2f, discontinuities O-GM10 %.2f (C-GM %.2f)\n",
              1e3 * std::sqrt(mean(wall_var)), 1e3 * std::sqrt(mean(edge_var)),
              1e3 * std::sqrt(mean(edge_var_cgm)));
  std::printf("fraction |err| < 2 sigma: raw+sensor model %.3f  C-GM %.3f  O-GM10 %.3f\n", f_raw,
              f_cgm, f_o10);
  std::printf(
      "median sigma mm: wall O-GM10 %.2f (C-GM %.2f), discontinuities O-GM10 %.2f "
      "(C-GM %.2f), moving object O-GM10 %.2f\n",
      1e3 * std::sqrt(mw), 1e3 * std::sqrt(median(wall_var_cgm)), 1e3 * std::sqrt(me),
      1e3 * std::sqrt(median(edge_var_cgm)), 1e3 * std::sqrt(mm));
  // Stage 1 alone is a per-pixel sensor sigma: close to Gaussian 95 % (quantisation widens
  // the tails). C-GM and O-GM variances are the spread of the mixture (eq. 5), not the error of
  // its mean, hence conservative: measured 0.99-1.00 (docs/depth_filter.md).
  EXPECT_GT(f_raw, 0.88);
  EXPECT_LT(f_raw, 0.99);
  EXPECT_GT(f_cgm, 0.97);
  EXPECT_GT(f_o10, 0.97);
  ASSERT_GT(edge_var.size(), 1000u);
  ASSERT_GT(moving_var.size(), 1000u);
  // With edge dropout most pixels 2 px from a jump are clean (median sigma as on the wall:
  // printed above); the variance concentrates on the pixels fused across the jump, so the
  // mean variance there is far higher than on the wall (measured 25x).
  EXPECT_GT(mean(edge_var), 4 * mean(wall_var));
  EXPECT_GT(mm, 4 * mw);  // moving object: median variance (measured 9.6x)
  (void)me;
}

}  // namespace
}  // namespace pplvo::depth_filter
