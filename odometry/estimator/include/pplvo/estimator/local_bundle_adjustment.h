#pragma once
/// Local bundle adjustment over a window of keyframes and the point landmarks they observe
/// (docs/estimator.md, "Local map"). No LCM, no map bookkeeping: the caller (the tracking
/// core's LocalMapper) says which keyframes are free, which are held fixed (the gauge and the
/// fixed lag), and which keyframe observed which landmark.
///
/// An RGB-D keyframe observes a point as a pixel and a depth; back-projected, that is a 3D
/// point in the keyframe's camera frame with the covariance the paper propagates from the
/// pixel and depth noise (Sec. "Depth Uncertainty"). The residual of one observation is that
/// measurement against the landmark moved into the keyframe, whitened by its covariance:
///   r = L^-1 (R_kf_w (X_w - t_w_kf) - p_kf),  L L^T = Sigma_kf,
/// which to first order is the paper's reprojection residual plus the depth residual of the
/// same observation (the back-projection is a bijection of pixel and depth). A Huber loss at
/// the 95 % chi-square bound (3 dof) keeps wrong associations from bending the window; they
/// are reported as outliers afterwards. Relative poses (BundleRelativePose) join the points as
/// whitened 6-dof residuals in xi.
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"

namespace pplvo::estimator {

struct BundleKeyframe {
  Pose3 T_w_kf = Pose3::Identity();
  bool fixed = false;  ///< held at its pose (gauge, or outside the optimised window)
};

struct BundleObservation {
  int keyframe = -1;  ///< index in BundleProblem::keyframes
  int landmark = -1;  ///< index in BundleProblem::landmarks_w
  Eigen::Vector3d p_kf = Eigen::Vector3d::Zero();    ///< the measured point, keyframe frame
  Eigen::Matrix3d cov_kf = Eigen::Matrix3d::Zero();  ///< its covariance
  /// false: only the pixel (the projection of p_kf) is used, with sigma_px per axis.
  bool use_depth = true;
  double sigma_px = 1.0;
};

/// A measured relative pose between two keyframes, T_to_from (maps points of `from` into `to`),
/// with the covariance of its xi = [t; q_xyz] (pose_parameterisation.h): what the lines and
/// planes of the pair say about it, their own landmarks marginalised (the estimator's
/// eqs. 20-22 on that pair).
struct BundleRelativePose {
  int from = -1, to = -1;  ///< indices in BundleProblem::keyframes
  Pose3 T_to_from = Pose3::Identity();
  Matrix6d covariance = Matrix6d::Identity();
};

struct BundleProblem {
  PinholeCamera camera;  ///< for observations without depth
  std::vector<BundleKeyframe> keyframes;
  std::vector<Eigen::Vector3d> landmarks_w;
  std::vector<BundleObservation> observations;
  std::vector<BundleRelativePose> relative_poses;
};

struct BundleOptions {
  int max_iterations = 8;
  /// Huber threshold and outlier bound on the squared whitened residual (3 dof, 95 %).
  double outlier_chi2 = 7.815;
  double outlier_chi2_2d = 5.991;  ///< the same for pixel observations (2 dof, 95 %)
};

struct BundleResult {
  bool solved = false;  ///< false: nothing to adjust or the solver failed (inputs unchanged)
  int iterations = 0;
  double initial_cost = 0, final_cost = 0;
  std::vector<Pose3> T_w_kf;                  ///< every keyframe, fixed ones unchanged
  std::vector<Eigen::Vector3d> landmarks_w;   ///< every landmark
  std::vector<bool> inlier;                   ///< per observation, chi2 below outlier_chi2
  /// Per observation, the squared whitened residual at the solution (NaN when left out).
  std::vector<double> chi2;
  /// Robust scale of the whitened residuals of the depth (3D) and pixel (2D) observations:
  /// sqrt(median chi2 / median of chi-square with 3 resp. 2 dof); 1 when the covariances
  /// describe the residuals, NaN without such observations.
  double depth_residual_scale = 0, pixel_residual_scale = 0;
};

/// Adjusts the free keyframes and every landmark with at least one observation. At least one
/// keyframe must be fixed (the gauge); invalid observations (non-finite, covariance not
/// positive definite, indices out of range) are left out and marked outliers.
BundleResult adjustLocalBundle(const BundleProblem& problem, const BundleOptions& options = {});

}  // namespace pplvo::estimator
