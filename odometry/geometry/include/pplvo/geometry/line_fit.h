#pragma once
/// Analytic weighted least-squares 3D line fitting (paper eqs. 13-17): centroid O, direction
/// theta with one entry fixed to 1, corrected covariance, interpolated endpoints.
/// Derivations: docs/geometry.md.
#include <Eigen/Core>
#include <vector>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/primitives.h"
#include "pplvo/geometry/plane_fit.h"  // FitStatus

namespace pplvo::geometry {

struct LineFitOptions {
  /// Re-solve theta_m with the corrected weights 1/Sigma_ri (true) or keep the first solution
  /// and only correct the covariance (false, the paper's literal wording).
  bool resolve_with_corrected_weights = true;
  /// Minimum spread of the samples along the line, metres (shorter support is degenerate).
  double min_extent_m = 0.01;
  /// Weights of the second solve. kPaperScalar: w_i = 1/Sigma_ri with Sigma_ri = J_ri Sigma_Pi
  /// J_ri^T, r_i = |P'_i x theta| (the paper); Sigma_theta_m = A^-1. The weight depends on the
  /// direction of the noisy residual, which makes the covariance optimistic (measured mean NEES
  /// ~1.2 x dof). kResidualCovariance (default): the 3-vector residual c_i = P'_i x theta gets
  /// the matrix weight W_i = S_i^+, S_i = [theta]x Sigma_Pi [theta]x^T (rank 2), i.e.
  /// E = sum c_i^T W_i c_i / 2, still linear in theta_m; Sigma_theta_m = A^-1 is then the
  /// Fisher information of the model (measured mean NEES ~1.0 x dof). See docs/geometry.md.
  enum class Weighting { kPaperScalar, kResidualCovariance };
  Weighting weighting = Weighting::kResidualCovariance;
  /// Size of the perturbation added to P'_i when r_i = 0 (J_ri undefined), metres.
  double zero_residual_perturbation_m = 1e-6;
};

/// Schema of LineFitOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, LineFitOptions& o) {
  v.field("resolve_with_corrected_weights", o.resolve_with_corrected_weights,
          "solve theta_m again with the corrected weights (false: the paper's literal "
          "wording, covariance corrected only)");
  v.field("min_extent_m", o.min_extent_m, "smallest spread of the samples along the line (m)",
          config::atLeast(0));
  v.field("weighting", o.weighting,
          "weights of the second solve: paper_scalar (w_i = 1/Sigma_ri, the paper) or "
          "residual_covariance (matrix weight, consistent covariance; docs/geometry.md)");
  v.field("zero_residual_perturbation_m", o.zero_residual_perturbation_m,
          "perturbation of P'_i where r_i = 0 (m)", config::positive());
}

struct LineFitResult {
  FitStatus status = FitStatus::kTooFewPoints;
  bool ok() const { return status == FitStatus::kOk; }
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();      ///< O, m
  Eigen::Matrix3d cov_centroid = Eigen::Matrix3d::Zero();  ///< Sigma_O, m^2
  Eigen::Vector3d theta = Eigen::Vector3d::UnitX();        ///< direction with theta(fixed_dim) = 1
  Eigen::Matrix3d cov_theta = Eigen::Matrix3d::Zero();     ///< zero row/col at fixed_dim
  int fixed_dim = 0;
  Line3WithCov line;  ///< endpoints O + lambda theta (eq. 17) with covariances
};

/// Fits a line to points P_i (camera frame, m) with covariances Sigma_Pi and depth variances
/// var_z_i (weights 1/var_z_i for O and the first solve). `end1`, `end2` are the measured
/// endpoint samples projected onto the fitted line to give line.p1 and line.p2.
LineFitResult fitLineWls(const std::vector<Eigen::Vector3d>& points,
                         const std::vector<Eigen::Matrix3d>& covs,
                         const std::vector<double>& var_z_m2, const Eigen::Vector3d& end1,
                         const Eigen::Vector3d& end2, const LineFitOptions& options = {});

/// Endpoint of eq. 17, P_hat = O + lambda theta with lambda = theta^T (P_end - O) / |theta|^2,
/// and its covariance J_O Sigma_O J_O^T + J_theta Sigma_theta J_theta^T.
Point3WithCov interpolateLineEndpoint(const Eigen::Vector3d& O, const Eigen::Matrix3d& cov_O,
                                      const Eigen::Vector3d& theta,
                                      const Eigen::Matrix3d& cov_theta,
                                      const Eigen::Vector3d& P_end);

}  // namespace pplvo::geometry

namespace pplvo::config {
template <>
struct EnumText<geometry::LineFitOptions::Weighting> {
  using Weighting = geometry::LineFitOptions::Weighting;
  static bool parse(const std::string& s, Weighting* out) {
    if (s == "residual_covariance")
      *out = Weighting::kResidualCovariance;
    else if (s == "paper_scalar")
      *out = Weighting::kPaperScalar;
    else
      return false;
    return true;
  }
  static std::string name(Weighting w) {
    return w == Weighting::kPaperScalar ? "paper_scalar" : "residual_covariance";
  }
  static const char* choices() { return "residual_covariance, paper_scalar"; }
};
}  // namespace pplvo::config
