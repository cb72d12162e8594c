#include "pplvo/core/body_odometry.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>

namespace pplvo {

Eigen::Matrix3d opticalToCameraBody() {
  Eigen::Matrix3d R;
  // Columns: the optical x, y, z axes in the body frame.
  R << 0, 0, 1,  //
      -1, 0, 0,  //
      0, -1, 0;
  return R;
}

Pose3 BodyExtrinsic::baseFromOptical() const {
  Pose3 T_camera_optical = Pose3::Identity();
  T_camera_optical.linear() = opticalToCameraBody();
  return T_base_camera * T_camera_optical;
}

BodyExtrinsic BodyMountOptions::extrinsic() const {
  constexpr double kDeg = M_PI / 180.0;
  BodyExtrinsic e;
  e.T_base_camera.linear() = (Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(pitch_deg * kDeg, Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitX()))
                                 .toRotationMatrix();
  e.T_base_camera.translation() = Eigen::Vector3d(x_m, y_m, z_m);
  return e;
}

Matrix6d motionCovarianceFromQuaternionCovariance(const Pose3& T_prev_curr,
                                                  const Matrix6d& covariance_t_qxyz) {
  // q = q(dtheta) * q_est with q(dtheta) ~ [1, dtheta/2]: the vector part moves by
  // dv = 0.5 (w I - [v]x) dtheta, invertible below a half turn.
  const Eigen::Quaterniond q(T_prev_curr.linear());
  const Eigen::Quaterniond qp = q.w() < 0 ? Eigen::Quaterniond(-q.coeffs()) : q;
  const Eigen::Matrix3d dv_dtheta = 0.5 * (qp.w() * Eigen::Matrix3d::Identity() - skew(qp.vec()));
  Matrix6d J = Matrix6d::Identity();
  J.bottomRightCorner<3, 3>() = dv_dtheta.inverse();
  return J * covariance_t_qxyz * J.transpose();
}

Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d K = skew(phi);
  if (theta < 1e-6) return Eigen::Matrix3d::Identity() + 0.5 * K;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(theta)) / t2 * K +
         (theta - std::sin(theta)) / (t2 * theta) * K * K;
}

namespace {

/// The nearest positive semi-definite matrix (eigenvalues clamped at 0): a motion's covariance
/// minus the shared error can dip below zero along an axis the estimate pinned down tightly.
Matrix6d clampedPsd(const Matrix6d& M) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(0.5 * (M + M.transpose()));
  return es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() *
         es.eigenvectors().transpose();
}

/// [dt; dtheta] of a motion of the optical frame, moved into base_link: dtheta' = R_a dtheta,
/// dt' = R_a dt + [R_m p_a]x R_a dtheta (R_m: the body motion's rotation).
Matrix6d bodyJacobian(const Pose3& T_base_optical, const Eigen::Matrix3d& R_m) {
  const Eigen::Matrix3d& R_a = T_base_optical.linear();
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = R_a;
  J.topRightCorner<3, 3>() = skew(R_m * T_base_optical.translation()) * R_a;
  J.bottomRightCorner<3, 3>() = R_a;
  return J;
}

}  // namespace

Vector6d twistOfMotion(const Pose3& motion, double dt_s) {
  const Eigen::AngleAxisd aa(motion.linear());
  const Eigen::Vector3d phi = aa.angle() * aa.axis();
  Vector6d twist;
  twist << leftJacobianSO3(phi).inverse() * motion.translation() / dt_s, phi / dt_s;
  return twist;
}

Pose3 motionOfTwist(const Vector6d& twist, double dt_s) {
  const Eigen::Vector3d phi = twist.tail<3>() * dt_s;
  Pose3 motion = Pose3::Identity();
  if (phi.norm() > 0) motion.linear() = Eigen::AngleAxisd(phi.norm(), phi.normalized()).matrix();
  motion.translation() = leftJacobianSO3(phi) * twist.head<3>() * dt_s;
  return motion;
}

