#include "pplvo/estimator/pose_estimator.h"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "pplvo/core/enum_names.h"
#include "pplvo/estimator/pose_parameterisation.h"
#include "pplvo/estimator/residuals.h"

namespace pplvo::estimator {

namespace {
/// Fewest residual rows worth a solve: one more than the six pose parameters. Six rows are
/// fitted exactly whatever the matches, so nothing would check the solution.
constexpr int kMinRowsToSolve = 7;

constexpr EnumName<EstimateStatus> kEstimateStatusNames[] = {
    {EstimateStatus::kOk, "ok"},
    {EstimateStatus::kNoConstraints, "no_constraints"},
    {EstimateStatus::kTooFewConstraints, "too_few_constraints"},
    {EstimateStatus::kDegenerate, "degenerate"},
    {EstimateStatus::kUncertain, "uncertain"},
    {EstimateStatus::kSolverFailure, "solver_failure"}};
}  // namespace

const char* toString(EstimateStatus s) { return enumName(kEstimateStatusNames, s, "unknown"); }

namespace {

// ---------------------------------------------------------------------------------------------
// Input validation.

template <int N>
bool isPsd(const Eigen::Matrix<double, N, N>& C) {
  const double scale = std::max(1e-300, C.cwiseAbs().maxCoeff());
  if ((C - C.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) return false;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> es;
  if constexpr (N == 3) {
    es.computeDirect(C, Eigen::EigenvaluesOnly);
  } else {
    es.compute(C, Eigen::EigenvaluesOnly);
  }
  return es.eigenvalues().minCoeff() >= -1e-10 * scale;
}

// ---------------------------------------------------------------------------------------------
// Terms of the joint cost E. Each keeps its data plus the weighting state that is fixed
// during one Ceres solve (IRLS).


template <int N>
bool whitening(const Eigen::Matrix<double, N, N>& Sigma, bool full,
               Eigen::Matrix<double, N, N>& S) {
  if (!Sigma.allFinite()) return false;
  if (!full) {
    S.setZero();
    for (int i = 0; i < N; ++i) {
      if (!(Sigma(i, i) > 0)) return false;
      S(i, i) = 1.0 / std::sqrt(Sigma(i, i));
    }
    return true;
  }
  Eigen::LLT<Eigen::Matrix<double, N, N>> llt(Sigma);
  if (llt.info() != Eigen::Success) return false;
  S = llt.matrixL().solve(Eigen::Matrix<double, N, N>::Identity());
  return S.allFinite();
}

double tukeySqrtWeight(double u, double c) {
  if (!(u < c)) return 0.0;
  const double a = 1.0 - (u / c) * (u / c);
  return a;  // sqrt of (1 - (u/c)^2)^2
}

// ---------------------------------------------------------------------------------------------

/// A prior on the pose, as six whitened rows S (xi - mean), S^T S = covariance^-1.
struct PriorTerm {
  Vector6d mean = Vector6d::Zero();
  Matrix6d S = Matrix6d::Identity();
  Matrix6d information = Matrix6d::Identity();
};

std::optional<PriorTerm> makePriorTerm(const std::optional<MotionPrior>& prior) {
  if (!prior || !isValidPose(prior->T_curr_prev, 1e-6) || !prior->covariance.allFinite()) {
    return std::nullopt;
  }
  PriorTerm term;
  if (!whitening<6>(0.5 * (prior->covariance + prior->covariance.transpose()), true, term.S)) {
    return std::nullopt;
  }
  term.mean = poseToXi(prior->T_curr_prev);
  term.information = term.S.transpose() * term.S;
  return term;
}

class JointProblem {
 public:
  JointProblem(const PoseEstimatorOptions& o, const PinholeCamera& camera)
      : o_(o), cam_{camera.fx, camera.fy, camera.cx, camera.cy, o.min_depth_m} {}

  std::vector<PointTerm> points;
  std::vector<LineTerm> lines;
  std::vector<PlaneTerm> planes;
  /// Not a measurement: left out of the robust scales, the Tukey weights and the row count.
  std::optional<PriorTerm> prior;
  /// Set by reweight: the planes' residual scale k (1: Sigma_r right) and their weight
  /// min(alpha, 1/k) in the cost and the information.
  double plane_scale = 1.0;
  double plane_weight = 0.0;
  /// Set by reweight: the point and line terms' weight in the cost and the information, and
  /// the factor their residuals' covariance exceeds the modelled Sigma_r by (robust scale^2).
  double point_weight = 1.0, line_weight = 1.0;
  double point_var_scale = 1.0, line_var_scale = 1.0;
  /// Set by reweight: the same factors as measured, below 1 too (the planes' k and the point
  /// and line spreads unclamped), for the covariance at the measured spread.
  double plane_spread = 1.0, point_spread_var = 1.0, line_spread_var = 1.0;

  struct ReweightResult {
    int rows = 0;  // rows with non-zero weight
    int n_points = 0, n_lines = 0, n_planes = 0;
    double scale = 1.0;
    double point_scale = 1.0, line_scale = 1.0;  // the Tukey scales of each family
  };

  /// Recomputes Sigma_r, the whitening and the Tukey weights at pose xi (IRLS step).
  ReweightResult reweight(const double* xi) {
    ReweightResult out;
    const PoseEval pose(xi);
    if (!pose.valid) return out;
    std::vector<double> abs_w, abs_p, abs_l;
    abs_w.reserve(2 * (points.size() + lines.size()));
    std::vector<double> norm_p(points.size(), 0.0), norm_l(lines.size(), 0.0);
    for (size_t i = 0; i < points.size(); ++i) {
      PointTerm& T = points[i];
      Eigen::Vector2d r;
      Eigen::Matrix2d Sig;
      T.active = pointResidual(T, pose, cam_, r, nullptr, &Sig) &&
                 whitening<2>(Sig, o_.full_whitening, T.S);
      if (!T.active) continue;
      const Eigen::Vector2d rw = T.S * r;
      abs_w.push_back(std::abs(rw(0)));
      abs_w.push_back(std::abs(rw(1)));
      norm_p[i] = rw.norm();
    }
    for (size_t i = 0; i < lines.size(); ++i) {
      LineTerm& T = lines[i];
      Eigen::Vector2d r, var;
      T.active = lineResidual(T, pose, cam_, r, nullptr, &var) && var.allFinite() && var(0) > 0 &&
                 var(1) > 0;
      if (!T.active) continue;
      T.s[0] = 1.0 / std::sqrt(var(0));
      T.s[1] = 1.0 / std::sqrt(var(1));
      const Eigen::Vector2d rw(T.s[0] * r(0), T.s[1] * r(1));
      abs_w.push_back(std::abs(rw(0)));
      abs_w.push_back(std::abs(rw(1)));
      norm_l[i] = rw.norm();
    }
    std::vector<double> plane_chi2;
    plane_chi2.reserve(planes.size());
    for (PlaneTerm& T : planes) {
      Eigen::Vector3d r;
      Eigen::Matrix3d Sig;
      planeResidual(T, pose, r, nullptr, &Sig);
      T.active = whitening<3>(Sig, o_.full_whitening, T.S);
      if (!T.active) continue;
      plane_chi2.push_back((T.S * r).squaredNorm());
      out.rows += 3;
      ++out.n_planes;
    }
    plane_scale = plane_spread = 1.0;
    if (o_.plane_weight_from_residuals && !plane_chi2.empty()) {
      auto mid = plane_chi2.begin() + plane_chi2.size() / 2;
      std::nth_element(plane_chi2.begin(), mid, plane_chi2.end());
      constexpr double kChi2Dof3Median = 2.366;
      if (std::isfinite(*mid)) {
        plane_spread = *mid / kChi2Dof3Median;
        plane_scale = std::max(1.0, plane_spread);
      }
    }
    plane_weight = o_.plane_weight_from_residuals ? std::min(o_.plane_scale_alpha, 1.0 / plane_scale)
                                                  : o_.plane_scale_alpha;
    const size_t n_point_values = 2 * static_cast<size_t>(std::count_if(
                                      points.begin(), points.end(),
                                      [](const PointTerm& T) { return T.active; }));
    abs_p.assign(abs_w.begin(), abs_w.begin() + n_point_values);
    abs_l.assign(abs_w.begin() + n_point_values, abs_w.end());
    auto spread = [](std::vector<double>& v) {
      auto mid = v.begin() + v.size() / 2;
      std::nth_element(v.begin(), mid, v.end());
      return 1.4826 * *mid;
    };
    double pooled_spread = 1.0;
    if (o_.tukey_mad_scale && !abs_w.empty()) {
      pooled_spread = spread(abs_w);
      out.scale = std::max(1.0, pooled_spread);
    }
    out.point_scale = out.line_scale = out.scale;
    double point_spread = pooled_spread, line_spread = pooled_spread;
    point_weight = line_weight = 1.0;
    if (o_.tukey_mad_scale && o_.family_robust_scales) {
      // Each family's own spread: a family whose residuals exceed their model by s_f more than
      // the other's weighs (s_min / s_f)^2; too few values to tell fall back to the pooled
      // scale.
      constexpr size_t kMinValues = 20;
      if (abs_p.size() >= kMinValues) {
        point_spread = spread(abs_p);
        out.point_scale = std::max(1.0, point_spread);
      }
      if (abs_l.size() >= kMinValues) {
        line_spread = spread(abs_l);
        out.line_scale = std::max(1.0, line_spread);
      }
      // Relative to the more precise family, which keeps weight 1: far from the solution the
      // scales measure the misfit of every family, and weighing all of them down would hand
      // the pose to the planes.
      const double best = std::min(out.point_scale, out.line_scale);
      point_weight = (best * best) / (out.point_scale * out.point_scale);
      line_weight = (best * best) / (out.line_scale * out.line_scale);
    }
    point_var_scale = o_.tukey_mad_scale ? out.point_scale * out.point_scale : 1.0;
    line_var_scale = o_.tukey_mad_scale ? out.line_scale * out.line_scale : 1.0;
    point_spread_var = o_.tukey_mad_scale ? point_spread * point_spread : 1.0;
    line_spread_var = o_.tukey_mad_scale ? line_spread * line_spread : 1.0;
    for (size_t i = 0; i < points.size(); ++i) {
      PointTerm& T = points[i];
      if (!T.active) continue;
      T.sqrt_tukey =
          o_.use_tukey ? tukeySqrtWeight(norm_p[i] / out.point_scale, o_.tukey_c) : 1.0;
      if (T.sqrt_tukey > 0) {
        out.rows += 2;
        ++out.n_points;
      }
    }
    for (size_t i = 0; i < lines.size(); ++i) {
      LineTerm& T = lines[i];
      if (!T.active) continue;
      T.sqrt_tukey =
          o_.use_tukey ? tukeySqrtWeight(norm_l[i] / out.line_scale, o_.tukey_c) : 1.0;
      if (T.sqrt_tukey > 0) {
        out.rows += 2;
        ++out.n_lines;
      }
    }
    return out;
  }

  /// Weighted residuals (rows of the terms with non-zero weight, fixed order) and their
  /// row-major Jacobian (rows x 6). Returns false if a term leaves the valid domain.
  bool evaluate(const double* xi, double* residuals, double* jacobian) const {
    const PoseEval pose(xi);
    if (!pose.valid) return false;
    int row = 0;
    Eigen::Vector2d r;
    Matrix26 J2;
    Matrix26* pJ2 = jacobian ? &J2 : nullptr;
    using RowJac = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>>;
    for (const PointTerm& T : points) {
      if (!T.active || T.sqrt_tukey <= 0) continue;
      if (!pointResidual(T, pose, cam_, r, pJ2, nullptr)) return false;
      const Eigen::Matrix2d W = (T.sqrt_tukey * std::sqrt(point_weight)) * T.S;
      Eigen::Map<Eigen::Vector2d>(residuals + row) = W * r;
      if (jacobian) RowJac(jacobian + 6 * row, 2, 6) = W * J2;
      row += 2;
    }
    for (const LineTerm& T : lines) {
      if (!T.active || T.sqrt_tukey <= 0) continue;
      if (!lineResidual(T, pose, cam_, r, pJ2, nullptr)) return false;
      const double sw = T.sqrt_tukey * std::sqrt(line_weight);
      const Eigen::Vector2d w(sw * T.s[0], sw * T.s[1]);
      Eigen::Map<Eigen::Vector2d>(residuals + row) = w.cwiseProduct(r);
      if (jacobian) RowJac(jacobian + 6 * row, 2, 6) = w.asDiagonal() * J2;
      row += 2;
    }
    Eigen::Vector3d r3;
    Matrix36 J3;
    const double sqrt_alpha = std::sqrt(plane_weight);
    for (const PlaneTerm& T : planes) {
      if (!T.active) continue;
      planeResidual(T, pose, r3, jacobian ? &J3 : nullptr, nullptr);
      const Eigen::Matrix3d W = sqrt_alpha * T.S;
      Eigen::Map<Eigen::Vector3d>(residuals + row) = W * r3;
      if (jacobian) RowJac(jacobian + 6 * row, 3, 6) = W * J3;
      row += 3;
    }
    return Eigen::Map<const Eigen::VectorXd>(residuals, row).allFinite();
  }

  /// H = J^T W J at xi over the inlier terms with the inverse-variance weights and alpha on
  /// the planes (Tukey weights only select the inliers): the information of eq. 23. M is the
  /// same sum with alpha^2, for the sandwich covariance H^-1 M H^-1; the point and line terms
  /// weigh point_weight / line_weight in both, and count their variance scale in M: their
  /// residuals' actual covariance is that factor times the modelled Sigma_r (the robust
  /// scale squared; docs/estimator.md, "The published covariance: what it contains").
  /// `H_planes` receives the planes' part of H, `M_spread` M with each family's variance
  /// factor as measured, below 1 too.
  void information(const double* xi, Matrix6d& H, Matrix6d& M, Matrix6d& H_planes,
                   Matrix6d& M_spread) const {
    const PoseEval pose(xi);
    H.setZero();
    M.setZero();
    H_planes.setZero();
    M_spread.setZero();
    if (!pose.valid) return;
    Eigen::Vector2d r;
    Matrix26 J2;
    for (const PointTerm& T : points) {
      if (!T.active || T.sqrt_tukey <= 0) continue;
      if (!pointResidual(T, pose, cam_, r, &J2, nullptr)) continue;
      const Matrix26 A = T.S * J2;
      const Matrix6d AtA = A.transpose() * A;
      H += point_weight * AtA;
      const double c = point_weight * point_weight * point_var_scale;
      M += c * AtA;
      M_spread += point_weight * point_weight * point_spread_var * AtA;
    }
    for (const LineTerm& T : lines) {
      if (!T.active || T.sqrt_tukey <= 0) continue;
      if (!lineResidual(T, pose, cam_, r, &J2, nullptr)) continue;
      const Matrix26 A = Eigen::Vector2d(T.s[0], T.s[1]).asDiagonal() * J2;
      const Matrix6d AtA = A.transpose() * A;
      H += line_weight * AtA;
      M += line_weight * line_weight * line_var_scale * AtA;
      M_spread += line_weight * line_weight * line_spread_var * AtA;
    }
    Eigen::Vector3d r3;
    Matrix36 J3;
    for (const PlaneTerm& T : planes) {
      if (!T.active) continue;
      planeResidual(T, pose, r3, &J3, nullptr);
      const Matrix36 A = T.S * J3;
      const Matrix6d AtA = A.transpose() * A;
      H.noalias() += plane_weight * AtA;
      H_planes.noalias() += plane_weight * AtA;
      M.noalias() += plane_weight * plane_weight * plane_scale * AtA;
      M_spread.noalias() += plane_weight * plane_weight * plane_spread * AtA;
    }
    if (prior) {  // weighted by its own covariance, so it enters M as it does H
      H += prior->information;
      M += prior->information;
      M_spread += prior->information;
    }
    H = 0.5 * (H + H.transpose());
    M = 0.5 * (M + M.transpose());
    M_spread = 0.5 * (M_spread + M_spread.transpose());
  }

 private:
  const PoseEstimatorOptions& o_;
  Projector cam_;
};

class JointCost : public ceres::CostFunction {
 public:
  JointCost(const JointProblem& problem, int rows) : problem_(problem) {
    set_num_residuals(rows);
    mutable_parameter_block_sizes()->push_back(6);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    return problem_.evaluate(parameters[0], residuals, jacobians ? jacobians[0] : nullptr);
  }

 private:
  const JointProblem& problem_;
};

class PriorCost : public ceres::SizedCostFunction<6, 6> {
 public:
  explicit PriorCost(const PriorTerm& prior) : prior_(prior) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Vector6d> xi(parameters[0]);
    Eigen::Map<Vector6d> r(residuals);
    r = prior_.S * (xi - prior_.mean);
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>> J(jacobians[0]);
      J = prior_.S;
    }
    return true;
  }

