// Rolling-shutter compensation (rolling_shutter.h): features read out row by row under a
// known motion are moved to where a global-shutter camera at the stamp sees them, and
// tracking a fast turn or a fast side step with the readout in the calibration beats the
// global-shutter model.
#include <gtest/gtest.h>

#include <cmath>

#include "landmark_world.h"
#include "pplvo/features/line_extractor.h"
#include "pplvo/tracking/frame_tracker.h"
#include "pplvo/tracking/readout_estimator.h"
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

TEST(RollingShutter, LinearVelocityOfAMotion) {
  // The camera moved 2 cm along its x axis while turning 3 deg about its y axis in 1/30 s:
  // the velocity is in the frame of the camera at the start of the motion.
  Pose3 T_prev_curr = Pose3::Identity();
  T_prev_curr.linear() =
      Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T_prev_curr.translation() = Eigen::Vector3d(0.02, 0, 0);
  const Eigen::Vector3d v = linearVelocity(T_prev_curr.inverse(), 1.0 / 30.0);
  EXPECT_TRUE(v.isApprox(Eigen::Vector3d(0.6, 0, 0), 1e-12));
  EXPECT_EQ(linearVelocity(T_prev_curr.inverse(), -1.0), Eigen::Vector3d::Zero());
  const CameraVelocity both = cameraVelocity(T_prev_curr.inverse(), 1.0 / 30.0);
  EXPECT_TRUE(both.linear.isApprox(v));
  EXPECT_TRUE(both.angular.isApprox(angularVelocity(T_prev_curr.inverse(), 1.0 / 30.0)));
}

/// Points on a slanted plane 1-2 m ahead read by a rolling shutter under `velocity`: the
/// features as read (when `lifted`, along the ray they were read on at the depth a depth image
/// read at once at the stamp gives them) and where the camera at the stamp sees them.
std::pair<FrameFeatures, std::vector<Eigen::Vector3d>> readOut(const CameraVelocity& velocity,
                                                               bool lifted) {
  PinholeCamera camera = kinectVgaCamera();
  camera.readout_s = kReadout;
  FrameFeatures frame;
  frame.camera = camera;
  std::vector<Eigen::Vector3d> truth;
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector3d X(-0.6 + 0.03 * i, -0.45 + 0.022 * i, 1.0 + 0.025 * i);
    truth.push_back(X);
    const Eigen::Vector3d read = testing::rollingShutterView(camera, kReadout, velocity, X);
    PointFeature p;
    p.px = camera.project(read);
    p.has_3d = lifted;
    if (lifted) {
      p.point.p = camera.ray(p.px.x(), p.px.y()) * X.z();
      p.point.cov = 1e-6 * Eigen::Matrix3d::Identity();
    }
    frame.points.push_back(p);
  }
  return {frame, truth};
}

double worstPixelError(const FrameFeatures& frame, const std::vector<Eigen::Vector3d>& truth) {
  double worst = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    worst = std::max(worst, (frame.points[i].px - frame.camera.project(truth[i])).norm());
  }
  return worst;
}

TEST(RollingShutter, FeaturesMoveToTheGlobalShutterView) {
  // A fast hand-held turn and step (rad/s, m/s).
  const CameraVelocity velocity{Eigen::Vector3d(0.3, 2.0, -0.4), Eigen::Vector3d(0.5, -0.4, 0.3)};
  auto [frame, truth] = readOut(velocity, /*lifted=*/true);
  ASSERT_GT(worstPixelError(frame, truth), 10.0);  // the readout moves the image by many pixels
  compensateRollingShutter(frame, velocity);
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_LT((frame.points[i].px - frame.camera.project(truth[i])).norm(), 1e-6) << i;
    EXPECT_LT((frame.points[i].point.p - truth[i]).norm(), 1e-9) << i;
  }
  // A global-shutter camera is left alone.
  FrameFeatures global = frame;
  global.camera.readout_s = 0;
  const Eigen::Vector2d before = global.points[0].px;
  compensateRollingShutter(global, velocity);
  EXPECT_EQ(global.points[0].px, before);
}

