// The local map (local_map.h, local_mapper.h) and tracking against it
// (TrackingReference::kLocalMap) on fabricated point features with known truth
// (landmark_world.h): the store's bookkeeping, landmarks re-used when the camera returns to
// an earlier place, drift below a single keyframe's on a loop, determinism, bounded memory.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "landmark_world.h"
#include "pplvo/estimator/pose_parameterisation.h"
#include "pplvo/tracking/frame_tracker.h"
#include "pplvo/tracking/local_map.h"
#include "pplvo/tracking/local_mapper.h"

namespace pplvo::tracking {
namespace {

using testing::LandmarkWorld;
using testing::pointsOnly;
using testing::poseOf;
using testing::residentKiB;
using testing::runTurns;
using testing::TurnsRun;
using testing::twoTurns;

MapObservation observationAt(int64_t seq, const Eigen::Vector3d& p, double sigma = 0.01) {
  return {seq, p, sigma * sigma * Eigen::Matrix3d::Identity(), 0.5};
}

cv::Mat descriptor(uint8_t value) { return cv::Mat(1, 32, CV_8U, cv::Scalar(value)); }

TEST(LocalMap, KeepsObservationsAndForgetsWhatNoKeyframeSees) {
  LocalMap map;
  Pose3 T1 = Pose3::Identity();
  T1.translation() = Eigen::Vector3d(1, 0, 0);
  map.addKeyframe(0, Pose3::Identity());
  map.addKeyframe(5, T1);
  const int64_t a = map.addPoint(observationAt(0, {0, 0, 2}), descriptor(1));
  const int64_t b = map.addPoint(observationAt(0, {1, 0, 2}), descriptor(2));
  EXPECT_EQ(map.addPoint(observationAt(3, {0, 0, 1}), descriptor(3)), -1);  // no keyframe 3
  ASSERT_GE(a, 0);
  ASSERT_GE(b, 0);
  EXPECT_TRUE(map.points().at(a).p_w.isApprox(Eigen::Vector3d(0, 0, 2)));
  // Keyframe 5 (1 m along x) sees landmark a at (-1, 0, 2): its descriptor becomes the latest.
  EXPECT_TRUE(map.addObservation(a, observationAt(5, {-1, 0, 2}), descriptor(9)));
  EXPECT_FALSE(map.addObservation(a, observationAt(5, {-1, 0, 2}), descriptor(9)));  // twice
  EXPECT_EQ(map.points().at(a).observations.size(), 2u);
  EXPECT_EQ(map.points().at(a).descriptor.at<uint8_t>(0, 0), 9);
  // Two equal measurements: half the variance.
  map.updatePointCovariance(a);
  EXPECT_NEAR(map.points().at(a).cov_w(0, 0), 0.5e-4, 1e-12);
  // The oldest keyframe leaves: b (seen only by it) goes, a stays with one observation.
  map.eraseOldestKeyframe();
  EXPECT_EQ(map.keyframes().size(), 1u);
  EXPECT_EQ(map.points().count(b), 0u);
  ASSERT_EQ(map.points().count(a), 1u);
  EXPECT_EQ(map.points().at(a).observations.size(), 1u);
  map.removeObservation(a, 5);
  EXPECT_TRUE(map.points().empty());
  EXPECT_TRUE(map.keyframe(5)->point_ids.empty());
}

/// A keyframe's lifted points: `world` points seen from T_w_c, each measured as if the camera
/// were at T_w_seen instead (a keyframe whose points disagree with where tracking put it).
FrameFeatures keyframeSeeing(int64_t seq, const std::vector<Eigen::Vector3d>& world,
                             const Pose3& T_w_seen) {
  FrameFeatures f;
  f.seq = seq;
  f.camera = fixtures::kinectVgaCamera();
  for (size_t i = 0; i < world.size(); ++i) {
    PointFeature p;
    p.point.p = T_w_seen.inverse() * world[i];
    p.point.cov = 1e-6 * Eigen::Matrix3d::Identity();
    p.px = f.camera.project(p.point.p);
    p.has_3d = true;
    f.points.push_back(p);
    f.point_descriptors.push_back(descriptor(static_cast<uint8_t>(17 * i + 3)));
  }
  return f;
}

/// Twelve points about 3 m ahead of the first keyframe (the world frame).
std::vector<Eigen::Vector3d> twelvePointsAhead() {
  std::vector<Eigen::Vector3d> world;
  for (int i = 0; i < 12; ++i)
    world.emplace_back(-1.0 + 0.18 * i, 0.3 * std::sin(i), 3.0 + 0.1 * i);
  return world;
}

/// A second keyframe 10 cm to the right of the first.
Pose3 tenCentimetresRight() {
  Pose3 T_w_1 = Pose3::Identity();
  T_w_1.translation() = Eigen::Vector3d(0.10, 0, 0);
  return T_w_1;
}

TEST(LocalMapper, TrackingsMeasurementHoldsKeyframesThatPointsWouldMove) {
  // Twelve points 3 m ahead, seen by keyframe 0 and by keyframe 1, which tracking put 10 cm to
  // the right; keyframe 1's points say it is 1.5 cm further.
  const std::vector<Eigen::Vector3d> world = twelvePointsAhead();
  const Pose3 T_w_1 = tenCentimetresRight();
  Pose3 T_w_seen = T_w_1;
  T_w_seen.translation().x() += 0.015;
  auto insertBoth = [&](const std::optional<MapRelativePose>& tracked) {
    LocalMapper mapper;
    mapper.insert(keyframeSeeing(0, world, Pose3::Identity()), Pose3::Identity());
    return mapper.insert(keyframeSeeing(1, world, T_w_seen), T_w_1, std::nullopt, tracked);
  };
  auto moved = [&](const KeyframeInsertion& k) {
    return (k.T_w_kf.translation() - T_w_1.translation()).norm();
  };
  // Without tracking's measurement the adjustment follows the points.
  const KeyframeInsertion points_only = insertBoth(std::nullopt);
  EXPECT_EQ(points_only.associated, 12);
  EXPECT_TRUE(points_only.adjusted);
  EXPECT_GT(moved(points_only), 0.01);
  // Tracking measured 10 cm to 0.1 mm: the keyframe stays within a millimetre of it.
  const MapRelativePose certain{0, T_w_1.inverse(), 1e-8 * Matrix6d::Identity()};
  const KeyframeInsertion held = insertBoth(certain);
  EXPECT_TRUE(held.adjusted);
  EXPECT_LT(moved(held), 1e-3);
  // To 5 cm: the points decide.
  const MapRelativePose loose{0, T_w_1.inverse(), 2.5e-3 * Matrix6d::Identity()};
  const KeyframeInsertion followed = insertBoth(loose);
  EXPECT_TRUE(followed.adjusted);
  EXPECT_GT(moved(followed), 0.01);
}

TEST(LocalMapper, LandmarksCarryTheirKeyframesUncertaintyIntoTheNewOne) {
  // Twelve points 3 m ahead, measured to 1 mm by keyframe 0; keyframe 1, 10 cm to the right,
  // measures the first six as well. Tracking measured keyframe 1 relative to keyframe 0 with
  // covariance `pose_cov`.
  const std::vector<Eigen::Vector3d> world = twelvePointsAhead();
  Pose3 T_w_1 = tenCentimetresRight();
  T_w_1.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Pose3 T_1_0 = T_w_1.inverse();
  const std::vector<Eigen::Vector3d> first_six(world.begin(), world.begin() + 6);
  auto render = [&](const Matrix6d& pose_cov) {
    LocalMapOptions o;
    o.adjust_keyframes = 0;  // nothing moves: the covariances alone are compared
    o.landmark_pose_uncertainty = true;
    LocalMapper mapper(o);
    mapper.insert(keyframeSeeing(0, world, Pose3::Identity()), Pose3::Identity());
    return mapper.insert(keyframeSeeing(1, first_six, T_w_1), T_w_1, std::nullopt,
                         MapRelativePose{0, T_1_0, pose_cov});
  };
  // Keyframe 0's measurement of point i carried into keyframe 1 (the Jacobian numerically).
  auto carried = [&](const Eigen::Vector3d& p_0, const Matrix6d& pose_cov) {
    const Vector6d xi = poseToXi(T_1_0);
    Eigen::Matrix<double, 3, 6> J;
    for (int j = 0; j < 6; ++j) {
      Vector6d d = Vector6d::Zero();
      d(j) = 1e-6;
      J.col(j) = (xiToPose(xi + d) * p_0 - xiToPose(xi - d) * p_0) / 2e-6;
    }
    const Eigen::Matrix3d R = T_1_0.linear();
    return Eigen::Matrix3d(1e-6 * R * R.transpose() + J * pose_cov * J.transpose());
  };
  auto covarianceOf = [&](const KeyframeInsertion& k, int i) -> Eigen::Matrix3d {
    const Eigen::Vector3d p_1 = T_1_0 * world[i];
    for (const PointFeature& f : k.reference.points) {
      if ((f.point.p - p_1).norm() < 1e-9) return f.point.cov;
    }
    ADD_FAILURE() << "point " << i << " not rendered";
    return Eigen::Matrix3d::Zero();
  };

  Matrix6d pose_cov = Matrix6d::Zero();
  pose_cov.diagonal() << 1e-4, 1e-4, 1e-4, 1e-6, 1e-6, 1e-6;  // 1 cm, ~0.1 deg
  const KeyframeInsertion k = render(pose_cov);
  EXPECT_EQ(k.associated, 6);
  ASSERT_EQ(k.reference.points.size(), 12u);
  for (int i = 0; i < 12; ++i) {
    const Eigen::Matrix3d from_0 = carried(world[i], pose_cov);
    // Seen by keyframe 1 too: the information of both measurements (its own is 1 mm).
    const Eigen::Matrix3d expected =
        i < 6 ? Eigen::Matrix3d((from_0.inverse() + 1e6 * Eigen::Matrix3d::Identity()).inverse())
              : from_0;
    EXPECT_LT((covarianceOf(k, i) - expected).norm(), 1e-6 * expected.norm()) << i;
  }
  // Keyframe 0's points alone are no more certain in keyframe 1 than keyframe 1's pose.
  EXPECT_GT(covarianceOf(k, 8)(0, 0), 1e-4);
  // Relative poses known exactly: two equal measurements, half the variance.
  const KeyframeInsertion known = render(Matrix6d::Zero());
  EXPECT_NEAR(covarianceOf(known, 2).trace(), 1.5e-6, 1e-12);
  EXPECT_NEAR(covarianceOf(known, 8).trace(), 3e-6, 1e-12);
}

TEST(LocalMap, ReturnsReuseEarlierLandmarksAndDriftLessThanOneKeyframe) {
  const std::vector<Pose3> truth = twoTurns(500);
  // One chain of keyframes: without the retired keyframes the keyframe default re-uses on
  // returns (test_keyframes.cpp has that comparison).
  TrackingOptions one_chain = pointsOnly(TrackingReference::kKeyframe);
  one_chain.keyframe.retired_keyframes = 0;
  const TurnsRun keyframe = runTurns(one_chain, truth);
  FrameTracker tracker(pointsOnly(TrackingReference::kLocalMap));
  const TurnsRun local = runTurns(pointsOnly(TrackingReference::kLocalMap), truth, &tracker);
  std::printf("second turn RMS error: keyframe %.2f mm, local map %.2f mm\n",
              1e3 * keyframe.error_second_turn_m, 1e3 * local.error_second_turn_m);
  EXPECT_EQ(keyframe.not_tracking, 0);
  EXPECT_EQ(local.not_tracking, 0);
  EXPECT_LT(local.error_second_turn_m, keyframe.error_second_turn_m);
  // Keyframes of the second turn observed landmarks first seen in the first turn.
  int reused = 0;
  for (const auto& [id, point] : tracker.localMapper().map().points()) {
    if (point.observations.front().keyframe_seq < 450 &&
        point.observations.back().keyframe_seq >= 500) {
      ++reused;
    }
  }
  EXPECT_GT(reused, 100);
}

TEST(LocalMap, TrackingIsDeterministic) {
  std::vector<Pose3> truth = twoTurns(200);
  truth.resize(250);
  const TurnsRun a = runTurns(pointsOnly(TrackingReference::kLocalMap), truth);
  const TurnsRun b = runTurns(pointsOnly(TrackingReference::kLocalMap), truth);
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (size_t k = 0; k < a.poses.size(); ++k) {
    EXPECT_EQ(a.poses[k].matrix(), b.poses[k].matrix()) << k;  // bit for bit
  }
}

TEST(LocalMap, MemoryStaysBounded) {
  // Twenty turns (5,000 frames) with at most 30 keyframes in the map.
  std::vector<Pose3> truth;
  for (int k = 0; k < 5000; ++k) {
    const double a = 2 * M_PI * k / 250.0;
    truth.push_back(poseOf({1.5 * std::sin(a), 0.1 * std::sin(3 * a), 1.5 * std::cos(a)}, a));
  }
  TrackingOptions o = pointsOnly(TrackingReference::kLocalMap);
  o.local_map.max_keyframes = 30;
  LandmarkWorld world(11);
  FrameTracker odometry(o);
  FrameFeatures reference;
  long rss_after_warmup = 0;
  size_t most_points = 0;
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    auto [f2, f3] = world.observe(k, truth[k], 2);
    k == 0 ? odometry.initialise(f2) : odometry.track(reference, f2);
    reference = std::move(f3);
    const LocalMap& map = odometry.localMapper().map();
    ASSERT_LE(map.keyframes().size(), 30u) << k;
    most_points = std::max(most_points, map.points().size());
    if (k == 500) rss_after_warmup = residentKiB();
  }
  EXPECT_GE(odometry.keyframes().insertedCount(), 150);
  EXPECT_LT(most_points, 30u * 2000u);
  EXPECT_LT(residentKiB() - rss_after_warmup, 16 * 1024);
}

}  // namespace
}  // namespace pplvo::tracking
