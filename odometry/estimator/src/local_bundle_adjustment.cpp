#include "pplvo/estimator/local_bundle_adjustment.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "pplvo/estimator/pose_parameterisation.h"

namespace pplvo::estimator {

namespace {

/// One keyframe's observation of one landmark; parameters: q_w_kf (Eigen order x y z w),
/// t_w_kf, X_w.
struct PointObservationCost {
  PointObservationCost(const Eigen::Vector3d& measured, const Eigen::Matrix3d& whitening)
      : p_kf(measured), S(whitening) {}

  template <class T>
  bool operator()(const T* q_w_kf, const T* t_w_kf, const T* X_w, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_w_kf);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(t_w_kf), X(X_w);
    const Eigen::Matrix<T, 3, 1> in_kf = q.conjugate() * (X - t);
    const Eigen::Matrix<T, 3, 1> d = in_kf - p_kf.cast<T>();
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = S.cast<T>() * d;
    return true;
  }

  Eigen::Vector3d p_kf;
  Eigen::Matrix3d S;  ///< L^-1, L L^T = Sigma_kf
};

/// A keyframe's pixel of a landmark (its depth left out): the reprojection error / sigma.
struct PixelObservationCost {
  PixelObservationCost(const Eigen::Vector2d& pixel, double sigma, const PinholeCamera& c)
      : px(pixel), inv_sigma(1.0 / sigma), fx(c.fx), fy(c.fy), cx(c.cx), cy(c.cy) {}

  template <class T>
  bool operator()(const T* q_w_kf, const T* t_w_kf, const T* X_w, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_w_kf);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(t_w_kf), X(X_w);
    const Eigen::Matrix<T, 3, 1> c = q.conjugate() * (X - t);
    if (!(c.z() > T(1e-6))) return false;
    residual[0] = (T(fx) * c.x() / c.z() + T(cx) - T(px.x())) * T(inv_sigma);
    residual[1] = (T(fy) * c.y() / c.z() + T(cy) - T(px.y())) * T(inv_sigma);
    return true;
  }

  Eigen::Vector2d px;
  double inv_sigma, fx, fy, cx, cy;
};

/// A measured relative pose: S (xi(T_to_w T_w_from) - xi_measured), q_w >= 0 as in poseToXi.
struct RelativePoseCost {
  RelativePoseCost(const Vector6d& measured, const Matrix6d& whitening)
      : xi(measured), S(whitening) {}

  template <class T>
  bool operator()(const T* q_w_from, const T* t_w_from, const T* q_w_to, const T* t_w_to,
                  T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> qa(q_w_from), qb(q_w_to);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> ta(t_w_from), tb(t_w_to);
    const Eigen::Quaternion<T> q = qb.conjugate() * qa;
    const Eigen::Matrix<T, 3, 1> t = qb.conjugate() * (ta - tb);
    const T sign = q.w() < T(0) ? T(-1) : T(1);
    Eigen::Matrix<T, 6, 1> d;
    d << t, sign * q.x(), sign * q.y(), sign * q.z();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = S.cast<T>() * (d - xi.cast<T>());
    return true;
  }

  Vector6d xi;
  Matrix6d S;
};

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

bool whiteningOf(const Eigen::Matrix3d& cov, Eigen::Matrix3d* S) {
  if (!cov.allFinite()) return false;
  const Eigen::LLT<Eigen::Matrix3d> llt(cov);
  if (llt.info() != Eigen::Success) return false;
  *S = llt.matrixL().solve(Eigen::Matrix3d::Identity());
  return S->allFinite();
}

}  // namespace

