#include "pplvo/geometry/line_fit.h"

#include <Eigen/LU>
#include <cmath>

#include "pplvo/core/geometry.h"

namespace pplvo::geometry {

Point3WithCov interpolateLineEndpoint(const Eigen::Vector3d& O, const Eigen::Matrix3d& cov_O,
                                      const Eigen::Vector3d& theta,
                                      const Eigen::Matrix3d& cov_theta,
                                      const Eigen::Vector3d& P_end) {
  const double t2 = theta.squaredNorm();
  const Eigen::Vector3d Pp = P_end - O;
  const double lambda = theta.dot(Pp) / t2;
  // d lambda / d O = -theta^T / |theta|^2;  d lambda / d theta = (P'^T - 2 lambda theta^T) /
  // |theta|^2
  const Eigen::Matrix3d J_O = Eigen::Matrix3d::Identity() - theta * theta.transpose() / t2;
  const Eigen::Matrix3d J_t =
      lambda * Eigen::Matrix3d::Identity() + theta * (Pp - 2.0 * lambda * theta).transpose() / t2;
  Point3WithCov out;
  out.p = O + lambda * theta;
  out.cov = J_O * cov_O * J_O.transpose() + J_t * cov_theta * J_t.transpose();
  return out;
}

namespace {

// M = sum w_i (|P'_i|^2 I - P'_i P'_i^T), so that E = theta^T M theta / 2 (eq. 13).
Eigen::Matrix3d crossMoment(const std::vector<Eigen::Vector3d>& Pp, const std::vector<double>& w) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < Pp.size(); ++i) {
    M.noalias() +=
        w[i] * (Pp[i].squaredNorm() * Eigen::Matrix3d::Identity() - Pp[i] * Pp[i].transpose());
  }
  return M;
}

// Matrix-weighted version: M = sum [P'_i]x^T W_i [P'_i]x, E = theta^T M theta / 2.
Eigen::Matrix3d crossMoment(const std::vector<Eigen::Vector3d>& Pp,
                            const std::vector<Eigen::Matrix3d>& W) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < Pp.size(); ++i) {
    const Eigen::Matrix3d S = skew(Pp[i]);
    M.noalias() += S.transpose() * W[i] * S;
  }
  return M;
}

// Eqs. 13-15 for fixed dimension k: with m = the two free indices (ascending),
// A = M(m, m), b = -M(m, k), theta_m = A^-1 b.
bool solveDirection(const Eigen::Matrix3d& M, int k, Eigen::Vector3d* theta,
                    Eigen::Matrix2d* A_out) {
  const int a = (k == 0) ? 1 : 0;
  const int b_i = (k == 2) ? 1 : 2;
  Eigen::Matrix2d A;
  A << M(a, a), M(a, b_i), M(b_i, a), M(b_i, b_i);
  const Eigen::Vector2d b(-M(a, k), -M(b_i, k));
  const double det = A.determinant();
  if (!(std::abs(det) > 1e-18 * A.squaredNorm()) || !std::isfinite(det)) return false;
  const Eigen::Vector2d th = A.inverse() * b;
  if (!th.allFinite()) return false;
  (*theta)(k) = 1.0;
  (*theta)(a) = th(0);
  (*theta)(b_i) = th(1);
  *A_out = A;
  return true;
}

}  // namespace

