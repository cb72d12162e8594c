// Depth of a separate depth camera registered into the colour camera (depth_registration.h):
// hand-computed projections (offset, rotation, occlusion, holes, resolution), the identity, the
// variance against a Monte Carlo of the sensor model, and the measurement stages on such frames.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "pplvo/depth_filter/depth_registration.h"
#include "pplvo/depth_filter/measurement_stages.h"

namespace pplvo::depth_filter {
namespace {

PinholeCamera camera(int w, int h, double f) {
  PinholeCamera c;
  c.width = w;
  c.height = h;
  c.fx = c.fy = f;
  c.cx = (w - 1) / 2.0;
  c.cy = (h - 1) / 2.0;
  return c;
}

DepthCamera rig(const PinholeCamera& depth_camera, const Eigen::Matrix3d& R_c_d,
                const Eigen::Vector3d& t_c_d) {
  DepthCamera d;
  d.camera = depth_camera;
  d.T_c_d.linear() = R_c_d;
  d.T_c_d.translation() = t_c_d;
  return d;
}

const QuadraticSensorModel kModel;

TEST(DepthRegistration, IdentityExtrinsicsAndEqualIntrinsicsIsTheIdentity) {
  const PinholeCamera cam = camera(64, 48, 50);
  cv::Mat depth(cam.height, cam.width, CV_32FC1);
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      // A slanted plane, a step to a nearer box, a 3x3 hole and a missing border column.
      float z = 2.0f + 0.01f * u + 0.005f * v;
      if (u >= 40 && u < 50 && v >= 10 && v < 30) z = 0.9f;
      if (u >= 10 && u < 13 && v >= 20 && v < 23) z = 0.0f;
      if (u == 0) z = 0.0f;
      depth.at<float>(v, u) = z;
    }
  }
  DepthRegistration reg;
  const DepthWithVariance out =
      reg.apply(cam, rig(cam, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()), depth, kModel);
  const DepthWithVariance stage1 = applySensorModel(kModel, depth);
  ASSERT_EQ(out.depth_m.size(), depth.size());
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const float z = depth.at<float>(v, u);
      ASSERT_EQ(out.depth_m.at<float>(v, u), z) << u << "," << v;
      ASSERT_EQ(out.var_m2.at<float>(v, u), stage1.var_m2.at<float>(v, u)) << u << "," << v;
    }
  }
  EXPECT_EQ(reg.stats().last_points, cv::countNonZero(depth));
  EXPECT_EQ(reg.stats().last_pixels_out, cv::countNonZero(depth));
}

TEST(DepthRegistration, PureOffsetShiftsByFocalTimesBaselineOverDepth) {
  const PinholeCamera cam = camera(64, 48, 50);
  cv::Mat depth(cam.height, cam.width, CV_32FC1, cv::Scalar(0.0f));
  depth.at<float>(20, 30) = 1.0f;
  depth.at<float>(30, 10) = 2.5f;
  // The depth camera 4 cm to the right of the colour camera (p_c = p_d + (0.04, 0, 0.1)):
  // x_c = x_d + 0.04, z_c = z_d + 0.1, u_c = 50 x_c / z_c + 31.5.
  DepthRegistration reg;
  const DepthWithVariance out = reg.apply(
      cam, rig(cam, Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.04, 0, 0.1)), depth, kModel);
  // (30, 20) at 1 m: x_d = -1.5/50 = -0.03, y_d = -3.5/50 = -0.07; x_c = 0.01 / 1.1 m,
  // u = 50 * 0.01 / 1.1 + 31.5 = 31.95 -> 32; v = 50 * -0.07 / 1.1 + 23.5 = 20.32 -> 20.
  EXPECT_FLOAT_EQ(out.depth_m.at<float>(20, 32), 1.1f);
  // Same direction (no rotation): a = 1, the variance of the measured 1 m.
  EXPECT_FLOAT_EQ(out.var_m2.at<float>(20, 32), kModel.varianceM2(1.0f));
  // (10, 30) at 2.5 m: x_d = -21.5/50 * 2.5 = -1.075, x_c = -1.035; z_c = 2.6;
  // u = 50 * -1.035 / 2.6 + 31.5 = 11.596 -> 12; v = 50 * 6.5/50 * 2.5 / 2.6 + 23.5 = 29.75 -> 30.
  EXPECT_FLOAT_EQ(out.depth_m.at<float>(30, 12), 2.6f);
  EXPECT_EQ(cv::countNonZero(out.depth_m), 2);
}