BundleResult adjustLocalBundle(const BundleProblem& problem, const BundleOptions& options) {
  BundleResult out;
  const int n_kf = static_cast<int>(problem.keyframes.size());
  const int n_lm = static_cast<int>(problem.landmarks_w.size());
  out.inlier.assign(problem.observations.size(), false);
  for (const BundleKeyframe& kf : problem.keyframes) out.T_w_kf.push_back(kf.T_w_kf);
  out.landmarks_w = problem.landmarks_w;

  std::vector<Eigen::Quaterniond> q(n_kf);
  std::vector<Eigen::Vector3d> t(n_kf);
  bool any_fixed = false, any_free = false;
  for (int k = 0; k < n_kf; ++k) {
    q[k] = Eigen::Quaterniond(problem.keyframes[k].T_w_kf.linear()).normalized();
    t[k] = problem.keyframes[k].T_w_kf.translation();
    (problem.keyframes[k].fixed ? any_fixed : any_free) = true;
  }
  if (!any_fixed) return out;  // no gauge: the window would float

  ceres::EigenQuaternionManifold quaternion;  // outlives cp, shared by every pose
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem cp(po);
  std::vector<bool> pose_added(n_kf, false);
  std::vector<bool> valid(problem.observations.size(), false);
  const double huber = std::sqrt(options.outlier_chi2);
  const double huber_2d = std::sqrt(options.outlier_chi2_2d);
  for (size_t i = 0; i < problem.observations.size(); ++i) {
    const BundleObservation& o = problem.observations[i];
    if (o.keyframe < 0 || o.keyframe >= n_kf || o.landmark < 0 || o.landmark >= n_lm) continue;
    Eigen::Matrix3d S;
    if (!o.p_kf.allFinite() || !out.landmarks_w[o.landmark].allFinite() ||
        !whiteningOf(o.cov_kf, &S)) {
      continue;
    }
    ceres::CostFunction* cost = nullptr;
    if (o.use_depth) {
      cost = new ceres::AutoDiffCostFunction<PointObservationCost, 3, 4, 3, 3>(
          new PointObservationCost(o.p_kf, S));
    } else {
      if (!(o.sigma_px > 0) || !(o.p_kf.z() > 0)) continue;
      cost = new ceres::AutoDiffCostFunction<PixelObservationCost, 2, 4, 3, 3>(
          new PixelObservationCost(problem.camera.project(o.p_kf), o.sigma_px, problem.camera));
    }
    valid[i] = true;
    cp.AddResidualBlock(cost, new ceres::HuberLoss(o.use_depth ? huber : huber_2d), q[o.keyframe].coeffs().data(),
                        t[o.keyframe].data(), out.landmarks_w[o.landmark].data());
    if (!pose_added[o.keyframe]) {
      pose_added[o.keyframe] = true;
      cp.SetManifold(q[o.keyframe].coeffs().data(), &quaternion);
      if (problem.keyframes[o.keyframe].fixed) {
        cp.SetParameterBlockConstant(q[o.keyframe].coeffs().data());
        cp.SetParameterBlockConstant(t[o.keyframe].data());
      }
    }
  }
  for (const BundleRelativePose& rel : problem.relative_poses) {
    if (rel.from < 0 || rel.from >= n_kf || rel.to < 0 || rel.to >= n_kf || rel.from == rel.to ||
        !rel.covariance.allFinite() || !rel.T_to_from.matrix().allFinite()) {
      continue;
    }
    const Eigen::LLT<Matrix6d> llt(rel.covariance);
    if (llt.info() != Eigen::Success) continue;
    const Matrix6d S = llt.matrixL().solve(Matrix6d::Identity());
    if (!S.allFinite()) continue;
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 4, 3, 4, 3>(
        new RelativePoseCost(poseToXi(rel.T_to_from), S));
    cp.AddResidualBlock(cost, nullptr, q[rel.from].coeffs().data(), t[rel.from].data(),
                        q[rel.to].coeffs().data(), t[rel.to].data());
    for (const int k : {rel.from, rel.to}) {
      if (pose_added[k]) continue;
      pose_added[k] = true;
      cp.SetManifold(q[k].coeffs().data(), &quaternion);
      if (problem.keyframes[k].fixed) {
        cp.SetParameterBlockConstant(q[k].coeffs().data());
        cp.SetParameterBlockConstant(t[k].data());
      }
    }
  }
  if (!any_free || cp.NumResidualBlocks() == 0) return out;

  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = 1;  // deterministic, and the pose loop owns one core
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &cp, &summary);
  if (summary.termination_type == ceres::FAILURE) {
    out.landmarks_w = problem.landmarks_w;
    return out;
  }
  for (int k = 0; k < n_kf; ++k) {
    if (!q[k].coeffs().allFinite() || !t[k].allFinite()) {
      out.landmarks_w = problem.landmarks_w;
      out.T_w_kf.clear();
      for (const BundleKeyframe& kf : problem.keyframes) out.T_w_kf.push_back(kf.T_w_kf);
      return out;
    }
    Pose3 T = Pose3::Identity();
    T.linear() = q[k].normalized().toRotationMatrix();
    T.translation() = t[k];
    out.T_w_kf[k] = T;
  }
  out.chi2.assign(problem.observations.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<double> chi2_depth, chi2_pixel;
  for (size_t i = 0; i < problem.observations.size(); ++i) {
    if (!valid[i]) continue;
    const BundleObservation& o = problem.observations[i];
    const Eigen::Vector3d c = out.T_w_kf[o.keyframe].inverse() * out.landmarks_w[o.landmark];
    if (o.use_depth) {
      Eigen::Matrix3d S;
      whiteningOf(o.cov_kf, &S);
      out.chi2[i] = (S * (c - o.p_kf)).squaredNorm();
      out.inlier[i] = out.chi2[i] < options.outlier_chi2;
      chi2_depth.push_back(out.chi2[i]);
    } else {
      const Eigen::Vector2d e =
          (problem.camera.project(c) - problem.camera.project(o.p_kf)) / o.sigma_px;
      out.chi2[i] = e.squaredNorm();
      out.inlier[i] = c.z() > 0 && out.chi2[i] < options.outlier_chi2_2d;
      chi2_pixel.push_back(out.chi2[i]);
    }
  }
  // Medians of chi-square with 3 and 2 dof.
  out.depth_residual_scale = std::sqrt(median(chi2_depth) / 2.365974);
  out.pixel_residual_scale = std::sqrt(median(chi2_pixel) / 1.386294);
  out.solved = true;
  out.iterations = static_cast<int>(summary.iterations.size());
  out.initial_cost = summary.initial_cost;
  out.final_cost = summary.final_cost;
  return out;
}

}  // namespace pplvo::estimator