 private:
  const PriorTerm& prior_;
};

bool poseChangeSmall(const Vector6d& a, const Vector6d& b, const PoseEstimatorOptions& o) {
  return (a.head<3>() - b.head<3>()).norm() < o.irls_tolerance_m &&
         2.0 * (a.tail<3>() - b.tail<3>()).norm() < o.irls_tolerance_rad;
}

// --- validation: each correspondence becomes a term or a counted skip -----------------------

void addPointTerms(const std::vector<PointMatch3D2D>& matches, JointProblem& problem,
                   CorrespondenceStats& sk) {
  problem.points.reserve(matches.size());
  for (const PointMatch3D2D& m : matches) {
    if (!m.P_prev.p.allFinite() || !m.P_prev.cov.allFinite() || !m.px_curr.allFinite() ||
        !std::isfinite(m.sigma_px)) {
      ++sk.non_finite;
      continue;
    }
    if (!isPsd<3>(m.P_prev.cov) || !(m.sigma_px > 0)) {
      ++sk.bad_covariance;
      continue;
    }
    PointTerm T;
    T.P = m.P_prev.p;
    T.cov = m.P_prev.cov;
    T.px = m.px_curr;
    T.var_px2 = m.sigma_px * m.sigma_px;
    problem.points.push_back(T);
  }
}

void addLineTerms(const std::vector<LineMatch3D2D>& matches, JointProblem& problem,
                  CorrespondenceStats& sk) {
  for (const LineMatch3D2D& m : matches) {
    const Line3WithCov& L = m.L_prev;
    if (!L.p1.allFinite() || !L.p2.allFinite() || !L.cov1.allFinite() || !L.cov2.allFinite() ||
        !m.l_curr.allFinite() || !std::isfinite(m.sigma_px)) {
      ++sk.non_finite;
      continue;
    }
    if (!isPsd<3>(L.cov1) || !isPsd<3>(L.cov2) || !(m.sigma_px > 0)) {
      ++sk.bad_covariance;
      continue;
    }
    const double ab = m.l_curr.head<2>().norm();
    if (!(ab > 1e-12) || (L.p1 - L.p2).norm() < 1e-9) {
      ++sk.bad_geometry;
      continue;
    }
    LineTerm T;
    T.P[0] = L.p1;
    T.P[1] = L.p2;
    T.cov[0] = L.cov1;
    T.cov[1] = L.cov2;
    T.l = m.l_curr / ab;
    T.var_px2 = m.sigma_px * m.sigma_px;
    problem.lines.push_back(T);
  }
}

void addPlaneTerms(const std::vector<PlaneMatch3D3D>& matches, JointProblem& problem,
                   CorrespondenceStats& sk) {
  for (const PlaneMatch3D3D& m : matches) {
    if (!m.prev.hessian.allFinite() || !m.curr.hessian.allFinite() || !m.prev.cov.allFinite() ||
        !m.curr.cov.allFinite()) {
      ++sk.non_finite;
      continue;
    }
    if (!isPsd<4>(m.prev.cov) || !isPsd<4>(m.curr.cov)) {
      ++sk.bad_covariance;
      continue;
    }
    const double n0 = m.prev.normal().norm(), n1 = m.curr.normal().norm();
    if (std::abs(n0 - 1.0) > 1e-3 || std::abs(n1 - 1.0) > 1e-3) {
      ++sk.bad_geometry;
      continue;
    }
    PlaneTerm T;
    T.prev = m.prev.hessian;
    T.prev.head<3>() /= n0;
    T.curr = m.curr.hessian;
    T.curr.head<3>() /= n1;
    T.cov_prev = m.prev.cov;
    T.cov_curr = m.curr.cov;
    problem.planes.push_back(T);
  }
}

// --- IRLS around Ceres LM -------------------------------------------------------------------

/// Where the IRLS ended: the last weights, and whether a solve failed (xi is then the pose
/// before that solve).
struct IrlsResult {
  JointProblem::ReweightResult rw;
  bool solver_failed = false;
};

/// Alternates Tukey reweighting and a Ceres LM solve from `xi` until the pose stops changing,
/// too few residuals remain, or a solve fails; counts iterations and costs into `est`.
IrlsResult solveIrls(JointProblem& problem, const PoseEstimatorOptions& o, Vector6d& xi,
                     PoseEstimate& est) {
  IrlsResult out;
  JointProblem::ReweightResult& rw = out.rw;
  rw = problem.reweight(xi.data());
  est.robust_scale = rw.scale;
  est.point_scale = rw.point_scale;
  est.line_scale = rw.line_scale;
  est.plane_scale = problem.plane_scale;
  est.plane_weight = problem.plane_weight;
  for (int it = 0; it < o.max_irls_iterations; ++it) {
    if (rw.rows < kMinRowsToSolve) break;
    const Vector6d xi_before = xi;
    JointCost cost(problem, rw.rows);
    std::optional<PriorCost> prior_cost;
    if (problem.prior) prior_cost.emplace(*problem.prior);
    ceres::Problem::Options popts;
    popts.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem cp(popts);
    cp.AddResidualBlock(&cost, nullptr, xi.data());
    if (prior_cost) cp.AddResidualBlock(&*prior_cost, nullptr, xi.data());
    ceres::Solver::Options sopts;
    sopts.minimizer_type = ceres::TRUST_REGION;
    sopts.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    sopts.linear_solver_type = ceres::DENSE_QR;
    sopts.max_num_iterations = o.max_lm_iterations;
    sopts.num_threads = 1;
    sopts.logging_type = ceres::SILENT;
    sopts.minimizer_progress_to_stdout = false;
    sopts.function_tolerance = 1e-10;
    sopts.parameter_tolerance = 1e-10;
    ceres::Solver::Summary summary;
    ceres::Solve(sopts, &cp, &summary);
    ++est.irls_iterations;
    est.lm_iterations += summary.num_successful_steps + summary.num_unsuccessful_steps;
    if (it == 0) est.initial_cost = summary.initial_cost;
    est.final_cost = summary.final_cost;
    if (summary.termination_type == ceres::FAILURE || !xi.allFinite() ||
        !(xi.tail<3>().squaredNorm() < 1.0)) {
      xi = xi_before;
      out.solver_failed = true;
      break;
    }
    xi = poseToXi(xiToPose(xi));  // keep q_w >= 0
    rw = problem.reweight(xi.data());
    est.robust_scale = rw.scale;
    est.point_scale = rw.point_scale;
    est.line_scale = rw.line_scale;
    est.plane_scale = problem.plane_scale;
    est.plane_weight = problem.plane_weight;
    if (it > 0 && poseChangeSmall(xi, xi_before, o)) break;
  }
  return out;
}

// --- covariance (eq. 23) --------------------------------------------------------------------

/// The pose covariance at `xi` into `est` (covariance, its largest translation and rotation
/// variances, the smallest relative eigenvalue of the Jacobi-scaled information).
void estimateCovariance(const JointProblem& problem, const Vector6d& xi,
                        const PoseEstimatorOptions& o, PoseEstimate& est) {
  Matrix6d H, M, H_planes, M_spread;
  // The whitened point and line residuals spread by the robust scale s (>= 1, MAD): their
  // covariance is s^2 Sigma_r, not Sigma_r (on real images s ~ 1.5; 1 on synthetic ones).
  // (With family_robust_scales each family has its own s and weighs 1/s^2.)
  problem.information(xi.data(), H, M, H_planes, M_spread);
  Eigen::Matrix<double, 6, 1> dinv_sqrt;
  bool diag_ok = H.allFinite() && M.allFinite();
  for (int i = 0; i < 6; ++i) {
    if (!(H(i, i) > 1e-300)) diag_ok = false;
    dinv_sqrt(i) = H(i, i) > 1e-300 ? 1.0 / std::sqrt(H(i, i)) : 1.0;
  }
  if (H.allFinite() && M.allFinite()) {
    // Jacobi-scaled eigen-decomposition: pseudo-inverse on the observable subspace,
    // kLargeVariance on the unobservable directions.
    const Matrix6d Hs = dinv_sqrt.asDiagonal() * H * dinv_sqrt.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Matrix6d> es(Hs);
    const auto& lam = es.eigenvalues();
    const double lmax = lam.maxCoeff();
    est.min_relative_eigenvalue = diag_ok && lmax > 0 ? std::max(0.0, lam.minCoeff() / lmax) : 0.0;
    Matrix6d Hinv = Matrix6d::Zero(), null_part = Matrix6d::Zero();
    for (int k = 0; k < 6; ++k) {
      const Vector6d y = dinv_sqrt.asDiagonal() * es.eigenvectors().col(k);
      if (diag_ok && lmax > 0 && lam(k) / lmax >= o.min_relative_eigenvalue) {
        Hinv.noalias() += y * y.transpose() / lam(k);
      } else {
        null_part.noalias() += kLargeVariance * y.normalized() * y.normalized().transpose();
      }
    }
    const Matrix6d cov = (o.covariance_sandwich ? Matrix6d(Hinv * M * Hinv) : Hinv) + null_part;
    if (cov.allFinite()) est.covariance = 0.5 * (cov + cov.transpose());
    const Matrix6d cov_spread =
        (o.covariance_sandwich ? Matrix6d(Hinv * M_spread * Hinv) : Hinv) + null_part;
    // Published only when positive definite: residuals that all vanish (fabricated exact
    // matches) measure no spread, and a zero covariance would claim an exact pose.
    const Matrix6d cov_spread_sym = 0.5 * (cov_spread + cov_spread.transpose());
    if (cov.allFinite() && cov_spread_sym.allFinite() &&
        Eigen::LLT<Matrix6d>(cov_spread_sym).info() == Eigen::Success) {
      est.covariance_at_measured_spread = cov_spread_sym;
    }
    // The current frame's depth enters only through its planes (points and lines are
    // reprojected into its image): a rigid error e of that depth moves them as a pose change
    // would, and the solve by H^-1 H_planes e.
    const Matrix6d sensitivity = Hinv * H_planes;
    if (sensitivity.allFinite()) est.current_depth_sensitivity = sensitivity;
  }
  est.max_translation_variance_m2 = maxTranslationVariance(est.covariance);
  est.max_rotation_variance = maxRotationVariance(est.covariance);
}

// --- rejection tests ------------------------------------------------------------------------

EstimateStatus classify(const PoseEstimate& est, bool solver_failed, int rows,
                        const PoseEstimatorOptions& o) {
  if (solver_failed || !est.T_curr_prev.matrix().allFinite()) return EstimateStatus::kSolverFailure;
  if (rows < kMinRowsToSolve) return EstimateStatus::kTooFewConstraints;
  if (est.min_relative_eigenvalue < o.min_relative_eigenvalue) return EstimateStatus::kDegenerate;
  // Solved, but weak: too few rows for the robust scale and the Tukey weights to catch a wrong
  // match (no redundancy to check the solution against), or weak geometry (collinear points,
  // near-parallel planes). Such an estimate may still be combined with a prediction.
  if (rows < o.min_residuals ||
      !(maxTranslationVariance(est.covariance) <= o.max_translation_variance_m2) ||
      !(maxRotationVariance(est.covariance) <= o.max_rotation_variance)) {
    return EstimateStatus::kUncertain;
  }
  return EstimateStatus::kOk;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

Correspondences buildCorrespondences(const FrameFeatures& prev, const FrameFeatures& curr,
                                     const FeatureMatches& matches, const PoseEstimatorOptions& o) {
  Correspondences out;
  auto inRange = [](int i, size_t n) { return i >= 0 && static_cast<size_t>(i) < n; };
  out.points.reserve(matches.points.size());
  for (const auto& [ip, ic] : matches.points) {
    if (!inRange(ip, prev.points.size()) || !inRange(ic, curr.points.size())) {
      ++out.skipped.bad_index;
      continue;
    }
    const PointFeature& fp = prev.points[ip];
    const PointFeature& fc = curr.points[ic];
    if (!fp.has_3d) {
      ++out.skipped.no_3d;
      continue;
    }
    PointMatch3D2D m;
    m.P_prev = fp.point;
    m.px_curr = fc.px;
    m.sigma_px = o.point_sigma_px * std::pow(o.octave_sigma_scale, std::max(0, fc.octave));
    out.points.push_back(m);
  }
  for (const auto& [ip, ic] : matches.lines) {
    if (!inRange(ip, prev.lines.size()) || !inRange(ic, curr.lines.size())) {
      ++out.skipped.bad_index;
      continue;
    }
    if (!prev.lines[ip].has_3d) {
      ++out.skipped.no_3d;
      continue;
    }
    LineMatch3D2D m;
    m.L_prev = prev.lines[ip].line;
    m.l_curr = curr.lines[ic].eq;
    m.sigma_px = o.line_sigma_px;
    out.lines.push_back(m);
  }
  for (const auto& [ip, ic] : matches.planes) {
    if (!inRange(ip, prev.planes.size()) || !inRange(ic, curr.planes.size())) {
      ++out.skipped.bad_index;
      continue;
    }
    out.planes.push_back({prev.planes[ip].plane, curr.planes[ic].plane});
  }
  return out;
}

PoseEstimator::PoseEstimator(PoseEstimatorOptions options) : options_(std::move(options)) {}

PoseEstimate PoseEstimator::estimate(const FrameFeatures& prev, const FrameFeatures& curr,
                                     const FeatureMatches& matches,
                                     const Pose3& T_curr_prev_guess) const {
  return estimate(buildCorrespondences(prev, curr, matches, options_), curr.camera,
                  T_curr_prev_guess);
}

PoseEstimate PoseEstimator::estimate(const Correspondences& in, const PinholeCamera& camera,
                                     const Pose3& T_curr_prev_guess,
                                     const std::optional<MotionPrior>& prior) const {
  const PoseEstimatorOptions& o = options_;
  PoseEstimate est;
  est.skipped = in.skipped;
  est.covariance = kLargeVariance * Matrix6d::Identity();
  est.max_translation_variance_m2 = kLargeVariance;
  est.max_rotation_variance = kLargeVariance;
  const Pose3 guess = isValidPose(T_curr_prev_guess, 1e-4) ? T_curr_prev_guess : Pose3::Identity();
  est.T_curr_prev = xiToPose(poseToXi(guess));
  const bool camera_ok = std::isfinite(camera.fx) && std::isfinite(camera.fy) &&
                         std::isfinite(camera.cx) && std::isfinite(camera.cy) && camera.fx != 0 &&
                         camera.fy != 0;

  // Validation: bad correspondences are counted in est.skipped, never used.
  JointProblem problem(o, camera);
  problem.prior = makePriorTerm(prior);
  if (o.use_points && camera_ok) addPointTerms(in.points, problem, est.skipped);
  if (o.use_lines && camera_ok) addLineTerms(in.lines, problem, est.skipped);
  if (o.use_planes && o.plane_scale_alpha > 0) addPlaneTerms(in.planes, problem, est.skipped);
  est.n_points_in = static_cast<int>(problem.points.size());
  est.n_lines_in = static_cast<int>(problem.lines.size());
  est.n_planes_in = static_cast<int>(problem.planes.size());
  if (est.n_points_in + est.n_lines_in + est.n_planes_in == 0) {
    est.status = EstimateStatus::kNoConstraints;
    return est;
  }

  // The pose: IRLS around Ceres LM from the guess.
  Vector6d xi = poseToXi(est.T_curr_prev);
  const IrlsResult irls = solveIrls(problem, o, xi, est);
  const JointProblem::ReweightResult& rw = irls.rw;
  est.T_curr_prev = xiToPose(xi);
  est.n_points_used = rw.n_points;
  est.n_lines_used = rw.n_lines;
  est.n_planes_used = rw.n_planes;
  est.n_residuals = rw.rows;

  // Its covariance (eq. 23), then the rejection tests; a failed solve returns the guess.
  estimateCovariance(problem, xi, o, est);
  est.status = classify(est, irls.solver_failed, rw.rows, o);
  if (est.status == EstimateStatus::kSolverFailure) est.T_curr_prev = xiToPose(poseToXi(guess));
  return est;
}

}  // namespace pplvo::estimator
