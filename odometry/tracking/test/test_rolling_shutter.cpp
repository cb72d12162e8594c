// Rolling-shutter compensation (rolling_shutter.h): features read out row by row under a
// known rotation are moved to where a global-shutter camera at the stamp sees them, and
// tracking a fast turn with the readout in the calibration beats the global-shutter model.
#include <gtest/gtest.h>

#include <cmath>

#include "landmark_world.h"
#include "pplvo/tracking/frame_tracker.h"
#include "pplvo/tracking/rolling_shutter.h"

namespace pplvo::tracking {
namespace {

using testing::kinectVgaCamera;
using testing::poseOf;

constexpr double kReadout = 0.030;  // s, a Kinect v1 colour camera's order

TEST(RollingShutter, RowTimeIsZeroAtTheMiddleRowAndSpansTheReadout) {
  PinholeCamera c = kinectVgaCamera();
  EXPECT_EQ(rowTime(c, 100), 0.0);  // global shutter
  c.readout_s = kReadout;
  EXPECT_NEAR(rowTime(c, 0.5 * (c.height - 1)), 0.0, 1e-15);
  EXPECT_NEAR(rowTime(c, c.height - 1) - rowTime(c, 0), kReadout, 1e-15);
}

TEST(RollingShutter, AngularVelocityOfAMotion) {
  // The camera turned 1 deg about its y axis in 1/30 s: T_curr_prev holds the inverse turn.
  Pose3 T_curr_prev = Pose3::Identity();
  const double angle = M_PI / 180.0;
  T_curr_prev.linear() = Eigen::AngleAxisd(-angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d w = angularVelocity(T_curr_prev, 1.0 / 30.0);
  EXPECT_TRUE(w.isApprox(Eigen::Vector3d(0, 30 * angle, 0), 1e-12));
  EXPECT_EQ(angularVelocity(T_curr_prev, 0.0), Eigen::Vector3d::Zero());
}

TEST(RollingShutter, FeaturesMoveToTheGlobalShutterView) {
  PinholeCamera camera = kinectVgaCamera();
  camera.readout_s = kReadout;
  const Eigen::Vector3d w(0.3, 2.0, -0.4);  // rad/s: a fast hand-held turn
  FrameFeatures frame;
  frame.camera = camera;
  std::vector<Eigen::Vector3d> truth;
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector3d X(-1.0 + 0.05 * i, -0.7 + 0.035 * i, 2.0 + 0.02 * i);
    truth.push_back(X);
    PointFeature p;
    p.px = camera.project(testing::rollingShutterView(camera, kReadout, w, X));
    p.has_3d = true;
    // Lifted along the ray it was read on, at the right distance.
    p.point.p = camera.ray(p.px.x(), p.px.y()).normalized() * X.norm();
    p.point.cov = 1e-6 * Eigen::Matrix3d::Identity();
    frame.points.push_back(p);
  }
  double worst_before = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    worst_before = std::max(worst_before, (frame.points[i].px - camera.project(truth[i])).norm());
  }
  ASSERT_GT(worst_before, 10.0);  // the readout moves the image by many pixels
  compensateRollingShutter(frame, w);
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_LT((frame.points[i].px - camera.project(truth[i])).norm(), 1e-6) << i;
    EXPECT_LT((frame.points[i].point.p - truth[i]).norm(), 1e-9) << i;
  }
  // A global-shutter camera is left alone.
  FrameFeatures global = frame;
  global.camera.readout_s = 0;
  const Eigen::Vector2d before = global.points[0].px;
  compensateRollingShutter(global, w);
  EXPECT_EQ(global.points[0].px, before);
}

TEST(RollingShutter, TrackingAFastTurnNeedsTheReadout) {
  // 90 frames turning at 1.2 rad/s about the vertical axis with a slow sway: the readout
  // shears every frame by up to ~9 px. The same observations, tracked once with the readout
  // in the calibration and once as if the shutter were global.
  std::vector<Pose3> truth;
  const double dt = 1.0 / 30.0;
  for (int k = 0; k < 90; ++k) {
    const double t = k * dt;
    truth.push_back(poseOf({0.1 * std::sin(t), 0.02 * std::sin(2 * t), 0}, 0.6 * t));
  }
  auto run = [&](double readout_s) {
    testing::LandmarkWorld world(5);
    FrameTracker tracker(testing::pointsOnly(TrackingReference::kKeyframe));
    FrameFeatures reference;
    double worst_deg = 0, worst_m = 0;
    for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
      auto [f2, f3] = world.observe(k, truth[k], 2, kReadout, Eigen::Vector3d(0, 0.6, 0));
      f2.utime = f3.utime = static_cast<int64_t>(std::llround(1e6 * k * dt));
      f2.camera.readout_s = f3.camera.readout_s = readout_s;
      const estimator::MotionChainOutput out =
          k == 0 ? tracker.initialise(f2) : tracker.track(reference, f2);
      reference = std::move(f3);
      const Pose3 err = (truth[0].inverse() * truth[k]).inverse() * out.T_w_c;
      worst_m = std::max(worst_m, err.translation().norm());
      worst_deg = std::max(worst_deg, Eigen::AngleAxisd(err.linear()).angle() * 180 / M_PI);
      if (std::getenv("PPLVO_TEST_VERBOSE") && k % 5 == 0)
        std::printf("%d status %d err %.1f mm %.2f deg\n", k, static_cast<int>(out.status),
                    1e3 * err.translation().norm(), Eigen::AngleAxisd(err.linear()).angle() * 180 / M_PI);
    }
    return std::make_pair(worst_m, worst_deg);
  };
  const auto [global_m, global_deg] = run(0.0);
  const auto [rolling_m, rolling_deg] = run(kReadout);
  std::printf("worst error: global-shutter model %.1f mm / %.2f deg, rolling-shutter model "
              "%.1f mm / %.2f deg\n",
              1e3 * global_m, global_deg, 1e3 * rolling_m, rolling_deg);
  EXPECT_LT(rolling_m, 0.5 * global_m);
  EXPECT_LT(rolling_deg, global_deg);
}

}  // namespace
}  // namespace pplvo::tracking
