// Frame-to-keyframe tracking (FrameTracker with TrackingReference::kKeyframe) on fabricated
// point features with known truth: a world of landmarks with binary descriptors, observed
// with pixel noise in 2D and lifted with depth noise in 3D, independently in every frame.
// Keyframes are taken where the rule says, drift stays bounded where frame-to-frame
// accumulates, a lost keyframe falls back to the previous frame, and the state stays bounded.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include "pplvo/estimator/pose_parameterisation.h"
#include "pplvo/fixtures/cameras.h"
#include "pplvo/tracking/frame_tracker.h"

namespace pplvo::tracking {
namespace {

using fixtures::kinectVgaCamera;

/// Landmarks on the walls of a 6 x 6 m room around the origin (camera near the centre),
/// each with a random 256-bit descriptor.
class LandmarkWorld {
 public:
  explicit LandmarkWorld(uint64_t seed, int n = 4000) : rng_(seed) {
    std::uniform_real_distribution<double> u(-3.0, 3.0), h(-1.2, 1.2);
    std::uniform_int_distribution<int> byte(0, 255), wall(0, 3);
    descriptors_.create(n, 32, CV_8U);
    for (int i = 0; i < n; ++i) {
      const double a = u(rng_), y = h(rng_);
      switch (wall(rng_)) {
        case 0:
          points_.emplace_back(a, y, 3.0);
          break;
        case 1:
          points_.emplace_back(a, y, -3.0);
          break;
        case 2:
          points_.emplace_back(3.0, y, a);
          break;
        default:
          points_.emplace_back(-3.0, y, a);
          break;
      }
      for (int b = 0; b < 32; ++b)
        descriptors_.at<uint8_t>(i, b) = static_cast<uint8_t>(byte(rng_));
    }
  }

  /// The 2D and 3D stages of a frame seen from T_w_c: the visible landmarks whose index is a
  /// multiple of `stride` (the same landmarks from every view, as a detector would find),
  /// pixel noise 0.5 px, depth noise 1.425e-3 z^2 m (Kinect).
  std::pair<FrameFeatures, FrameFeatures> observe(int64_t seq, const Pose3& T_w_c, int stride = 1) {
    const PinholeCamera camera = kinectVgaCamera();
    std::normal_distribution<double> n01(0.0, 1.0);
    std::vector<int> visible;
    const Pose3 T_c_w = T_w_c.inverse();
    for (int i = 0; i < static_cast<int>(points_.size()); i += stride) {
      const Eigen::Vector3d p = T_c_w * points_[i];
      if (p.z() < 0.5 || p.z() > 8.0) continue;
      const Eigen::Vector2d px = camera.project(p);
      if (px.x() < 5 || px.y() < 5 || px.x() > camera.width - 6 || px.y() > camera.height - 6)
        continue;
      visible.push_back(i);
    }
    FrameFeatures f2, f3;
    f2.seq = f3.seq = seq;
    f2.camera = f3.camera = camera;
    const std::vector<int>& kept = visible;
    f2.point_descriptors.create(static_cast<int>(kept.size()), 32, CV_8U);
    for (size_t k = 0; k < kept.size(); ++k) {
      const Eigen::Vector3d p = T_c_w * points_[kept[k]];
      PointFeature f;
      f.px = camera.project(p) + 0.5 * Eigen::Vector2d(n01(rng_), n01(rng_));
      f2.points.push_back(f);
      descriptors_.row(kept[k]).copyTo(f2.point_descriptors.row(static_cast<int>(k)));
      // The 3D stage: lifted along the observed pixel's ray with depth noise.
      const double sigma_z = 1.425e-3 * p.z() * p.z();
      const double z = p.z() + sigma_z * n01(rng_);
      f.has_3d = true;
      f.point.p = camera.backproject(f.px.x(), f.px.y(), z);
      const Eigen::Vector3d ray = f.point.p / z;
      const double sx = 0.5 * z / camera.fx;
      f.point.cov = sigma_z * sigma_z * ray * ray.transpose() +
                    sx * sx *
                        (Eigen::Matrix3d::Identity() -
                         Eigen::Vector3d::UnitZ() * Eigen::Vector3d::UnitZ().transpose());
      f3.points.push_back(f);
    }
    f3.point_descriptors = f2.point_descriptors.clone();
    return {f2, f3};
  }

 private:
  std::mt19937_64 rng_;
  std::vector<Eigen::Vector3d> points_;
  cv::Mat descriptors_;
};

Pose3 poseOf(const Eigen::Vector3d& t, double yaw_rad, double pitch_rad = 0.0) {
  Pose3 T = Pose3::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

TrackingOptions pointsOnly(TrackingReference reference) {
  TrackingOptions o;
  o.reference = reference;
  o.tracker.estimator.use_lines = false;
  o.tracker.estimator.use_planes = false;
  return o;
}

struct RunResult {
  std::vector<estimator::MotionChainOutput> outputs;
  std::vector<TrackingStats> stats;
  std::vector<int64_t> keyframe_seq;  ///< active keyframe after each frame
  double final_error_m = 0, max_error_m = 0, max_error_deg = 0;
  int64_t keyframes = 0;
  int fallbacks = 0, lost = 0, not_tracking = 0;
};

RunResult run(const TrackingOptions& options, const std::vector<Pose3>& truth,
              uint64_t seed = 7) {
  LandmarkWorld world(seed);
  FrameTracker odometry(options);
  RunResult r;
  FrameFeatures reference;
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    auto [f2, f3] = world.observe(k, truth[k]);
    TrackingStats s;
    const estimator::MotionChainOutput out = k == 0 ? odometry.initialise(f2) : odometry.track(reference, f2, &s);
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
                  static_cast<int>(out.status), static_cast<long long>(s.reference_seq.value_or(-1)),
                  s.keyframe_fallback, s.new_keyframe, s.point_matches, out.estimate.n_residuals,
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

long residentKiB() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * (sysconf(_SC_PAGESIZE) / 1024);
}

TEST(Keyframes, StateStaysBoundedOver2000Frames) {
  // A 2,000-frame walk around the room: the keyframe is always recent, memory does not grow.
  std::vector<Pose3> truth;
  for (int k = 0; k < 2000; ++k) {
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
    const estimator::MotionChainOutput out = k == 0 ? odometry.initialise(f2) : odometry.track(reference, f2);
    reference = std::move(f3);
    if (k > 0 && out.status != TrackingStatus::kTracking) ++not_tracking;
    ASSERT_LE(k - odometry.keyframes().activeSeq().value_or(-1), 60) << k;
    if (k == 200) rss_after_warmup = residentKiB();
  }
  EXPECT_EQ(not_tracking, 0);
  EXPECT_GE(odometry.keyframes().insertedCount(), 20);
  EXPECT_LT(residentKiB() - rss_after_warmup, 16 * 1024);
}

}  // namespace
}  // namespace pplvo::tracking