void OdometryChain::compose(const Pose3& motion, const Matrix6d& motion_covariance) {
  // p_k = p + R t', R_k = R R'. Errors in odom: dp_k = dp - [R t']x dphi + R dt',
  // dphi_k = dphi + R dtheta'.
  const Eigen::Matrix3d R = T_odom_base_.linear();
  Matrix6d F = Matrix6d::Identity();
  F.topRightCorner<3, 3>() = -skew(R * motion.translation());
  Matrix6d G = Matrix6d::Zero();
  G.topLeftCorner<3, 3>() = R;
  G.bottomRightCorner<3, 3>() = R;
  covariance_ = F * covariance_ * F.transpose() + G * motion_covariance * G.transpose();
  T_odom_base_ = T_odom_base_ * motion;
  T_odom_base_.linear() = Eigen::Quaterniond(T_odom_base_.linear()).normalized().toRotationMatrix();
}

BodyOdometryIntegrator::BodyOdometryIntegrator(BodyExtrinsic extrinsic)
    : extrinsic_(extrinsic),
      T_base_optical_(extrinsic_.baseFromOptical()),
      J_shared_(bodyJacobian(T_base_optical_, Eigen::Matrix3d::Identity())) {}

BodyOdometry BodyOdometryIntegrator::add(const FramePose& pose, double stamp_s) {
  BodyOdometry out;
  out.utime = pose.utime;
  out.seq = pose.seq;
  out.stamp = pose.stamp;
  out.status = pose.status;
  const double dt = stamp_s - last_stamp_s_;
  const bool has_motion = started_ && pose.status != TrackingStatus::kFirstFrame && dt > 0.0;
  if (has_motion) {
    // The motion of the body: T_base_optical T_prev_curr T_base_optical^-1, and the covariance
    // of its [dt'; dtheta'] (left rotation in the previous body frame) without the shared
    // error of its two frames, which does not accumulate.
    const Pose3 motion = T_base_optical_ * pose.T_prev_curr * T_base_optical_.inverse();
    const Matrix6d J_body = bodyJacobian(T_base_optical_, motion.linear());
    const Matrix6d accumulating = clampedPsd(pose.rel_covariance - pose.frame_error_covariance);
    frame_error_body_ =
        J_shared_ *
        motionCovarianceFromQuaternionCovariance(Pose3::Identity(), pose.frame_error_covariance) *
        J_shared_.transpose();
    const Matrix6d motion_cov =
        J_body * motionCovarianceFromQuaternionCovariance(pose.T_prev_curr, accumulating) *
        J_body.transpose();

    chain_.compose(motion, motion_cov);

    // The body twist, constant over the interval, that moves the body by `motion` (the same
    // in the body frame at both ends of the interval, as nav_msgs/Odometry's twist in
    // child_frame_id); its covariance to first order, dv = V^-1 dt' / dt, dw = dtheta' / dt.
    const Vector6d twist = twistOfMotion(motion, dt);
    out.linear_velocity = twist.head<3>();
    out.angular_velocity = twist.tail<3>();
    Matrix6d J_twist = Matrix6d::Zero();
    J_twist.topLeftCorner<3, 3>() = leftJacobianSO3(twist.tail<3>() * dt).inverse() / dt;
    J_twist.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() / dt;
    out.twist_covariance = J_twist * motion_cov * J_twist.transpose();
    out.dt_s = dt;
  } else {
    out.twist_covariance = Matrix6d::Identity() * kUnknownTwistVariance;
  }
  started_ = true;
  last_stamp_s_ = stamp_s;
  out.T_odom_base = chain_.pose();
  out.pose_covariance = chain_.covariance();
  if (has_motion || !chain_.covariance().isZero()) {
    // The shared errors of the first and the current frame, once (isotropic blocks: the same
    // in odom's axes up to the current body rotation).
    Matrix6d G = Matrix6d::Zero();
    G.topLeftCorner<3, 3>() = chain_.pose().linear();
    G.bottomRightCorner<3, 3>() = chain_.pose().linear();
    out.pose_covariance += G * frame_error_body_ * G.transpose();
  }
  return out;
}

}  // namespace pplvo
