#pragma once
/// Weighted least-squares plane fitting with the corrected covariance (paper eqs. 11-12 and the
/// Hessian-form recovery with its Jacobian). Derivations: docs/geometry.md.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/primitives.h"

namespace pplvo::geometry {

struct PlaneFitOptions {
  /// Planes closer than this to the camera centre (|d| from a PCA fit) are rejected: the
  /// minimal parameterisation theta_m = N/d is singular at d = 0 (paper, "WLS Plane Fitting").
  double min_plane_distance_m = 0.05;
  /// Reject if the smallest/largest eigenvalue ratio of A is below this (degenerate support).
  double min_condition = 1e-12;
  /// Re-solve theta_m with the corrected weights 1/Sigma_ri (true = weighted ML estimate;
  /// false = keep the paper's first solution and only correct the covariance).
  bool resolve_with_corrected_weights = true;
  int min_points = 3;
  /// One trimmed refit: points with |theta_m P_i + 1| > k sqrt(Sigma_ri) after the corrected
  /// solve are dropped and the fit repeated (segment pixels from a neighbouring surface); 0 = off.
  double outlier_sigma = 3.0;
};

/// Schema of PlaneFitOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, PlaneFitOptions& o) {
  v.field("min_plane_distance_m", o.min_plane_distance_m,
          "reject planes closer than this to the camera centre: theta_m = N/d is singular at "
          "d = 0 (Sec. 4.3)",
          config::atLeast(0));
  v.field("min_condition", o.min_condition,
          "reject when the smallest/largest eigenvalue ratio of A is below this",
          config::atLeast(0));
  v.field("resolve_with_corrected_weights", o.resolve_with_corrected_weights,
          "solve again with the corrected weights 1/Sigma_ri (false: keep the paper's first "
          "solution, correct only the covariance)");
  v.field("min_points", o.min_points, "fewest points of a fit", config::atLeast(3));
  v.field("outlier_sigma", o.outlier_sigma,
          "one trimmed refit drops points with |theta_m P_i + 1| > k sqrt(Sigma_ri); 0 = off",
          config::atLeast(0));
}

enum class FitStatus { kOk, kTooFewPoints, kThroughCameraCentre, kDegenerate, kNonFinite };
const char* toString(FitStatus s);

struct PlaneFitResult {
  FitStatus status = FitStatus::kTooFewPoints;
  bool ok() const { return status == FitStatus::kOk; }
  Eigen::Vector3d theta_m = Eigen::Vector3d::Zero();      ///< N/d, 1/m (theta_m . P + 1 = 0)
  Eigen::Matrix3d cov_theta_m = Eigen::Matrix3d::Zero();  ///< 1/m^2, inverse corrected A
  PlaneWithCov plane;                                     ///< n.p + d = 0, d > 0, 4x4 cov
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();     ///< unweighted mean, m
  double rms_m = 0.0;                                     ///< rms point-to-plane distance
  int n_points = 0;
  int n_outliers = 0;  ///< dropped by the trimmed refit
};

/// Fits a plane to points P_i (camera frame, m) with covariances Sigma_Pi and depth variances
/// var_z_i (initial weights w_i = 1/var_z_i, eq. 11). Returns a status instead of throwing.
PlaneFitResult fitPlaneWls(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<Eigen::Matrix3d>& covs,
                           const std::vector<double>& var_z_m2,
                           const PlaneFitOptions& options = {});

/// Eq. 11 (Hessian form from theta_m) with its Jacobian d[n; d]/d theta_m (4x3).
PlaneWithCov hessianFromMinimal(const Eigen::Vector3d& theta_m, const Eigen::Matrix3d& cov_theta_m,
                                Eigen::Matrix<double, 4, 3>* jacobian = nullptr);

}  // namespace pplvo::geometry