TEST(DepthRegistration, RotationMovesTheAxisAndScalesTheVarianceByCosineSquared) {
  const PinholeCamera dc = camera(65, 49, 50);  // principal point (32, 24) on a pixel
  const PinholeCamera cam = dc;
  cv::Mat d2(dc.height, dc.width, CV_32FC1, cv::Scalar(0.0f));
  d2.at<float>(24, 32) = 2.0f;  // on the depth camera's axis
  const double theta = 10.0 * M_PI / 180.0;
  // R_c_d rotates the depth camera's axis by +10 deg about y: p_c = (2 sin, 0, 2 cos).
  const Eigen::Matrix3d R = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitY()).toRotationMatrix();
  DepthRegistration reg;
  const DepthWithVariance out = reg.apply(cam, rig(dc, R, Eigen::Vector3d::Zero()), d2, kModel);
  // u = 50 tan(10 deg) + 32 = 40.816 -> 41; v = 24. The point covers 1 / cos(10 deg) = 1.015
  // px: [40.31, 41.32) x [23.49, 24.51), pixel centres 41 and 24 only.
  const float z_c = static_cast<float>(2.0 * std::cos(theta));
  EXPECT_NEAR(out.depth_m.at<float>(24, 41), z_c, 1e-6);
  // dz_c / dz_d = cos(theta).
  EXPECT_NEAR(out.var_m2.at<float>(24, 41),
              std::cos(theta) * std::cos(theta) * kModel.varianceM2(2.0f), 1e-12);
  EXPECT_EQ(cv::countNonZero(out.depth_m), 1);
}

TEST(DepthRegistration, NearestSurfaceHidesTheFarOneAndKeepsItsVariance) {
  const PinholeCamera cam = camera(64, 48, 50);
  cv::Mat depth(cam.height, cam.width, CV_32FC1, cv::Scalar(0.0f));
  // A 4 cm baseline shifts a point f * 0.04 / z px to the left: 2 px at 1 m, 1 px at 2 m.
  depth.at<float>(10, 12) = 1.0f;  // to (10, 10)
  depth.at<float>(10, 11) = 2.0f;  // to (10, 10) too: hidden
  depth.at<float>(10, 30) = 2.0f;  // to (10, 29)
  depth.at<float>(10, 31) = 1.0f;  // to (10, 29) too: hides it
  DepthRegistration reg;
  const DepthWithVariance out = reg.apply(
      cam, rig(cam, Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.04, 0, 0)), depth, kModel);
  EXPECT_FLOAT_EQ(out.depth_m.at<float>(10, 10), 1.0f);
  EXPECT_FLOAT_EQ(out.var_m2.at<float>(10, 10), kModel.varianceM2(1.0f));
  EXPECT_FLOAT_EQ(out.depth_m.at<float>(10, 29), 1.0f);  // whichever order they come in
  EXPECT_FLOAT_EQ(out.var_m2.at<float>(10, 29), kModel.varianceM2(1.0f));
  EXPECT_EQ(cv::countNonZero(out.depth_m), 2);
}

TEST(DepthRegistration, HolesAndTheDisoccludedBackgroundStayEmpty) {
  const PinholeCamera cam = camera(64, 48, 50);
  cv::Mat depth(cam.height, cam.width, CV_32FC1, cv::Scalar(2.0f));
  for (int v = 10; v < 20; ++v) {
    for (int u = 20; u < 30; ++u) depth.at<float>(v, u) = 0.5f;  // a near box
  }
  for (int v = 30; v < 33; ++v) {
    for (int u = 40; u < 43; ++u) depth.at<float>(v, u) = 0.0f;  // a 3x3 hole
  }
  // Depth camera 5 cm to the left: background shifts 50 * 0.05 / 2 = 1.25 px right, the box
  // 50 * 0.05 / 0.5 = 5 px right. Background column 19 lands on 20.25, the box (20..29) on
  // 25..34: the colour camera sees background at 21..24 that the box hid from the depth
  // camera, which stays empty. Right of the box, background columns 30..33 land on
  // 31.25..34.25, behind the box; column 34 on 35.25.
  DepthRegistration reg;
  const DepthWithVariance out = reg.apply(
      cam, rig(cam, Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.05, 0, 0)), depth, kModel);
  for (int v = 11; v < 19; ++v) {
    for (int u = 21; u <= 24; ++u) EXPECT_EQ(out.depth_m.at<float>(v, u), 0.0f) << u << "," << v;
    EXPECT_EQ(out.depth_m.at<float>(v, 20), 2.0f);
    for (int u = 25; u <= 34; ++u) EXPECT_EQ(out.depth_m.at<float>(v, u), 0.5f) << u << "," << v;
    EXPECT_EQ(out.depth_m.at<float>(v, 35), 2.0f);
  }
  // The hole (columns 40..42) moves to 41.25..43.25: pixels 41..43 stay empty, column 39
  // lands on 40.25, column 43 on 44.25.
  for (int v = 31; v < 33; ++v) {
    EXPECT_EQ(out.depth_m.at<float>(v, 40), 2.0f);
    for (int u = 41; u <= 43; ++u) EXPECT_EQ(out.depth_m.at<float>(v, u), 0.0f) << u << "," << v;
    EXPECT_EQ(out.depth_m.at<float>(v, 44), 2.0f);
  }
}

