#pragma once
/// A small error-state filter over the robot body's pose that fuses two odometries, each a
/// body twist with its covariance per interval (odometry_t: pplvo's PPLVO_ODOMETRY and a wheel
/// odometry). For each frame interval the two twists measure the same motion, so the filter's
/// motion is their information-weighted mean (the Kalman update of one by the other), and the
/// pose and its covariance are propagated with it exactly as pplvo propagates its own
/// (first order, odom frame). Either source alone carries on when the other has nothing for an
/// interval (pplvo lost, wheels stopped publishing).
#include <optional>

#include "pplvo/core/body_odometry.h"

namespace pplvo::examples {

struct BodyTwist {
  Vector6d xi = Vector6d::Zero();         ///< [v; w] in base_link
  Matrix6d covariance = Matrix6d::Zero();
};

/// The twist of an odometry_t sample (nullopt when it has none: the first frame, dt 0, or a
/// variance of "no information" on every axis).
std::optional<BodyTwist> twistOf(const BodyOdometry& o);

/// Information-weighted mean of two measurements of the same twist.
BodyTwist fuseTwists(const BodyTwist& a, const BodyTwist& b);

/// The wheels' own errors, estimated online: a yaw-rate bias (a wheel-base error) and a speed
/// scale error (wheel radius, slip), each a random walk.
struct WheelErrorOptions {
  double bias_sigma_rad_s = 0.05;      ///< prior
  double scale_sigma = 0.1;            ///< prior
  double bias_walk_rad_s_per_sqrt_s = 0.001;
  double scale_walk_per_sqrt_s = 0.02;  ///< slip changes with the floor
};

/// One interval's motion from pplvo's twist and the wheels' twist, with the wheels' yaw-rate
/// bias b and speed scale error k as states: the wheels measure
/// [(1 + k) vx, vy, vz, wx, wy, wz + b] of the true twist. Each interval solves the linear
/// least squares of both measurements and the prior on (b, k) (a Kalman update), returns the
/// twist's marginal (for the pose) and keeps (b, k) and their covariance for the next one.
class WheelErrorEstimator {
 public:
  explicit WheelErrorEstimator(WheelErrorOptions options = {});
  BodyTwist fuse(const BodyTwist& pplvo, const BodyTwist& wheels, double dt_s);
  /// Only the wheels: corrected by the current estimate, its uncertainty added.
  BodyTwist correctWheels(const BodyTwist& wheels, double dt_s);
  double yawRateBias() const { return state_(0); }
  double speedScaleError() const { return state_(1); }

 private:
  void predict(double dt_s);
  WheelErrorOptions options_;
  Eigen::Vector2d state_ = Eigen::Vector2d::Zero();  ///< b, k
  Eigen::Matrix2d covariance_;
};

class TwistFusionFilter {
 public:
  /// Moves the body by `twist` over `dt_s` seconds; the pose covariance grows by the motion's.
  void propagate(const BodyTwist& twist, double dt_s);
  const Pose3& pose() const { return chain_.pose(); }
  const Matrix6d& covariance() const { return chain_.covariance(); }  ///< [x y z rx ry rz], odom

 private:
  OdometryChain chain_;  // the same composition as pplvo's own odometry
};

}  // namespace pplvo::examples