TEST(RollingShutter, TheTranslationNeedsDepth) {
  // A side step alone (0.6 m/s at 1-2 m: up to ~3 px): lifted features move to the stamp's
  // view; a feature without depth cannot be moved by a translation and stays as read, while a
  // turn moves it exactly (no depth needed).
  const CameraVelocity step{Eigen::Vector3d::Zero(), Eigen::Vector3d(0.6, 0.0, 0.0)};
  auto [lifted, truth] = readOut(step, /*lifted=*/true);
  const double read_error_px = worstPixelError(lifted, truth);
  ASSERT_GT(read_error_px, 2.0);
  compensateRollingShutter(lifted, step);
  EXPECT_LT(worstPixelError(lifted, truth), 1e-6);
  auto [flat, flat_truth] = readOut(step, /*lifted=*/false);
  compensateRollingShutter(flat, step);
  EXPECT_NEAR(worstPixelError(flat, flat_truth), read_error_px, 1e-9);
  const CameraVelocity turn{Eigen::Vector3d(0, 1.5, 0), Eigen::Vector3d::Zero()};
  auto [turned, turn_truth] = readOut(turn, /*lifted=*/false);
  compensateRollingShutter(turned, turn);
  EXPECT_LT(worstPixelError(turned, turn_truth), 1e-6);
}

TEST(RollingShutter, CorrespondencesOfA2DStageTakeTheTranslation) {
  // A frame's 2D stage (no depth) read during a side and forward step, matched to 3D features
  // of a reference 0.1 m behind it: each observation moves to where the camera at the stamp
  // sees the matched feature, at the depth the (here exact) predicted pose gives it.
  PinholeCamera camera = kinectVgaCamera();
  camera.readout_s = kReadout;
  const CameraVelocity step{Eigen::Vector3d::Zero(), Eigen::Vector3d(0.5, -0.3, 0.4)};
  Pose3 T_curr_ref = Pose3::Identity();
  T_curr_ref.translation() = Eigen::Vector3d(0.02, 0.01, -0.1);
  estimator::Correspondences c;
  std::vector<Eigen::Vector2d> truth;
  for (int i = 0; i < 30; ++i) {
    estimator::PointMatch3D2D m;
    m.P_prev.p = Eigen::Vector3d(-0.5 + 0.035 * i, -0.4 + 0.028 * i, 1.2 + 0.03 * i);
    const Eigen::Vector3d X = T_curr_ref * m.P_prev.p;
    truth.push_back(camera.project(X));
    m.px_curr = camera.project(testing::rollingShutterView(camera, kReadout, step, X));
    c.points.push_back(m);
  }
  // A segment from the top left to the bottom right, observed as the line through its read ends.
  estimator::LineMatch3D2D line;
  line.L_prev.p1 = Eigen::Vector3d(-0.4, -0.35, 1.5);
  line.L_prev.p2 = Eigen::Vector3d(0.3, 0.4, 1.8);
  const Eigen::Vector3d X1 = T_curr_ref * line.L_prev.p1, X2 = T_curr_ref * line.L_prev.p2;
  line.l_curr = features::lineEquation(
      camera.project(testing::rollingShutterView(camera, kReadout, step, X1)),
      camera.project(testing::rollingShutterView(camera, kReadout, step, X2)));
  c.lines.push_back(line);
  double worst_read = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    worst_read = std::max(worst_read, (c.points[i].px_curr - truth[i]).norm());
  }
  ASSERT_GT(worst_read, 2.0);
  compensateReadoutTranslation(c, camera, T_curr_ref, step.linear);
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_LT((c.points[i].px_curr - truth[i]).norm(), 0.02) << i;
  }
  // The line now passes through the segment's ends as seen at the stamp (first order in the
  // readout: the ends read at their own rows; 0.05 px).
  const Eigen::Vector3d& l = c.lines[0].l_curr;
  for (const Eigen::Vector3d& X : {X1, X2}) {
    EXPECT_LT(std::abs(l.head<2>().dot(camera.project(X)) + l.z()), 0.05);
  }
  // A global shutter is left alone.
  estimator::Correspondences global = c;
  PinholeCamera global_camera = camera;
  global_camera.readout_s = 0;
  compensateReadoutTranslation(global, global_camera, T_curr_ref, step.linear);
  EXPECT_EQ(global.points[0].px_curr, c.points[0].px_curr);
}

