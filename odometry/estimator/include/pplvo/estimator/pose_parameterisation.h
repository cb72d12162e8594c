#pragma once
/// The paper's minimal pose parameterisation and its EKF covariance propagation
/// (Sec. "Pose Uncertainty", eqs. 23-25; derivations in docs/estimator.md).
///
/// xi = [t_x t_y t_z q_x q_y q_z] of a rigid transform T = (R(q), t), with the unit quaternion
/// q = [q_x q_y q_z, q_w], q_w = sqrt(1 - q_x^2 - q_y^2 - q_z^2) >= 0 (the sign of q is chosen
/// so that q_w >= 0; the parameterisation is valid for rotations below 180 deg, which holds for
/// frame-to-frame motion and for the transforms across a depth-filter window).
#include <Eigen/Core>

#include "pplvo/core/geometry.h"

namespace pplvo {

/// xi of a pose (quaternion sign chosen so that q_w >= 0).
Vector6d poseToXi(const Pose3& T);
/// Pose of xi; |q_xyz| is clamped to 1 (q_w = 0) if it exceeds it.
Pose3 xiToPose(const Vector6d& xi);

/// Motion as [t; angle-axis]: scaling this vector scales the motion (translation and rotation
/// angle; t is scaled directly rather than through the SE(3) log, the same to first order).
/// Zero when T is not finite. The velocity model's and the shared-error estimate's tangent.
Vector6d motionToVector(const Pose3& T);
/// The inverse of motionToVector.
Pose3 vectorToMotion(const Vector6d& v);

/// d(R(v) p)/dv (3x3) with R(v) the rotation of q = [v, sqrt(1 - |v|^2)] (q_w > 0 required).
Eigen::Matrix3d rotatedPointJacobian(const Eigen::Vector3d& v, const Eigen::Vector3d& p);

/// Jacobians of the composition f(xi^(k|1), xi^(k+1|k)) = xi^(k+1|1) (the state transition f
/// of eq. 24, which is eq. 25, eq:pose_comp): t = R^(k+1|k) t^(k|1) + t^(k+1|k),
/// q = q^(k+1|k) (x) q^(k|1). T^(b|a) maps points of frame a into frame b (same convention as T_curr_prev).
struct CompositionJacobians {
  Matrix6d F;  ///< d xi^(k+1|1) / d xi^(k|1)
  Matrix6d G;  ///< d xi^(k+1|1) / d xi^(k+1|k)
};
CompositionJacobians compositionJacobians(const Pose3& T_k_1, const Pose3& T_k1_k);

/// Eq. 22: Sigma^(k+1|1) = F Sigma^(k|1) F^T + G Q G^T with Q = Sigma^(k+1|k).
Matrix6d propagateCompositionCovariance(const Pose3& T_k_1, const Matrix6d& cov_k_1,
                                        const Pose3& T_k1_k, const Matrix6d& cov_k1_k);

/// Covariance of the point T p (first order in xi(T)): p's covariance rotated by R plus the
/// pose's, J cov_xi J^T with J = d(T p)/d xi = [I, rotatedPointJacobian(q_xyz, p)].
/// `q_xyz` is xi(T)'s rotation part (poseToXi(T).tail<3>(), passed in: one per pose, many points).
Eigen::Matrix3d transformedPointCovariance(const Eigen::Matrix3d& R, const Eigen::Vector3d& q_xyz,
                                           const Matrix6d& cov_xi, const Eigen::Vector3d& p,
                                           const Eigen::Matrix3d& cov_p);

/// Covariance of xi(T^-1) given the covariance of xi(T) (first order).
Matrix6d invertedPoseCovariance(const Pose3& T, const Matrix6d& cov);

/// Largest eigenvalue of the translation block (m^2); +inf if the block is not finite.
double maxTranslationVariance(const Matrix6d& cov);
/// Largest eigenvalue of the rotation (q_xyz) block; +inf if not finite.
double maxRotationVariance(const Matrix6d& cov);

}  // namespace pplvo
