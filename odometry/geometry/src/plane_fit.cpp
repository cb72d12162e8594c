#include "pplvo/geometry/plane_fit.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>

#include "pplvo/core/enum_names.h"

namespace pplvo::geometry {

namespace {
constexpr EnumName<FitStatus> kFitStatusNames[] = {
    {FitStatus::kOk, "ok"},
    {FitStatus::kTooFewPoints, "too_few_points"},
    {FitStatus::kThroughCameraCentre, "through_camera_centre"},
    {FitStatus::kDegenerate, "degenerate"},
    {FitStatus::kNonFinite, "non_finite"}};
}  // namespace

const char* toString(FitStatus s) { return enumName(kFitStatusNames, s, "unknown"); }

PlaneWithCov hessianFromMinimal(const Eigen::Vector3d& theta_m, const Eigen::Matrix3d& cov_theta_m,
                                Eigen::Matrix<double, 4, 3>* jacobian) {
  // theta = [theta_m, 1] / |theta_m|: n = theta_m / |theta_m|, d = 1 / |theta_m| > 0.
  const double s = theta_m.norm();
  const Eigen::Vector3d n = theta_m / s;
  const double d = 1.0 / s;
  Eigen::Matrix<double, 4, 3> J;
  J.topRows<3>() = (Eigen::Matrix3d::Identity() - n * n.transpose()) / s;  // dn/dtheta_m
  J.row(3) = -n.transpose() / (s * s);                                     // dd/dtheta_m
  PlaneWithCov out;
  out.hessian << n, d;
  out.cov = J * cov_theta_m * J.transpose();
  if (jacobian) *jacobian = J;
  return out;
}

PlaneFitResult fitPlaneWls(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<Eigen::Matrix3d>& covs,
                           const std::vector<double>& var_z_m2, const PlaneFitOptions& options) {
  PlaneFitResult res;
  const size_t n = points.size();
  res.n_points = static_cast<int>(n);
  if (n < static_cast<size_t>(std::max(3, options.min_points)) || covs.size() != n ||
      var_z_m2.size() != n) {
    res.status = FitStatus::kTooFewPoints;
    return res;
  }
  // PCA first: detects planes through the camera centre (d ~ 0) before theta_m = N/d blows up.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(n);
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : points) scatter += (p - mean) * (p - mean).transpose();
  if (!mean.allFinite() || !scatter.allFinite()) {
    res.status = FitStatus::kNonFinite;
    return res;
  }
  res.centroid = mean;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(scatter);
  const Eigen::Vector3d ev = pca.eigenvalues();
  if (!(ev(2) > 0.0) || ev(1) < 1e-12 * ev(2)) {
    res.status = FitStatus::kDegenerate;  // collinear or coincident points
    return res;
  }
  const Eigen::Vector3d n_pca = pca.eigenvectors().col(0);
  if (std::abs(n_pca.dot(mean)) < options.min_plane_distance_m) {
    res.status = FitStatus::kThroughCameraCentre;
    return res;
  }

  // Eq. 10: E = sum w_i (theta_m P_i + 1)^2 / 2, w_i = 1 / sigma_Zi^2
  //   => A theta_m = b, A = sum w_i P_i P_i^T, b = -sum w_i P_i.
  // weigh(i) gives w_i; stored in w (used again below) and accumulated in the same pass.
  std::vector<double> w(n);
  auto solve = [&](auto weigh, Eigen::Matrix3d* A_out, Eigen::Vector3d* th) {
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < n; ++i) {
      w[i] = weigh(i);
      A.noalias() += w[i] * points[i] * points[i].transpose();
      b -= w[i] * points[i];
    }
    *A_out = A;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(A);
    const Eigen::Vector3d e = es.eigenvalues();
    if (!(e(0) > options.min_condition * e(2))) return false;
    *th = A.ldlt().solve(b);
    return th->allFinite();
  };
  Eigen::Matrix3d A;
  Eigen::Vector3d theta_m;
  if (!solve([&](size_t i) { return 1.0 / var_z_m2[i]; }, &A, &theta_m)) {
    res.status = FitStatus::kDegenerate;
    return res;
  }
  // Corrected weights: 1 / Sigma_ri, Sigma_ri = theta_m^T Sigma_Pi theta_m (residual of eq. 11).
  const auto corrected = [&](size_t i) {
    const double s = theta_m.dot(covs[i] * theta_m);
    return 1.0 / std::max(s, 1e-300);
  };
  Eigen::Vector3d theta_corr;
  Eigen::Matrix3d A_corr;
  if (!solve(corrected, &A_corr, &theta_corr)) {
    res.status = FitStatus::kDegenerate;
    return res;
  }
  if (options.resolve_with_corrected_weights) theta_m = theta_corr;
  if (options.outlier_sigma > 0) {
    // Trim residuals beyond k sigma_ri and repeat the corrected solve once.
    int n_out = 0;
    std::vector<double> w2 = w;
    for (size_t i = 0; i < n; ++i) {
      const double r = theta_m.dot(points[i]) + 1.0;
      if (r * r * w[i] > options.outlier_sigma * options.outlier_sigma) {
        w2[i] = 0.0;
        ++n_out;
      }
    }
    if (n_out > 0 && static_cast<int>(n) - n_out >= std::max(3, options.min_points)) {
      // Weights of the kept points from the current estimate.
      if (solve([&](size_t i) { return w2[i] > 0 ? corrected(i) : w2[i]; }, &A_corr,
                &theta_corr)) {
        theta_m = theta_corr;
        res.n_outliers = n_out;
      }
    }
  }
  res.theta_m = theta_m;
  res.cov_theta_m = A_corr.inverse();
  if (!res.cov_theta_m.allFinite() || !(theta_m.norm() > 0.0)) {
    res.status = FitStatus::kNonFinite;
    return res;
  }
  res.plane = hessianFromMinimal(theta_m, res.cov_theta_m);
  double ss = 0.0;
  for (const auto& p : points) {
    const double r = res.plane.distance(p);
    ss += r * r;
  }
  res.rms_m = std::sqrt(ss / static_cast<double>(n));
  res.status = FitStatus::kOk;
  return res;
}

}  // namespace pplvo::geometry
