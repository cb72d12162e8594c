#pragma once
/// The residuals of the joint cost E (paper eqs. 19-21; docs/estimator.md) with their Jacobians
/// with respect to the pose xi = [t; q_xyz] (pose_parameterisation.h) and their covariances.
/// The terms keep their data plus the weighting state that PoseEstimator fixes during one
/// Ceres solve (IRLS). Inline: the estimator calls them in its innermost loops. Exposed so that
/// every Jacobian is checked numerically (test_residual_jacobians).
#include <Eigen/Core>

#include "pplvo/core/geometry.h"
#include "pplvo/estimator/pose_parameterisation.h"

namespace pplvo::estimator {

struct PointTerm {
  Eigen::Vector3d P;
  Eigen::Matrix3d cov;
  Eigen::Vector2d px;
  double var_px2;
  // weighting state
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();  // whitening: r_w = S r
  double sqrt_tukey = 1.0;
  bool active = false;
};

struct LineTerm {
  Eigen::Vector3d P[2];
  Eigen::Matrix3d cov[2];
  Eigen::Vector3d l;
  double var_px2;
  double s[2] = {0, 0};  // whitening of each endpoint distance
  double sqrt_tukey = 1.0;
  bool active = false;
};

struct PlaneTerm {
  Eigen::Vector4d prev, curr;
  Eigen::Matrix4d cov_prev, cov_curr;
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();  // whitening (without alpha)
  bool active = false;
};

/// Pose with the derivatives of R(v) w.r.t. each q_xyz component.
struct PoseEval {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  Eigen::Matrix3d dR[3];  // dR/dv_k
  bool valid = false;

  explicit PoseEval(const double* xi) {
    const Eigen::Vector3d v(xi[3], xi[4], xi[5]);
    t = Eigen::Vector3d(xi[0], xi[1], xi[2]);
    if (!(v.squaredNorm() < 1.0 - 1e-9) || !t.allFinite() || !v.allFinite()) return;
    R = xiToPose((Vector6d() << t, v).finished()).linear();
    Eigen::Matrix3d M[3];
    for (int j = 0; j < 3; ++j) M[j] = rotatedPointJacobian(v, Eigen::Vector3d::Unit(j));
    // column k of M[j] is dR/dv_k * e_j, i.e. column j of dR/dv_k.
    for (int k = 0; k < 3; ++k) {
      for (int j = 0; j < 3; ++j) dR[k].col(j) = M[j].col(k);
    }
    valid = true;
  }
  Eigen::Matrix3d dRp(const Eigen::Vector3d& p) const {
    Eigen::Matrix3d out;
    for (int k = 0; k < 3; ++k) out.col(k) = dR[k] * p;
    return out;
  }
};

using Matrix26 = Eigen::Matrix<double, 2, 6>;
using Matrix36 = Eigen::Matrix<double, 3, 6>;
using Matrix23 = Eigen::Matrix<double, 2, 3>;

struct Projector {
  double fx, fy, cx, cy, min_depth;
  bool project(const Eigen::Vector3d& X, Eigen::Vector2d& px, Matrix23& dpi) const {
    if (!(X.z() > min_depth)) return false;
    const double iz = 1.0 / X.z();
    px = {fx * X.x() * iz + cx, fy * X.y() * iz + cy};
    dpi << fx * iz, 0, -fx * X.x() * iz * iz, 0, fy * iz, -fy * X.y() * iz * iz;
    return true;
  }
};

/// Residual (eq. 19) and its Jacobian w.r.t. xi; Sigma_r if requested.
inline bool pointResidual(const PointTerm& T, const PoseEval& pose, const Projector& cam,
                          Eigen::Vector2d& r, Matrix26* J, Eigen::Matrix2d* Sigma_r) {
  const Eigen::Vector3d X = pose.R * T.P + pose.t;
  Eigen::Vector2d px;
  Matrix23 dpi;
  if (!cam.project(X, px, dpi)) return false;
  r = T.px - px;
  if (J) {
    J->leftCols<3>() = -dpi;
    J->rightCols<3>() = -dpi * pose.dRp(T.P);
  }
  if (Sigma_r) {
    const Matrix23 JP = dpi * pose.R;
    *Sigma_r = JP * T.cov * JP.transpose() + T.var_px2 * Eigen::Matrix2d::Identity();
  }
  return true;
}

/// Residual (eq. 20): signed distances of the projected endpoints to l_curr.
inline bool lineResidual(const LineTerm& T, const PoseEval& pose, const Projector& cam,
                         Eigen::Vector2d& r, Matrix26* J, Eigen::Vector2d* var_r) {
  for (int i = 0; i < 2; ++i) {
    const Eigen::Vector3d X = pose.R * T.P[i] + pose.t;
    Eigen::Vector2d px;
    Matrix23 dpi;
    if (!cam.project(X, px, dpi)) return false;
    r(i) = T.l(0) * px.x() + T.l(1) * px.y() + T.l(2);
    const Eigen::RowVector3d g = T.l.head<2>().transpose() * dpi;  // d r_i / d X
    if (J) {
      J->block<1, 3>(i, 0) = g;
      J->block<1, 3>(i, 3) = g * pose.dRp(T.P[i]);
    }
    if (var_r) {
      const Eigen::RowVector3d gR = g * pose.R;
      (*var_r)(i) = gR * T.cov[i] * gR.transpose() + T.var_px2;
    }
  }
  return true;
}

/// Residual (eq. 21, our form): the previous plane moved into the current frame,
/// {n_c = R N, d_c = d - n_c . t} (PlaneWithCov::transformed), compared with the current plane
/// through their plane "points": r = d_c n_c - d' N'.
inline void planeResidual(const PlaneTerm& T, const PoseEval& pose, Eigen::Vector3d& r, Matrix36* J,
                          Eigen::Matrix3d* Sigma_r) {
  const Eigen::Vector3d N = T.prev.head<3>(), Nc = T.curr.head<3>();
  const Eigen::Vector3d n = pose.R * N;
  const double dc = T.prev(3) - n.dot(pose.t);
  r = dc * n - T.curr(3) * Nc;
  if (J) {
    J->leftCols<3>() = -n * n.transpose();
    J->rightCols<3>() = (dc * Eigen::Matrix3d::Identity() - n * pose.t.transpose()) * pose.dRp(N);
  }
  if (Sigma_r) {
    Eigen::Matrix<double, 3, 4> dr_dpc;  // d r / d [n_c; d_c]
    dr_dpc << dc * Eigen::Matrix3d::Identity(), n;
    Eigen::Matrix4d Jt = Eigen::Matrix4d::Zero();  // d [n_c; d_c] / d [N; d]
    Jt.topLeftCorner<3, 3>() = pose.R;
    Jt.block<1, 3>(3, 0) = -pose.t.transpose() * pose.R;
    Jt(3, 3) = 1.0;
    const Eigen::Matrix<double, 3, 4> A = dr_dpc * Jt;
    Eigen::Matrix<double, 3, 4> B;
    B << -T.curr(3) * Eigen::Matrix3d::Identity(), -Nc;
    *Sigma_r = A * T.cov_prev * A.transpose() + B * T.cov_curr * B.transpose();
  }
}

}  // namespace pplvo::estimator
