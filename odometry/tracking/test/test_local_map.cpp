// The local map (local_map.h, local_mapper.h) and tracking against it
// (TrackingReference::kLocalMap) on fabricated point features with known truth
// (landmark_world.h): the store's bookkeeping, landmarks re-used when the camera returns to
// an earlier place, drift below a single keyframe's on a loop, determinism, bounded memory.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "landmark_world.h"
#include "pplvo/tracking/frame_tracker.h"
#include "pplvo/tracking/local_map.h"

namespace pplvo::tracking {
namespace {

using testing::LandmarkWorld;
using testing::poseOf;
using testing::pointsOnly;
using testing::residentKiB;

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


/// Two turns of a circle of 1.5 m radius looking outwards at the walls (500 frames a turn):
/// the second turn passes every place of the first.
std::vector<Pose3> twoTurns(int frames_per_turn = 500) {
  std::vector<Pose3> truth;
  for (int k = 0; k < 2 * frames_per_turn; ++k) {
    const double a = 2 * M_PI * k / frames_per_turn;
    truth.push_back(poseOf({1.5 * std::sin(a), 0.1 * std::sin(3 * a), 1.5 * std::cos(a)}, a));
  }
  return truth;
}

struct LoopRun {
  std::vector<Pose3> poses;
  double error_second_turn_m = 0;  ///< RMS position error over the second turn
  int not_tracking = 0;
};

LoopRun runLoop(const TrackingOptions& options, const std::vector<Pose3>& truth,
                FrameTracker* tracker_out = nullptr) {
  LandmarkWorld world(11);
  FrameTracker own(options);
  FrameTracker& odometry = tracker_out ? *tracker_out : own;
  FrameFeatures reference;
  LoopRun r;
  double sum2 = 0;
  int n = 0;
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    auto [f2, f3] = world.observe(k, truth[k], 2);
    const estimator::MotionChainOutput out =
        k == 0 ? odometry.initialise(f2) : odometry.track(reference, f2);
    reference = std::move(f3);
    if (k > 0 && out.status != TrackingStatus::kTracking) ++r.not_tracking;
    r.poses.push_back(out.T_w_c);
    if (k >= static_cast<int>(truth.size()) / 2) {
      const Pose3 expected = truth[0].inverse() * truth[k];
      sum2 += (expected.translation() - out.T_w_c.translation()).squaredNorm();
      ++n;
    }
  }
  r.error_second_turn_m = std::sqrt(sum2 / std::max(1, n));
  return r;
}

TEST(LocalMap, ReturnsReuseEarlierLandmarksAndDriftLessThanOneKeyframe) {
  const std::vector<Pose3> truth = twoTurns();
  const LoopRun keyframe = runLoop(pointsOnly(TrackingReference::kKeyframe), truth);
  FrameTracker tracker(pointsOnly(TrackingReference::kLocalMap));
  const LoopRun local = runLoop(pointsOnly(TrackingReference::kLocalMap), truth, &tracker);
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
  const LoopRun a = runLoop(pointsOnly(TrackingReference::kLocalMap), truth);
  const LoopRun b = runLoop(pointsOnly(TrackingReference::kLocalMap), truth);
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