TEST(DepthRegistration, LowerResolutionDepthCoversItsFootprintWithoutASieve) {
  // Depth at half the colour camera's resolution, same field of view: each depth pixel covers
  // 2x2 colour pixels.
  const PinholeCamera colour = camera(64, 48, 50);
  const PinholeCamera dc = camera(32, 24, 25);
  const cv::Mat depth(dc.height, dc.width, CV_32FC1, cv::Scalar(2.0f));
  DepthRegistration reg;
  const DepthWithVariance out = reg.apply(
      colour, rig(dc, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()), depth, kModel);
  EXPECT_EQ(cv::countNonZero(out.depth_m), colour.width * colour.height);
  EXPECT_FLOAT_EQ(out.var_m2.at<float>(17, 33), kModel.varianceM2(2.0f));
}

TEST(DepthRegistration, NarrowerDepthCameraFillsOnlyTheCentreOfAWideColourImage) {
  // Colour: 64 px over 2 atan(32/25) = 104 deg; depth: 64 px over 2 atan(32/100) = 35 deg. The
  // depth view spans |u - cx| <= 25 * 32 / 100 = 8 colour px (|x| <= 0.3175 / 0.32 at the edge
  // pixel centres: 7.94 px).
  const PinholeCamera colour = camera(64, 48, 25);
  const PinholeCamera dc = camera(64, 48, 100);
  const cv::Mat depth(dc.height, dc.width, CV_32FC1, cv::Scalar(3.0f));
  DepthRegistration reg;
  const DepthWithVariance out = reg.apply(
      colour, rig(dc, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()), depth, kModel);
  for (int u = 0; u < colour.width; ++u) {
    const bool inside = std::abs(u - colour.cx) < 7.9;
    EXPECT_EQ(out.depth_m.at<float>(24, u) > 0, inside) << u;
  }
  // Depth pixels are 4x smaller than colour pixels: several land on each; all at 3 m.
  EXPECT_FLOAT_EQ(out.depth_m.at<float>(24, 32), 3.0f);
}

TEST(DepthRegistration, DenserDepthIsNotBiasedTowardsTheCamera) {
  // A depth camera with twice the colour camera's focal length lands four noisy samples of a
  // wall at 2 m on each colour pixel: each pixel takes the one whose footprint holds its
  // centre, not the nearest of the four (about one sigma too near).
  const PinholeCamera colour = camera(64, 48, 50);
  const PinholeCamera dc = camera(128, 96, 100);
  cv::Mat depth(dc.height, dc.width, CV_32FC1);
  cv::RNG rng(7);
  const double sigma = std::sqrt(kModel.varianceM2(2.0f));
  for (int v = 0; v < dc.height; ++v) {
    for (int u = 0; u < dc.width; ++u) {
      depth.at<float>(v, u) = static_cast<float>(2.0 + sigma * rng.gaussian(1.0));
    }
  }
  DepthRegistration reg;
  const DepthWithVariance out = reg.apply(
      colour, rig(dc, Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.01, 0, 0)), depth, kModel);
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int v = 2; v < colour.height - 2; ++v) {
    for (int u = 2; u < colour.width - 2; ++u) {
      const float z = out.depth_m.at<float>(v, u);
      ASSERT_GT(z, 0.0f) << u << "," << v;
      sum += z - 2.0;
      sum2 += (z - 2.0) * (z - 2.0);
      ++n;
    }
  }
  // The mean error near 0: the nearest of four would be -1.03 sigma; what remains (-0.08 sigma)
  // comes from the pixels whose centre lies on a footprint boundary and no footprint holds,
  // which keep the nearest. The spread is that of one sample.
  EXPECT_NEAR(sum / n, 0.0, 0.2 * sigma);
  EXPECT_NEAR(std::sqrt(sum2 / n), sigma, 0.1 * sigma);
}

