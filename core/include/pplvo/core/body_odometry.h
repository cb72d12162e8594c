#pragma once
/// Odometry of the robot's body in the axes and frames a fusion filter expects (REP-103: x
/// forward, y left, z up; REP-105: `base_link` in `odom`), computed from the camera's poses.
///
/// pose_t is the camera's optical frame (x right, y down, z forward) in the first camera frame,
/// with the covariance of the frame-to-frame motion. A wheel/IMU filter wants the body pose in
/// `odom`, the body's twist and a 6x6 covariance for each, in ROS's order: this module does
/// that conversion once, so that no user writes it again.
#include <cstdint>
#include <string>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/frame_pose.h"
#include "pplvo/core/geometry.h"

namespace pplvo {

/// The camera's optical frame in its body frame (`camera_link`: x forward, y left, z up):
/// optical z (forward) is body x, optical x (right) is body -y, optical y (down) is body -z.
Eigen::Matrix3d opticalToCameraBody();

/// Where the camera sits on the robot.
struct BodyExtrinsic {
  /// The camera's body frame (`camera_link`) in `base_link`; identity: the camera at the
  /// robot's origin, looking along its x axis.
  Pose3 T_base_camera = Pose3::Identity();
  /// The optical frame in `base_link` (T_base_camera * the optical-to-body rotation).
  Pose3 baseFromOptical() const;
};

/// The mounting as configured (odometry.body): camera_link in base_link, translation and
/// roll/pitch/yaw about base_link's fixed x, y, z axes (R = Rz(yaw) Ry(pitch) Rx(roll), as
/// ROS's static_transform_publisher).
struct BodyMountOptions {
  double x_m = 0.0, y_m = 0.0, z_m = 0.0;
  double roll_deg = 0.0, pitch_deg = 0.0, yaw_deg = 0.0;
  BodyExtrinsic extrinsic() const;
};

template <class V>
void visit(V& v, BodyMountOptions& o) {
  v.field("x_m", o.x_m, "camera_link in base_link: forward (m)");
  v.field("y_m", o.y_m, "camera_link in base_link: left (m)");
  v.field("z_m", o.z_m, "camera_link in base_link: up (m)");
  v.field("roll_deg", o.roll_deg, "rotation about base_link's x (deg)",
          config::between(-180.0, 180.0));
  v.field("pitch_deg", o.pitch_deg, "about y, positive looks down (deg)",
          config::between(-90.0, 90.0));
  v.field("yaw_deg", o.yaw_deg, "about z, positive looks left (deg)",
          config::between(-180.0, 180.0));
}

/// One odometry sample (odometry_t on the wire). Covariances are row-major 6x6 in ROS's order.
struct BodyOdometry {
  int64_t utime = 0;
  int64_t seq = 0;
  std::string stamp;
  TrackingStatus status = TrackingStatus::kFirstFrame;
  /// base_link in odom (odom = base_link at the first frame).
  Pose3 T_odom_base = Pose3::Identity();
  /// Over [x y z, rx ry rz]: position error in odom and a small rotation about odom's axes,
  /// R = Exp(dtheta) R_est (what nav_msgs/Odometry's pose covariance means in practice). Grows
  /// as the frame-to-frame covariances are composed, like a wheel odometry's.
  Matrix6d pose_covariance = Matrix6d::Zero();
  /// Mean velocities over the last frame interval, in base_link (the current body frame).
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   ///< m/s
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s
  /// Over [vx vy vz, wx wy wz] in base_link, of the part of the motion's error that
  /// accumulates (the per-frame shared error is in pose_covariance, once);
  /// kUnknownTwistVariance on the diagonal when there is no previous frame.
  Matrix6d twist_covariance = Matrix6d::Zero();
  double dt_s = 0.0;  ///< the interval the twist is averaged over (0: unknown)
};

/// Variance that says "no information" for a twist (ROS filters ignore such an axis in effect).
inline constexpr double kUnknownTwistVariance = 1e6;

/// Covariance of [dt; dtheta] (translation, small left rotation R = Exp(dtheta) R_est) of a
/// motion T_prev_curr, from pose_t's covariance over [t; q_xyz] (the quaternion's vector part).
Matrix6d motionCovarianceFromQuaternionCovariance(const Pose3& T_prev_curr,
                                                  const Matrix6d& covariance_t_qxyz);

/// SO(3)'s left Jacobian V(phi): exp of a twist (v, w) over dt moves by V(w dt) v dt.
Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& phi);

/// The constant body twist [v; w] that moves a body by `motion` (in its own frame at the start)
/// in dt_s: the SE(3) logarithm over dt, w = log(R) / dt, v = V(log R)^-1 t / dt.
Vector6d twistOfMotion(const Pose3& motion, double dt_s);
/// Its inverse: the motion of the constant twist [v; w] over dt_s (the SE(3) exponential).
Pose3 motionOfTwist(const Vector6d& twist, double dt_s);

/// A chain of body motions and the covariance of its pose, to first order: the pose of
/// base_link in odom and its covariance over [x y z rx ry rz] (position error in odom, a small
/// rotation about odom's axes). Shared by pplvo's odometry and a filter that integrates twists.
class OdometryChain {
 public:
  /// Appends `motion` (in the current body frame) with the covariance of its [dt; dtheta]
  /// (left rotation in the current body frame).
  void compose(const Pose3& motion, const Matrix6d& motion_covariance);
  const Pose3& pose() const { return T_odom_base_; }
  const Matrix6d& covariance() const { return covariance_; }

 private:
  Pose3 T_odom_base_ = Pose3::Identity();
  Matrix6d covariance_ = Matrix6d::Zero();
};

/// Integrates the estimator's frame-to-frame motions into body odometry. The odom pose is the
/// composition of the motions, so it stays continuous when the estimator starts a new world
/// frame (a restarted tracker); its covariance is the first-order composition of their
/// covariances (independent increments).
class BodyOdometryIntegrator {
 public:
  /// Each pose's `frame_error_covariance` is the part of its rel_covariance that does not
  /// accumulate, the per-frame shared error of its two frames: a frame's error enters the
  /// motion before it and the one after it with opposite signs, so a chain of motions
  /// carries it once. It is taken out of each motion (and so of the twist) and added once to
  /// the pose covariance.
  explicit BodyOdometryIntegrator(BodyExtrinsic extrinsic = {});

  /// The next pose of the estimator (in seq order). `stamp_s`: the frame's time in seconds
  /// (its stamp), for the twist.
  BodyOdometry add(const FramePose& pose, double stamp_s);

  const BodyExtrinsic& extrinsic() const { return extrinsic_; }

 private:
  BodyExtrinsic extrinsic_;
  Pose3 T_base_optical_;
  Matrix6d J_shared_;  ///< [dt; dtheta] of a motion in the optical frame -> in base_link
  Matrix6d frame_error_body_ = Matrix6d::Zero();  ///< the latest 2 Q over [dt; dtheta] in base_link
  bool started_ = false;
  double last_stamp_s_ = 0.0;
  OdometryChain chain_;
};

}  // namespace pplvo
