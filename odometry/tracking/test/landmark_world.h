#pragma once
// Fabricated point features with known truth for the tracking tests: a world of landmarks
// with binary descriptors, observed with pixel noise in 2D and lifted with depth noise in 3D,
// independently in every frame.
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <random>
#include <utility>
#include <vector>

#include "pplvo/core/features.h"
#include "pplvo/fixtures/cameras.h"
#include "pplvo/tracking/frame_tracker.h"

namespace pplvo::tracking::testing {

using fixtures::kinectVgaCamera;

/// Where a rolling shutter that reads its rows over `readout_s` (middle row at the stamp) sees
/// the point p_mid (camera frame at the stamp) while the camera moves at `velocity` (camera
/// frame): in the frame of the camera that read its row, [exp(tau w), tau v] from the stamp's.
/// The row is where the point projects at that row's instant (a fixed point; converges in a
/// few steps).
inline Eigen::Vector3d rollingShutterView(const PinholeCamera& camera, double readout_s,
                                          const CameraVelocity& velocity,
                                          const Eigen::Vector3d& p_mid) {
  const Eigen::Vector3d& w = velocity.angular;
  if (!(readout_s > 0) || !(w.norm() > 0 || velocity.linear.norm() > 0)) return p_mid;
  Eigen::Vector3d p = p_mid;
  for (int i = 0; i < 20; ++i) {
    const double v = camera.project(p).y();
    const double tau = (v - 0.5 * (camera.height - 1)) * readout_s / (camera.height - 1);
    const Eigen::Matrix3d R =
        w.norm() > 0 ? Eigen::AngleAxisd(w.norm() * tau, w.normalized()).toRotationMatrix()
                     : Eigen::Matrix3d::Identity();
    p = R.transpose() * (p_mid - tau * velocity.linear);
  }
  return p;
}

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
  /// pixel noise 0.5 px, depth noise 1.425e-3 z^2 m (Kinect). With `readout_s` > 0 the
  /// colour rows are read over that time while the camera turns at `angular_velocity` (rad/s,
  /// camera frame; the middle row at T_w_c): each point where that rolling shutter sees it,
  /// lifted along that ray (the camera's own readout_s is left 0: the caller sets it).
  std::pair<FrameFeatures, FrameFeatures> observe(
      int64_t seq, const Pose3& T_w_c, int stride = 1, double readout_s = 0.0,
      const CameraVelocity& velocity = CameraVelocity{}) {
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
      const Eigen::Vector3d p_stamp = T_c_w * points_[kept[k]];
      const Eigen::Vector3d p = rollingShutterView(camera, readout_s, velocity, p_stamp);
      PointFeature f;
      f.px = camera.project(p) + 0.5 * Eigen::Vector2d(n01(rng_), n01(rng_));
      f2.points.push_back(f);
      descriptors_.row(kept[k]).copyTo(f2.point_descriptors.row(static_cast<int>(k)));
      // The 3D stage: lifted along the observed pixel's ray with depth noise, the depth that of
      // a depth image read at once at the stamp.
      const double sigma_z = 1.425e-3 * p_stamp.z() * p_stamp.z();
      const double z = p_stamp.z() + sigma_z * n01(rng_);
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

inline Pose3 poseOf(const Eigen::Vector3d& t, double yaw_rad, double pitch_rad = 0.0) {
  Pose3 T = Pose3::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

/// Tracking options with points only (the fabricated world has no lines or planes).
inline TrackingOptions pointsOnly(TrackingReference reference) {
  TrackingOptions o;
  o.reference = reference;
  o.tracker.estimator.use_lines = false;
  o.tracker.estimator.use_planes = false;
  return o;
}

/// Resident memory of this process (KiB), for the bounded-memory tests.
inline long residentKiB() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * (sysconf(_SC_PAGESIZE) / 1024);
}

/// Two turns of a circle of 1.5 m radius looking outwards at the walls: the second turn
/// passes every place of the first.
inline std::vector<Pose3> twoTurns(int frames_per_turn) {
  std::vector<Pose3> truth;
  for (int k = 0; k < 2 * frames_per_turn; ++k) {
    const double a = 2 * M_PI * k / frames_per_turn;
    truth.push_back(poseOf({1.5 * std::sin(a), 0.1 * std::sin(3 * a), 1.5 * std::cos(a)}, a));
  }
  return truth;
}

/// A run over two turns (twoTurns): errors of the second half, keyframes of each half.
struct TurnsRun {
  std::vector<Pose3> poses;
  double error_second_turn_m = 0;  ///< RMS position error over the second half
  int not_tracking = 0;
  int keyframes_first_turn = 0, keyframes_second_turn = 0;
  int reused_from_first_turn = 0;  ///< second-half frames that made a first-half keyframe active
};

/// Tracks `truth` (fabricated landmarks, world seed 11, every second point) with a tracker
/// made from `options`, or with `*tracker` when given (to inspect it afterwards; `options`
/// unused then).
inline TurnsRun runTurns(const TrackingOptions& options, const std::vector<Pose3>& truth,
                         FrameTracker* tracker = nullptr) {
  LandmarkWorld world(11);
  std::optional<FrameTracker> own;
  if (tracker == nullptr) own.emplace(options);
  FrameTracker& odometry = tracker ? *tracker : *own;
  FrameFeatures reference;
  TurnsRun r;
  const int half = static_cast<int>(truth.size()) / 2;
  double sum2 = 0;
  int n = 0;
  for (int k = 0; k < static_cast<int>(truth.size()); ++k) {
    auto [f2, f3] = world.observe(k, truth[k], 2);
    TrackingStats s;
    const estimator::MotionChainOutput out =
        k == 0 ? odometry.initialise(f2) : odometry.track(reference, f2, &s);
    reference = std::move(f3);
    if (k > 0 && out.status != TrackingStatus::kTracking) ++r.not_tracking;
    if (s.new_keyframe || k == 0) ++(k < half ? r.keyframes_first_turn : r.keyframes_second_turn);
    if (k >= half && s.reused_keyframe && *s.reused_keyframe < half) ++r.reused_from_first_turn;
    r.poses.push_back(out.T_w_c);
    if (k >= half) {
      const Pose3 expected = truth[0].inverse() * truth[k];
      sum2 += (expected.translation() - out.T_w_c.translation()).squaredNorm();
      ++n;
    }
  }
  r.error_second_turn_m = std::sqrt(sum2 / std::max(1, n));
  return r;
}

}  // namespace pplvo::tracking::testing