/// The drift over the last two seconds (60 frames at 30 Hz) of per-frame pose errors, by when
/// a readout read from the frames is read and used.
double driftOverTheLastTwoSeconds(const std::vector<Pose3>& errors) {
  const size_t n = errors.size();
  return (errors[n - 61].inverse() * errors[n - 1]).translation().norm();
}

/// Tracks `truth` (30 Hz) observed by a landmark world's rolling shutter (`sensor_readout_s`)
/// while the camera moves at `velocity[k]` (its own frame), with `model_readout_s` in the
/// calibration and, when that is 0, the readout read from the frames if `read_readout`;
/// returns each frame's pose error relative to the first frame, and the tracker's readout
/// estimator in `*readout` if given.
std::vector<Pose3> trackingErrors(const std::vector<Pose3>& truth,
                                  const std::vector<CameraVelocity>& velocity,
                                  double sensor_readout_s, double model_readout_s,
                                  uint64_t world_seed, bool read_readout = false,
                                  ReadoutEstimator* readout = nullptr,
                                  TrackingReference reference_mode = TrackingReference::kKeyframe) {
  testing::LandmarkWorld world(world_seed);
  TrackingOptions options = testing::pointsOnly(reference_mode);
  options.readout_from_frames = read_readout;
  FrameTracker tracker(options);
  FrameFeatures reference;
  std::vector<Pose3> errors;
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    auto [f2, f3] = world.observe(k, truth[k], 2, sensor_readout_s, velocity[k]);
    f2.utime = f3.utime = static_cast<int64_t>(std::llround(1e6 * k / 30.0));
    f2.camera.readout_s = f3.camera.readout_s = model_readout_s;
    const estimator::MotionChainOutput out =
        k == 0 ? tracker.initialise(f2) : tracker.track(reference, f2);
    reference = std::move(f3);
    errors.push_back((truth[0].inverse() * truth[k]).inverse() * out.T_w_c);
  }
  if (readout != nullptr) *readout = tracker.readoutEstimator();
  return errors;
}

/// The camera-frame velocity of poseOf(position(t), yaw_rate t) from its world velocity.
CameraVelocity velocityOf(const Pose3& T_w_c, const Eigen::Vector3d& velocity_w,
                          double yaw_rate) {
  // poseOf's yaw turns about the world's y axis, which is the camera's (no pitch here).
  return {Eigen::Vector3d(0, yaw_rate, 0), T_w_c.linear().transpose() * velocity_w};
}

TEST(RollingShutter, TrackingAFastTurnNeedsTheReadout) {
  // 90 frames turning at 0.6 rad/s about the vertical axis with a slow sway: the readout
  // shears every frame by up to ~9 px. The same observations, tracked once with the readout
  // in the calibration and once as if the shutter were global.
  std::vector<Pose3> truth;
  std::vector<CameraVelocity> velocity;
  for (int k = 0; k < 90; ++k) {
    const double t = k / 30.0;
    truth.push_back(poseOf({0.1 * std::sin(t), 0.02 * std::sin(2 * t), 0}, 0.6 * t));
    velocity.push_back(
        velocityOf(truth.back(), {0.1 * std::cos(t), 0.04 * std::cos(2 * t), 0}, 0.6));
  }
  auto worst = [](const std::vector<Pose3>& errors) {
    double m = 0, deg = 0;
    for (const Pose3& e : errors) {
      m = std::max(m, e.translation().norm());
      deg = std::max(deg, Eigen::AngleAxisd(e.linear()).angle() * 180 / M_PI);
    }
    return std::make_pair(m, deg);
  };
  const auto [global_m, global_deg] = worst(trackingErrors(truth, velocity, kReadout, 0.0, 5));
  const auto [rolling_m, rolling_deg] =
      worst(trackingErrors(truth, velocity, kReadout, kReadout, 5));
  std::printf("worst error: global-shutter model %.1f mm / %.2f deg, rolling-shutter model "
              "%.1f mm / %.2f deg\n",
              1e3 * global_m, global_deg, 1e3 * rolling_m, rolling_deg);
  EXPECT_LT(rolling_m, 0.5 * global_m);
  EXPECT_LT(rolling_deg, global_deg);
}

