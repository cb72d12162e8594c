#include "pplvo/estimator/pose_parameterisation.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>

namespace pplvo {

namespace {

Eigen::Quaterniond quatOfXi(const Eigen::Vector3d& v_in) {
  Eigen::Vector3d v = v_in;
  const double n2 = v.squaredNorm();
  if (n2 > 1.0) v /= std::sqrt(n2);
  const double w = std::sqrt(std::max(0.0, 1.0 - v.squaredNorm()));
  return Eigen::Quaterniond(w, v.x(), v.y(), v.z());
}

double maxEigenvalue(const Eigen::Matrix3d& B) {
  if (!B.allFinite()) return std::numeric_limits<double>::infinity();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(0.5 * (B + B.transpose()),
                                                    Eigen::EigenvaluesOnly);
  return es.eigenvalues().maxCoeff();
}

}  // namespace

Vector6d poseToXi(const Pose3& T) {
  Eigen::Quaterniond q(T.linear());
  q.normalize();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  Vector6d xi;
  xi << T.translation(), q.vec();
  return xi;
}

Pose3 xiToPose(const Vector6d& xi) { return makePose(xi.head<3>(), quatOfXi(xi.tail<3>())); }

Vector6d motionToVector(const Pose3& T) {
  const Eigen::AngleAxisd aa(T.linear());
  Vector6d v;
  v << T.translation(), aa.angle() * aa.axis();
  return v.allFinite() ? v : Vector6d::Zero();
}

Pose3 vectorToMotion(const Vector6d& v) {
  Pose3 T = Pose3::Identity();
  const double angle = v.tail<3>().norm();
  if (angle > 1e-15) T.linear() = Eigen::AngleAxisd(angle, v.tail<3>() / angle).toRotationMatrix();
  T.translation() = v.head<3>();
  return T;
}

Eigen::Matrix3d rotatedPointJacobian(const Eigen::Vector3d& v, const Eigen::Vector3d& p) {
  // R(q) p = p + 2 w (u x p) + 2 u x (u x p), u = v, w = sqrt(1 - |v|^2).
  const double w = std::sqrt(std::max(1e-300, 1.0 - v.squaredNorm()));
  const Eigen::Vector3d uxp = v.cross(p);
  Eigen::Matrix3d d_du =
      -2.0 * w * skew(p) +
      2.0 * (v * p.transpose() + v.dot(p) * Eigen::Matrix3d::Identity() - 2.0 * p * v.transpose());
  // + d/dw * dw/dv, dw/dv = -v^T / w
  d_du += (2.0 * uxp) * (-v.transpose() / w);
  return d_du;
}

CompositionJacobians compositionJacobians(const Pose3& T_k_1, const Pose3& T_k1_k) {
  const Vector6d xi1 = poseToXi(T_k_1);
  const Vector6d xi2 = poseToXi(T_k1_k);
  const Eigen::Vector3d t1 = xi1.head<3>(), v1 = xi1.tail<3>(), v2 = xi2.tail<3>();
  const double w1 = std::sqrt(std::max(1e-300, 1.0 - v1.squaredNorm()));
  const double w2 = std::sqrt(std::max(1e-300, 1.0 - v2.squaredNorm()));
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  // q = q2 (x) q1: vec = w2 v1 + w1 v2 + v2 x v1, w = w2 w1 - v2 . v1.
  Eigen::Matrix3d dv_dv1 = w2 * I + skew(v2) - v2 * v1.transpose() / w1;
  Eigen::Matrix3d dv_dv2 = w1 * I - skew(v1) - v1 * v2.transpose() / w2;
  const double w = w2 * w1 - v2.dot(v1);
  if (w < 0) {  // the composed quaternion is re-signed so that q_w >= 0
    dv_dv1 = -dv_dv1;
    dv_dv2 = -dv_dv2;
  }
  CompositionJacobians J;
  J.F.setZero();
  J.G.setZero();
  J.F.topLeftCorner<3, 3>() = T_k1_k.linear();
  J.F.bottomRightCorner<3, 3>() = dv_dv1;
  J.G.topLeftCorner<3, 3>() = I;
  J.G.topRightCorner<3, 3>() = rotatedPointJacobian(v2, t1);
  J.G.bottomRightCorner<3, 3>() = dv_dv2;
  return J;
}

Matrix6d propagateCompositionCovariance(const Pose3& T_k_1, const Matrix6d& cov_k_1,
                                        const Pose3& T_k1_k, const Matrix6d& cov_k1_k) {
  const CompositionJacobians J = compositionJacobians(T_k_1, T_k1_k);
  Matrix6d out = J.F * cov_k_1 * J.F.transpose() + J.G * cov_k1_k * J.G.transpose();
  return 0.5 * (out + out.transpose());
}

Eigen::Matrix3d transformedPointCovariance(const Eigen::Matrix3d& R, const Eigen::Vector3d& q_xyz,
                                           const Matrix6d& cov_xi, const Eigen::Vector3d& p,
                                           const Eigen::Matrix3d& cov_p) {
  Eigen::Matrix<double, 3, 6> J;
  J.leftCols<3>().setIdentity();
  J.rightCols<3>() = rotatedPointJacobian(q_xyz, p);
  return R * cov_p * R.transpose() + J * cov_xi * J.transpose();
}

Matrix6d invertedPoseCovariance(const Pose3& T, const Matrix6d& cov) {
  // T^-1: t' = -R(v')^T... with v' = -v (conjugate, same q_w), t' = -R(v') t.
  const Vector6d xi = poseToXi(T);
  const Eigen::Vector3d t = xi.head<3>(), v = xi.tail<3>();
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = -T.linear().transpose();
  J.topRightCorner<3, 3>() = rotatedPointJacobian(-v, t);
  J.bottomRightCorner<3, 3>() = -Eigen::Matrix3d::Identity();
  Matrix6d out = J * cov * J.transpose();
  return 0.5 * (out + out.transpose());
}

double maxTranslationVariance(const Matrix6d& cov) {
  return maxEigenvalue(cov.topLeftCorner<3, 3>());
}

double maxRotationVariance(const Matrix6d& cov) {
  return maxEigenvalue(cov.bottomRightCorner<3, 3>());
}

}  // namespace pplvo