LineFitResult fitLineWls(const std::vector<Eigen::Vector3d>& points,
                         const std::vector<Eigen::Matrix3d>& covs,
                         const std::vector<double>& var_z_m2, const Eigen::Vector3d& end1,
                         const Eigen::Vector3d& end2, const LineFitOptions& options) {
  LineFitResult res;
  const size_t n = points.size();
  if (n < 3 || covs.size() != n || var_z_m2.size() != n) {
    res.status = FitStatus::kTooFewPoints;
    return res;
  }
  // Centroid with normalised weights w_i = sigma_Zi^-2 / sum_j sigma_Zj^-2;
  // Sigma_O = sum w_i^2 Sigma_Pi.
  std::vector<double> w(n);
  double wsum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    w[i] = 1.0 / var_z_m2[i];
    wsum += w[i];
  }
  if (!(wsum > 0.0) || !std::isfinite(wsum)) {
    res.status = FitStatus::kNonFinite;
    return res;
  }
  Eigen::Vector3d O = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov_O = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    const double wi = w[i] / wsum;
    O += wi * points[i];
    cov_O += wi * wi * covs[i];
  }
  std::vector<Eigen::Vector3d> Pp(n);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (size_t i = 0; i < n; ++i) {
    Pp[i] = points[i] - O;
    lo = lo.cwiseMin(Pp[i]);
    hi = hi.cwiseMax(Pp[i]);
  }
  if (!O.allFinite()) {
    res.status = FitStatus::kNonFinite;
    return res;
  }
  int k = 0;
  (hi - lo).maxCoeff(&k);  // fix the dimension with the largest range of samples
  if ((hi - lo).norm() < options.min_extent_m) {
    res.status = FitStatus::kDegenerate;
    return res;
  }
  // First solve with w_i = sigma_Zi^-2 (the scale of w does not change theta).
  Eigen::Vector3d theta;
  Eigen::Matrix2d A;
  if (!solveDirection(crossMoment(Pp, w), k, &theta, &A)) {
    res.status = FitStatus::kDegenerate;
    return res;
  }
  const Eigen::Matrix3d S = skew(theta);
  Eigen::Matrix3d M2;
  if (options.weighting == LineFitOptions::Weighting::kPaperScalar) {
    // Corrected weights: r_i = |P'_i x theta|, Sigma_ri = J_ri Sigma_Pi J_ri^T with
    // J_ri = (c_i / |c_i|)^T (-[theta]x), c_i = P'_i x theta; perturb P'_i when r_i = 0.
    const Eigen::Vector3d perp = theta.unitOrthogonal();
    for (size_t i = 0; i < n; ++i) {
      Eigen::Vector3d c = Pp[i].cross(theta);
      if (c.norm() < 1e-12 * std::max(1.0, Pp[i].norm() * theta.norm())) {
        c = (Pp[i] + options.zero_residual_perturbation_m * perp).cross(theta);
      }
      const Eigen::RowVector3d J = -(c / c.norm()).transpose() * S;
      const double s = J * covs[i] * J.transpose();
      w[i] = 1.0 / std::max(s, 1e-300);
    }
    M2 = crossMoment(Pp, w);
  } else {
    // W_i = S_i^+ with S_i = [theta]x Sigma_Pi [theta]x^T, inverted in the plane orthogonal to
    // theta.
    Eigen::Matrix<double, 3, 2> U;
    U.col(0) = theta.unitOrthogonal();
    U.col(1) = theta.normalized().cross(U.col(0));
    std::vector<Eigen::Matrix3d> W(n);
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Matrix<double, 3, 2> H = S * U;  // c = -[theta]x P', so U^T S_i U = H^T Sigma H
      const Eigen::Matrix2d Si = H.transpose() * covs[i] * H;
      W[i] = U * Si.inverse() * U.transpose();
    }
    M2 = crossMoment(Pp, W);
  }
  Eigen::Vector3d theta2;
  Eigen::Matrix2d A2;
  if (!solveDirection(M2, k, &theta2, &A2)) {
    res.status = FitStatus::kDegenerate;
    return res;
  }
  if (options.resolve_with_corrected_weights) theta = theta2;
  const int a = (k == 0) ? 1 : 0;
  const int b_i = (k == 2) ? 1 : 2;
  const Eigen::Matrix2d cov_m = A2.inverse();  // Sigma_theta_m = A^-1 of the corrected system
  Eigen::Matrix3d cov_theta = Eigen::Matrix3d::Zero();
  cov_theta(a, a) = cov_m(0, 0);
  cov_theta(a, b_i) = cov_m(0, 1);
  cov_theta(b_i, a) = cov_m(1, 0);
  cov_theta(b_i, b_i) = cov_m(1, 1);
  if (!cov_theta.allFinite() || !cov_O.allFinite()) {
    res.status = FitStatus::kNonFinite;
    return res;
  }
  res.centroid = O;
  res.cov_centroid = cov_O;
  res.theta = theta;
  res.cov_theta = cov_theta;
  res.fixed_dim = k;
  const Point3WithCov e1 = interpolateLineEndpoint(O, cov_O, theta, cov_theta, end1);
  const Point3WithCov e2 = interpolateLineEndpoint(O, cov_O, theta, cov_theta, end2);
  res.line.p1 = e1.p;
  res.line.cov1 = e1.cov;
  res.line.p2 = e2.p;
  res.line.cov2 = e2.cov;
  if ((e2.p - e1.p).norm() < options.min_extent_m) {
    res.status = FitStatus::kDegenerate;
    return res;
  }
  res.status = FitStatus::kOk;
  return res;
}

}  // namespace pplvo::geometry