TEST(RollingShutter, TrackingAFastSideStepNeedsTheTranslation) {
  // 120 frames stepping side to side (0.5 m either way, 4 s a period: up to 0.79 m/s) without
  // turning, as along fr1_xyz's axes: the readout shears every frame by up to ~2 px at 3 m,
  // one way going left and the other going right. The same observations, tracked once with
  // the readout in the calibration, once as if the shutter were global, and read by a global
  // shutter (the floor).
  std::vector<Pose3> truth;
  std::vector<CameraVelocity> velocity;
  const double w = M_PI / 2;
  for (int k = 0; k < 120; ++k) {
    const double t = k / 30.0;
    truth.push_back(poseOf({0.5 * std::sin(w * t), 0.05 * std::sin(0.5 * w * t), 0}, 0.0));
    velocity.push_back(velocityOf(
        truth.back(), {0.5 * w * std::cos(w * t), 0.025 * w * std::cos(0.5 * w * t), 0}, 0.0));
  }
  auto rms = [](const std::vector<Pose3>& errors) {
    double sum2 = 0;
    for (const Pose3& e : errors) sum2 += e.translation().squaredNorm();
    return std::sqrt(sum2 / static_cast<double>(errors.size()));
  };
  const double global_m = rms(trackingErrors(truth, velocity, kReadout, 0.0, 7));
  const double rolling_m = rms(trackingErrors(truth, velocity, kReadout, kReadout, 7));
  const double base_m = rms(trackingErrors(truth, velocity, 0.0, 0.0, 7));
  std::printf("RMS position error: global-shutter model %.2f mm, rolling-shutter model %.2f mm, "
              "global shutter %.2f mm\n",
              1e3 * global_m, 1e3 * rolling_m, 1e3 * base_m);
  EXPECT_LT(rolling_m, 0.5 * global_m);
  EXPECT_LT(rolling_m - base_m, 0.25 * (global_m - base_m));
}

/// Six seconds turning at 0.6 rad/s about the vertical axis with a slow sway (new keyframes as
/// the view turns away: readings against several references).
void longTurn(std::vector<Pose3>& truth, std::vector<CameraVelocity>& velocity) {
  for (int k = 0; k < 180; ++k) {
    const double t = k / 30.0;
    truth.push_back(poseOf({0.1 * std::sin(t), 0.02 * std::sin(2 * t), 0}, 0.6 * t));
    velocity.push_back(
        velocityOf(truth.back(), {0.1 * std::cos(t), 0.04 * std::cos(2 * t), 0}, 0.6));
  }
}

TEST(RollingShutter, TheReadoutReadFromTheFramesOnAFastTurn) {
  // The readout in neither the calibration nor the model: read from the frames, it is found
  // and used, and most of the global-shutter model's error goes.
  std::vector<Pose3> truth;
  std::vector<CameraVelocity> velocity;
  longTurn(truth, velocity);
  const double global_m =
      driftOverTheLastTwoSeconds(trackingErrors(truth, velocity, kReadout, 0.0, 5));
  const double rolling_m =
      driftOverTheLastTwoSeconds(trackingErrors(truth, velocity, kReadout, kReadout, 5));
  ReadoutEstimator readout;
  const double read_m =
      driftOverTheLastTwoSeconds(trackingErrors(truth, velocity, kReadout, 0.0, 5, true, &readout));
  std::printf(
      "readout read from the frames: %.1f ms (standard error %.1f ms, %d readings, %d "
      "references); drift over the last 2 s: global-shutter model %.1f mm, readout in "
      "the calibration %.1f mm, read from the frames %.1f mm\n",
      1e3 * readout.mean_s(), 1e3 * readout.standardError_s(), readout.readings(),
      readout.references(), 1e3 * global_m, 1e3 * rolling_m, 1e3 * read_m);
  ASSERT_TRUE(readout.readout_s().has_value());
  EXPECT_NEAR(*readout.readout_s(), kReadout, 0.006);
  // Measured 44.6 / 18.2 / 24.5 mm: nearer the calibrated readout's than the global model's.
  EXPECT_LT(read_m - rolling_m, 0.5 * (global_m - rolling_m));
}

