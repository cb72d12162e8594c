// Frame-to-keyframe tracking (FrameTracker with TrackingReference::kKeyframe) on fabricated
// point features with known truth: a world of landmarks with binary descriptors, observed
// with pixel noise in 2D and lifted with depth noise in 3D, independently in every frame.
// Keyframes are taken where the rule says, drift stays bounded where frame-to-frame
// accumulates, a lost keyframe falls back to the previous frame, and the state stays bounded.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "landmark_world.h"
#include "pplvo/estimator/pose_parameterisation.h"
#include "pplvo/tracking/frame_tracker.h"

namespace pplvo::tracking {
namespace {

using testing::LandmarkWorld;
using testing::pointsOnly;
using testing::poseOf;
using testing::residentKiB;
using testing::runTurns;
using testing::TurnsRun;
using testing::twoTurns;

struct RunResult {
  std::vector<estimator::MotionChainOutput> outputs;
  std::vector<TrackingStats> stats;
  std::vector<int64_t> keyframe_seq;  ///< active keyframe after each frame
  double final_error_m = 0, max_error_m = 0, max_error_deg = 0;
  int64_t keyframes = 0;
  int fallbacks = 0, lost = 0, not_tracking = 0;
};

/// `frame_interval_us` > 0: frames stamped that far apart (else unstamped, utime 0).
RunResult run(const TrackingOptions& options, const std::vector<Pose3>& truth, uint64_t seed = 7,
              int64_t frame_interval_us = 0) {
  LandmarkWorld world(seed);
  FrameTracker odometry(options);
  RunResult r;
  FrameFeatures reference;
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    auto [f2, f3] = world.observe(k, truth[k]);
    f2.utime = f3.utime = (1 + k) * frame_interval_us;
    TrackingStats s;
    const estimator::MotionChainOutput out =
        k == 0 ? odometry.initialise(f2) : odometry.track(reference, f2, &s);
    reference = std::move(f3);
    const Pose3 expected = truth[0].inverse() * truth[k];
    const Pose3 err = expected.inverse() * out.T_w_c;
    r.final_error_m = err.translation().norm();
    r.max_error_m = std::max(r.max_error_m, r.final_error_m);
    r.max_error_deg =
        std::max(r.max_error_deg, Eigen::AngleAxisd(err.linear()).angle() * 180.0 / M_PI);
    if (s.keyframe_fallback) ++r.fallbacks;
    if (out.status == TrackingStatus::kLost) ++r.lost;
    if (k > 0 && out.status != TrackingStatus::kTracking) ++r.not_tracking;
    r.outputs.push_back(out);
    r.stats.push_back(s);
    r.keyframe_seq.push_back(odometry.keyframes().activeSeq().value_or(-1));
    if (std::getenv("PPLVO_TEST_VERBOSE")) {
      std::printf("%d status %d ref %lld fb %d new %d pm %d rows %d est %s err %.1f mm\n", k,
                  static_cast<int>(out.status),
                  static_cast<long long>(s.reference_seq.value_or(-1)), s.keyframe_fallback,
                  s.new_keyframe, s.point_matches, out.estimate.n_residuals,
                  toString(out.estimate.status), 1e3 * r.final_error_m);
    }
  }
  r.keyframes = odometry.keyframes().insertedCount();
  return r;
}

TEST(Keyframes, ParseAndNameTheReference) {
  TrackingReference r = TrackingReference::kFrame;
  EXPECT_TRUE(parseTrackingReference("keyframe", &r));
  EXPECT_EQ(r, TrackingReference::kKeyframe);
  EXPECT_STREQ(toString(r), "keyframe");
  EXPECT_TRUE(parseTrackingReference("frame", &r));
  EXPECT_EQ(r, TrackingReference::kFrame);
  EXPECT_TRUE(parseTrackingReference("local_map", &r));
  EXPECT_EQ(r, TrackingReference::kLocalMap);
  EXPECT_STREQ(toString(r), "local_map");
  EXPECT_FALSE(parseTrackingReference("local", &r));
}

TEST(Keyframes, StillCameraKeepsItsFirstKeyframe) {
  const std::vector<Pose3> truth(60, Pose3::Identity());
  const RunResult r = run(pointsOnly(TrackingReference::kKeyframe), truth);
  EXPECT_EQ(r.not_tracking, 0);
  EXPECT_EQ(r.keyframes, 1);
  EXPECT_EQ(r.keyframe_seq.back(), 0);
  // Every frame after the second is estimated against frame 0's landmarks.
  for (size_t k = 2; k < r.stats.size(); ++k) EXPECT_EQ(r.stats[k].reference_seq, 0) << k;
  EXPECT_LT(r.max_error_m, 0.01);  // one estimate against one keyframe: ~5 mm
}

TEST(Keyframes, FrameModeNeverKeepsAKeyframe) {
  const std::vector<Pose3> truth(10, Pose3::Identity());
  const RunResult r = run(pointsOnly(TrackingReference::kFrame), truth);
  EXPECT_EQ(r.keyframes, 0);
  for (size_t k = 1; k < r.stats.size(); ++k) {
    EXPECT_EQ(r.stats[k].reference_seq, static_cast<int64_t>(k) - 1);
  }
}

TEST(Keyframes, NewKeyframesFollowTheMotionBound) {
  // 2 cm per frame along x for 120 frames (2.4 m): with the overlap and uncertainty rules
  // off, only the translation bound (0.3 m) takes keyframes: one per ~15 frames.
  std::vector<Pose3> truth;
  for (int k = 0; k < 120; ++k) truth.push_back(poseOf({0.02 * k - 1.2, 0, 0}, 0));
  TrackingOptions o = pointsOnly(TrackingReference::kKeyframe);
  o.keyframe.min_inlier_fraction = 0;
  o.keyframe.max_variance_growth = 1e9;
  const RunResult r = run(o, truth);
  EXPECT_EQ(r.not_tracking, 0);
  EXPECT_GE(r.keyframes, 7);
  EXPECT_LE(r.keyframes, 9);
  for (size_t k = 1; k < truth.size(); ++k) {
    // The frame a pose was estimated from is never farther than the bound plus one step.
    const int64_t ref = r.stats[k].reference_seq.value_or(-1);
    ASSERT_GE(ref, 0);
    EXPECT_LE((truth[ref].translation() - truth[k].translation()).norm(), 0.3 + 0.021) << k;
  }
}

TEST(Keyframes, AReversalAtALowFrameRateIsTracked) {
  // 50 mm a frame towards a wall, then straight back, at 10 Hz (a dataset played at every
  // third frame): the motion changes by 100 mm at the turn. The stamps say three 30 Hz frames
  // passed, so the velocity model's process noise lets the measured turn through; without
  // stamps the prediction gate takes it for a wrong solution and the velocity model carries
  // the frame on forwards (90 mm off until a return re-uses the first keyframe).
  std::vector<Pose3> truth;
  for (int k = 0; k < 16; ++k) truth.push_back(poseOf({0.0, 0.0, 0.05 * (k < 8 ? k : 16 - k)}, 0));
  const TrackingOptions o = pointsOnly(TrackingReference::kKeyframe);
  const RunResult stamped = run(o, truth, 7, 100000);
  EXPECT_EQ(stamped.not_tracking, 0);
  EXPECT_LT(stamped.max_error_m, 0.01);
  const RunResult unstamped = run(o, truth);
  EXPECT_GE(unstamped.not_tracking, 1);
  EXPECT_GT(unstamped.max_error_m, 0.05);
}

TEST(Keyframes, OverlapRuleTakesAKeyframeBeforeTheViewIsGone) {
  // A steady turn of 1 deg per frame: the keyframe's landmarks leave the 62-deg field of view;
  // the overlap rule (half of the first frame's inlier rows) takes a keyframe well before.
  std::vector<Pose3> truth;
  for (int k = 0; k < 120; ++k) truth.push_back(poseOf({0, 0, 0}, k * M_PI / 180.0));
  TrackingOptions o = pointsOnly(TrackingReference::kKeyframe);
  o.keyframe.max_variance_growth = 1e9;
  o.keyframe.max_rotation_deg = 180;
  const RunResult r = run(o, truth);
  EXPECT_EQ(r.not_tracking, 0);
  EXPECT_EQ(r.fallbacks, 0);
  EXPECT_GE(r.keyframes, 3);
  for (size_t k = 1; k < truth.size(); ++k) {
    const int64_t ref = r.stats[k].reference_seq.value_or(-1);
    EXPECT_LT(k - ref, 45u) << k;  // half the view is 31 deg of turn
  }
}

TEST(Keyframes, DriftStaysBoundedWhereFrameToFrameAccumulates) {
  // 600 frames swaying +-8 cm and +-3 deg around one spot: every keyframe estimate is a
  // single measurement of a bounded pose, while frame to frame sums 599 independent errors.
  std::vector<Pose3> truth;
  for (int k = 0; k < 600; ++k) {
    const double s = std::sin(2 * M_PI * k / 90.0), c = std::cos(2 * M_PI * k / 70.0);
    truth.push_back(poseOf({0.08 * s, 0.03 * c, 0.05 * s * c}, 3.0 * M_PI / 180.0 * c));
  }
  const RunResult f2f = run(pointsOnly(TrackingReference::kFrame), truth);
  const RunResult kf = run(pointsOnly(TrackingReference::kKeyframe), truth);
  std::printf(
      "frame: final %.2f mm, max %.2f mm / %.3f deg; keyframe: final %.2f mm, max %.2f "
      "mm / %.3f deg, %lld keyframes\n",
      1e3 * f2f.final_error_m, 1e3 * f2f.max_error_m, f2f.max_error_deg, 1e3 * kf.final_error_m,
      1e3 * kf.max_error_m, kf.max_error_deg, static_cast<long long>(kf.keyframes));
  EXPECT_EQ(kf.not_tracking, 0);
  EXPECT_LE(kf.keyframes, 5);
  EXPECT_LT(kf.max_error_m, 0.5 * f2f.max_error_m);
  EXPECT_LT(kf.max_error_deg, 0.5 * f2f.max_error_deg);
}

TEST(Keyframes, ReturnsAreTrackedAgainstTheEarlierKeyframes) {
  // The second turn passes the first turn's keyframes: with retired keyframes kept, it is
  // tracked against them again (few new keyframes), and its error is the first turn's, not
  // the first turn's plus the drift of another chain of keyframes.
  const std::vector<Pose3> truth = twoTurns(500);
  TrackingOptions without = pointsOnly(TrackingReference::kKeyframe);
  without.keyframe.retired_keyframes = 0;
  TrackingOptions with = without;
  with.keyframe.retired_keyframes = 64;
  const TurnsRun chain = runTurns(without, truth);
  const TurnsRun returns = runTurns(with, truth);
  std::printf(
      "second turn RMS error: new keyframes only %.2f mm (%d + %d keyframes), earlier "
      "keyframes re-used %.2f mm (%d + %d keyframes, %d re-uses of the first turn's)\n",
      1e3 * chain.error_second_turn_m, chain.keyframes_first_turn, chain.keyframes_second_turn,
      1e3 * returns.error_second_turn_m, returns.keyframes_first_turn,
      returns.keyframes_second_turn, returns.reused_from_first_turn);
  EXPECT_EQ(chain.not_tracking, 0);
  EXPECT_EQ(returns.not_tracking, 0);
  EXPECT_EQ(chain.reused_from_first_turn, 0);
  EXPECT_GE(returns.reused_from_first_turn, returns.keyframes_first_turn / 2);
  EXPECT_LT(returns.keyframes_second_turn, returns.keyframes_first_turn / 2);
  EXPECT_LT(returns.error_second_turn_m, 0.9 * chain.error_second_turn_m);
  // Deterministic, bit for bit.
  const TurnsRun again = runTurns(with, truth);
  ASSERT_EQ(again.poses.size(), returns.poses.size());
  for (size_t k = 0; k < again.poses.size(); ++k) {
    ASSERT_EQ(again.poses[k].matrix(), returns.poses[k].matrix()) << k;
  }
}

TEST(Keyframes, LostKeyframeFallsBackToThePreviousFrame) {
  // Turn 100 deg away in 50 frames and back (smoothly: at most 3.1 deg per frame). With the
  // keyframe rules off, the keyframe's
  // landmarks leave the view: its estimate fails, the previous frame serves and a new
  // keyframe starts there; tracking never stops and the way back is tracked too.
  std::vector<Pose3> truth;
  for (int k = 0; k <= 100; ++k) {
    const double deg = 50.0 * (1.0 - std::cos(2 * M_PI * k / 100.0));
    truth.push_back(poseOf({0.01 * std::sin(k * 0.1), 0, 0}, deg * M_PI / 180.0));
  }
  TrackingOptions o = pointsOnly(TrackingReference::kKeyframe);
  o.keyframe.min_inlier_fraction = 0;
  o.keyframe.max_variance_growth = 1e9;
  o.keyframe.max_translation_m = 1e3;
  o.keyframe.max_rotation_deg = 180;
  const RunResult r = run(o, truth);
  EXPECT_EQ(r.lost, 0);
  EXPECT_EQ(r.not_tracking, 0);
  EXPECT_GE(r.fallbacks, 2);  // at least once each way
  for (size_t k = 1; k < r.stats.size(); ++k) {
    if (r.stats[k].keyframe_fallback) {
      EXPECT_EQ(r.stats[k].reference_seq, static_cast<int64_t>(k) - 1);
      EXPECT_TRUE(r.stats[k].new_keyframe);
    }
  }
  EXPECT_LT(r.final_error_m, 0.05);
  EXPECT_LT(r.max_error_deg, 2.0);
}

TEST(Keyframes, StateStaysBoundedOver5000Frames) {
  // A 5,000-frame walk around the room (10 rounds, ~3 min at 30 Hz): the keyframe is always
  // a recent one or one of the retired keyframes kept, memory does not grow.
  std::vector<Pose3> truth;
  for (int k = 0; k < 5000; ++k) {
    const double a = 2 * M_PI * k / 500.0;
    truth.push_back(poseOf({1.5 * std::sin(a), 0.1 * std::sin(3 * a), 1.5 * std::cos(a)}, a));
  }
  LandmarkWorld world(11);
  FrameTracker odometry(pointsOnly(TrackingReference::kKeyframe));
  FrameFeatures reference;
  long rss_after_warmup = 0;
  int not_tracking = 0;
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    auto [f2, f3] = world.observe(k, truth[k], 2);
    const estimator::MotionChainOutput out =
        k == 0 ? odometry.initialise(f2) : odometry.track(reference, f2);
    reference = std::move(f3);
    if (k > 0 && out.status != TrackingStatus::kTracking) ++not_tracking;
    ASSERT_LE(odometry.keyframes().retired().size(),
              static_cast<size_t>(odometry.options().keyframe.retired_keyframes))
        << k;
    if (k == 200) rss_after_warmup = residentKiB();
  }
  EXPECT_EQ(not_tracking, 0);
  EXPECT_GE(odometry.keyframes().insertedCount(), 20);
  EXPECT_LT(residentKiB() - rss_after_warmup, 16 * 1024);
}

}  // namespace
}  // namespace pplvo::tracking
