#pragma once
/// Rigid-body helpers on Eigen types. Naming: T_a_b maps points from frame b to frame a.
#include <algorithm>
#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pplvo {

using Pose3 = Eigen::Isometry3d;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// Pose from translation and unit quaternion (normalised here).
inline Pose3 makePose(const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
  Pose3 T = Pose3::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

/// Rotation angle of R in radians, robust near 0 and pi.
inline double rotationAngle(const Eigen::Matrix3d& R) {
  const double c = std::min(1.0, std::max(-1.0, (R.trace() - 1.0) * 0.5));
  const double s = 0.5 * Eigen::Vector3d(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1)).norm();
  return std::atan2(s, c);
}

/// Skew-symmetric matrix: skew(a) * b == a.cross(b).
inline Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d S;
  S << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return S;
}

/// True when every entry of the pose is finite and its rotation is orthonormal.
inline bool isValidPose(const Pose3& T, double tol = 1e-6) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < tol &&
         std::abs(R.determinant() - 1.0) < tol;
}

/// Symmetric matrix from its row-major upper triangle (3x3: 6 values, 4x4: 10 values).
template <int N, typename Scalar>
Eigen::Matrix<double, N, N> symmetricFromUpper(const Scalar* upper) {
  Eigen::Matrix<double, N, N> M;
  int k = 0;
  for (int r = 0; r < N; ++r) {
    for (int c = r; c < N; ++c) {
      M(r, c) = M(c, r) = static_cast<double>(upper[k++]);
    }
  }
  return M;
}

/// Row-major upper triangle of a square matrix (the inverse of symmetricFromUpper).
template <int N, typename Scalar>
void upperFromSymmetric(const Eigen::Matrix<double, N, N>& M, Scalar* upper) {
  int k = 0;
  for (int r = 0; r < N; ++r) {
    for (int c = r; c < N; ++c) upper[k++] = static_cast<Scalar>(0.5 * (M(r, c) + M(c, r)));
  }
}

}  // namespace pplvo