TEST(RollingShutter, TheLocalMapStartsAgainWhenTheCompensationSwitchesOn) {
  // The readout in the calibration, tracked against the local map: the first keyframe is
  // lifted as read (no velocity yet), the next ones at their stamps. Associated and adjusted
  // together, the two kinds of landmark moved the second keyframe by the shear (54 mm at
  // frame 10); the map now starts again with the first keyframe at its stamp.
  std::vector<Pose3> truth;
  std::vector<CameraVelocity> velocity;
  longTurn(truth, velocity);
  auto worst = [](const std::vector<Pose3>& errors) {
    double m = 0;
    for (const Pose3& e : errors) m = std::max(m, e.translation().norm());
    return m;
  };
  const TrackingReference map = TrackingReference::kLocalMap;
  const double global_m =
      worst(trackingErrors(truth, velocity, kReadout, 0.0, 5, false, nullptr, map));
  const double rolling_m =
      worst(trackingErrors(truth, velocity, kReadout, kReadout, 5, false, nullptr, map));
  std::printf(
      "local map, worst error: global-shutter model %.1f mm, readout in the "
      "calibration %.1f mm\n",
      1e3 * global_m, 1e3 * rolling_m);
  EXPECT_LT(rolling_m, 0.5 * global_m);
}

TEST(RollingShutter, TheLocalMapReadsTheReadoutAgainstItsNewestKeyframe) {
  // The same turn with the readout in neither the calibration nor the model: the local map's
  // reference mixes several keyframes' landmarks, so each frame is matched again against the
  // newest keyframe as it arrived, and the readout is read and used there too.
  std::vector<Pose3> truth;
  std::vector<CameraVelocity> velocity;
  longTurn(truth, velocity);
  const TrackingReference map = TrackingReference::kLocalMap;
  const double global_m = driftOverTheLastTwoSeconds(
      trackingErrors(truth, velocity, kReadout, 0.0, 5, false, nullptr, map));
  ReadoutEstimator readout;
  const double read_m = driftOverTheLastTwoSeconds(
      trackingErrors(truth, velocity, kReadout, 0.0, 5, true, &readout, map));
  std::printf(
      "local map: readout read %.1f ms (standard error %.1f ms, %d readings, %d references); "
      "drift over the last 2 s: global-shutter model %.1f mm, read from the frames %.1f mm\n",
      1e3 * readout.mean_s(), 1e3 * readout.standardError_s(), readout.readings(),
      readout.references(), 1e3 * global_m, 1e3 * read_m);
  ASSERT_TRUE(readout.readout_s().has_value());
  EXPECT_NEAR(*readout.readout_s(), kReadout, 0.006);
  EXPECT_LT(read_m, global_m);
}

TEST(RollingShutter, AGlobalShutterReadsNoReadout) {
  // The same turn read by a global shutter: the readings stay near zero and nothing is
  // compensated (the poses are those of the global-shutter model, bit for bit).
  std::vector<Pose3> truth;
  std::vector<CameraVelocity> velocity;
  longTurn(truth, velocity);
  ReadoutEstimator readout;
  const std::vector<Pose3> read = trackingErrors(truth, velocity, 0.0, 0.0, 5, true, &readout);
  const std::vector<Pose3> as_read = trackingErrors(truth, velocity, 0.0, 0.0, 5, false);
  std::printf(
      "global shutter: readout read %.2f ms (standard error %.2f ms, %d readings, %d "
      "references)\n",
      1e3 * readout.mean_s(), 1e3 * readout.standardError_s(), readout.readings(),
      readout.references());
  EXPECT_GE(readout.references(), ReadoutEstimator::kMinReferences);
  EXPECT_LT(std::abs(readout.mean_s()), 3 * readout.standardError_s());
  EXPECT_FALSE(readout.readout_s().has_value());
  ASSERT_EQ(read.size(), as_read.size());
  for (size_t k = 0; k < read.size(); ++k) EXPECT_EQ(read[k].matrix(), as_read[k].matrix()) << k;
}

}  // namespace
}  // namespace pplvo::tracking