TEST(DepthRegistration, VarianceMatchesAMonteCarloOfTheSensorModel) {
  // Colour camera looking at a plane z_c = 2 m; a depth camera turned 30 deg about y and 5 cm
  // aside sees it obliquely (z_d = (2 - t_z) / a, a = r_3 . ray). Sparse points (every 4 px
  // of the depth camera, each covering about 3.3 x 3.3 colour px) so that the pixel a point's
  // noiseless projection rounds to holds that point and no other in every trial (the noise
  // moves a projection by < 0.5 px through the 1.1 m baseline).
  const PinholeCamera colour = camera(128, 96, 150);
  const PinholeCamera dc = camera(64, 48, 50);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(30.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d t(-1.1, 0.02, 0.05);
  const DepthCamera d = rig(dc, R, t);
  struct Point {
    int u, v;
    double z_d;
    int uc, vc;  // colour pixel of the noiseless projection
    double sum = 0, sum2 = 0, pred = 0;
    int n = 0;
  };
  std::vector<Point> points;
  for (int v = 2; v < dc.height; v += 4) {
    for (int u = 2; u < dc.width; u += 4) {
      const Eigen::Vector3d ray = dc.ray(u, v);
      const double a = R.row(2).dot(ray);
      const double z_d = (2.0 - t.z()) / a;
      const Eigen::Vector2d px = colour.project(R * (ray * z_d) + t);
      if (!colour.inImage(px, 2)) continue;
      points.push_back({u, v, z_d, static_cast<int>(std::lround(px.x())),
                        static_cast<int>(std::lround(px.y()))});
    }
  }
  ASSERT_GT(points.size(), 40u);
  std::mt19937 rng(23);
  std::normal_distribution<double> n01;
  DepthRegistration reg;
  cv::Mat depth(dc.height, dc.width, CV_32FC1);
  const int kTrials = 400;
  for (int trial = 0; trial < kTrials; ++trial) {
    depth.setTo(0.0f);
    for (const Point& p : points) {
      const double sigma = std::sqrt(kModel.varianceM2(static_cast<float>(p.z_d)));
      depth.at<float>(p.v, p.u) = static_cast<float>(p.z_d + sigma * n01(rng));
    }
    const DepthWithVariance out = reg.apply(colour, d, depth, kModel);
    for (Point& p : points) {
      const float z = out.depth_m.at<float>(p.vc, p.uc);
      ASSERT_GT(z, 0.0f) << p.u << "," << p.v << " -> " << p.uc << "," << p.vc;
      p.sum += z - 2.0;
      p.sum2 += (z - 2.0) * (z - 2.0);
      p.pred += out.var_m2.at<float>(p.vc, p.uc);
      ++p.n;
    }
  }
  // NEES of the registered depth against the truth (2 m): 1 on average; without the factor
  // a^2 it would be the mean of 1 / a^2 (checked to be far from 1).
  double nees = 0, without_a = 0;
  for (const Point& p : points) {
    nees += p.sum2 / p.pred;
    without_a += 1.0 / std::pow(R.row(2).dot(dc.ray(p.u, p.v)), 2);
  }
  nees /= static_cast<double>(points.size());
  without_a /= static_cast<double>(points.size());
  EXPECT_GT(std::abs(without_a - 1.0), 0.2);
  EXPECT_NEAR(nees, 1.0, 0.05);
  // And per point within a chi-square bound of 400 samples (99.9 %: +-25 %).
  for (const Point& p : points) {
    EXPECT_NEAR(p.sum2 / p.pred, 1.0, 0.25) << p.u << "," << p.v;
    EXPECT_NEAR(p.sum / p.n, 0.0, 4 * std::sqrt(p.pred / p.n / p.n)) << p.u << "," << p.v;
  }
}

TEST(MeasurementStages, UnregisteredDepthWithAnIdentityRigGivesTheRegisteredResult) {
  RgbdFrame frame;
  frame.camera = camera(64, 48, 50);
  frame.depth_m = cv::Mat(48, 64, CV_32FC1);
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) {
      frame.depth_m.at<float>(v, u) = (u > 20 && u < 30) ? 0.8f : 1.5f + 0.02f * v;
    }
  }
  for (DepthModel model : {DepthModel::kSensor, DepthModel::kCgm}) {
    DepthFilterOptions options;
    options.model = model;
    MeasurementStages registered(options), unregistered(options);
    StageTimings timings;
    const DepthWithVariance a = registered.apply(frame, timings);
    RgbdFrame u = frame;
    u.depth_camera = DepthCamera{frame.camera, Pose3::Identity()};
    const DepthWithVariance b = unregistered.apply(u, timings);
    EXPECT_EQ(cv::norm(a.depth_m, b.depth_m, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(a.var_m2, b.var_m2, cv::NORM_INF), 0.0);
    EXPECT_EQ(unregistered.registration().stats().frames, 1);
    EXPECT_NE(timings.find("register"), nullptr);
  }
}

}  // namespace
}  // namespace pplvo::depth_filter
