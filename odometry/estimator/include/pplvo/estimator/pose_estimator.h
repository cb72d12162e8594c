#pragma once
/// Frame-to-frame pose from 3D-to-2D point and line matches and 3D-to-3D plane matches,
/// weighted by their propagated uncertainty (paper Sec. "Pose Estimation" and "Pose
/// Uncertainty"; equations numbered as in docs/estimator.md: residuals 18-20 (LaTeX labels
/// eq:pt_err, eq:line_err, eq:plane_r), joint cost E (eq:objective_fx), covariance 21
/// (eq:pose_var)). Derivations: docs/estimator.md.
///
/// Frames: "prev" is the reference frame whose 3D primitives are known, "curr" the frame
/// whose 2D points/lines and planes are observed. T_curr_prev maps prev-camera points into the
/// current camera: p_curr = T_curr_prev * p_prev.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"
#include "pplvo/core/geometry.h"
#include "pplvo/core/primitives.h"

namespace pplvo::estimator {

/// 3D point of the previous frame matched to an undistorted pixel of the current frame.
struct PointMatch3D2D {
  Point3WithCov P_prev;                               ///< prev camera frame, m / m^2
  Eigen::Vector2d px_curr = Eigen::Vector2d::Zero();  ///< undistorted pixel
  double sigma_px = std::sqrt(1.0 / 12.0);            ///< std of each pixel coordinate
};

/// 3D segment of the previous frame matched to a 2D line a u + b v + c = 0 of the current
/// frame (a^2 + b^2 = 1; re-normalised if needed).
struct LineMatch3D2D {
  Line3WithCov L_prev;
  Eigen::Vector3d l_curr = Eigen::Vector3d::Zero();
  double sigma_px = std::sqrt(1.0 / 12.0);  ///< std of the 2D line's distance at an endpoint
};

/// Plane of the previous frame matched to a plane of the current frame.
struct PlaneMatch3D3D {
  PlaneWithCov prev, curr;
};

/// Counts of matches dropped before the optimisation.
struct CorrespondenceStats {
  int bad_index = 0;       ///< match index outside the feature arrays
  int no_3d = 0;           ///< previous point/line without a 3D estimate
  int non_finite = 0;      ///< NaN/inf in a value or covariance
  int bad_covariance = 0;  ///< covariance not symmetric positive semi-definite
  int bad_geometry = 0;    ///< degenerate 2D line equation, plane normal not unit, ...
  int total() const { return bad_index + no_3d + non_finite + bad_covariance + bad_geometry; }
};

struct Correspondences {
  std::vector<PointMatch3D2D> points;
  std::vector<LineMatch3D2D> lines;
  std::vector<PlaneMatch3D3D> planes;
  CorrespondenceStats skipped;  ///< filled by buildCorrespondences()
};

/// A Gaussian prior on T_curr_prev (e.g. the constant-velocity prediction with the velocity
/// model's process noise): its mean and the covariance of xi = [t; q_xyz] about that mean.
struct MotionPrior {
  Pose3 T_curr_prev = Pose3::Identity();
  Matrix6d covariance = Matrix6d::Identity();
};

/// Options of PoseEstimator. Defaults follow the paper where it gives a value.
struct PoseEstimatorOptions {
  /// Feature families (for the paper's ablations: points, points+lines, points+planes, all).
  bool use_points = true;
  bool use_lines = true;
  bool use_planes = true;

  /// Pixel noise of a keypoint: sigma_p^2 = 1/12 px^2 (uniform quantisation, paper Sec.
  /// "Point Backprojection"). Multiplied by octave_sigma_scale^octave in buildCorrespondences
  /// (1.0 = same for every octave; e.g. 1.2 for an ORB pyramid).
  double point_sigma_px = std::sqrt(1.0 / 12.0);
  /// 1.2 = the ORB pyramid's scale factor: a keypoint found on level o is located to within
  /// 1.2^o pixels of level 0 (as in ORB-SLAM). ICL RPE 7.7 -> 6.8 mm/s (docs/estimator.md).
  double octave_sigma_scale = 1.2;
  /// Std of the current 2D line's distance at a projected endpoint (px).
  double line_sigma_px = std::sqrt(1.0 / 12.0);
  /// alpha of the joint cost E: scale of the plane terms (paper: 0.02, "coarse tuning").
  double plane_scale_alpha = 0.02;
  /// Planes' weight from their residuals: at each IRLS step k = max(1, median over planes of
  /// r^T Sigma_r^-1 r / 2.366) (the median of chi-square(3) is 2.366: k = 1 when Sigma_r is
  /// right), the plane terms weigh min(alpha, 1/k), and the sandwich covariance takes their
  /// residual covariance as k Sigma_r. Real depth errors are correlated over a plane, so its
  /// WLS covariance (which shrinks with the pixel count) is far too small: median k 2,100 on
  /// TUM fr1, 430 on fr3, 8 on ICL-NUIM, under 1 on the synthetic room (docs/estimator.md,
  /// "Plane weights from their residuals"). false: alpha alone (the paper).
  bool plane_weight_from_residuals = true;
  /// Pose covariance. true: sandwich H^-1 M H^-1 with H = J^T W J (alpha in W) and M the same
  /// with alpha^2: the first-order covariance of the estimate for any alpha (equal to the
  /// paper's (J^T W J)^-1 when alpha = 1, and independent of alpha for planes alone).
  /// false: the paper's eq. 23, (J^T W J)^-1 with alpha in W (conservative on planes).
  bool covariance_sandwich = true;
  /// false (paper): w(r) = inverse diagonal of Sigma_r. true: full whitening Sigma_r^(-1/2),
  /// the Mahalanobis weight the diagonal approximates (Sigma_r of a point is anisotropic: the
  /// depth uncertainty projects along the epipolar direction). Default true: lower RPE on all
  /// three benchmark sequences (ICL 9.2 -> 7.7 mm/s, TUM 14.9 -> 13.2, synthetic 9.1 -> 8.9).
  bool full_whitening = true;

  /// Tukey M-estimator on the whitened point and line residual blocks (paper Sec. "Pose
  /// Estimation"); c in units of the robust scale (4.685: 95% efficiency).
  bool use_tukey = true;
  double tukey_c = 4.685;
  /// Robust scale of the whitened residuals: max(1, 1.4826 * median |r_w|) (MAD). With 1.0
  /// the Tukey threshold stays at c (whitened residuals are then assumed unit-variance).
  /// The scale s also enters the covariance: the point and line terms of the sandwich count
  /// s^2 times (their residuals spread s times their model; docs/estimator.md).
  bool tukey_mad_scale = true;
  /// One robust scale per family instead of one for points and lines together: the point
  /// residuals and the line residuals each get their MAD scale s_f (pooled when a family has
  /// fewer than 10 terms) and their Tukey threshold c s_f, and the family whose residuals
  /// spread more than the other's (relative to their noise models) weighs (s_min / s_f)^2 in
  /// the cost and the information; the more precise family keeps weight 1 (far from the
  /// solution every scale measures the misfit). Measured s: points 1.3-1.8 and lines 3-4.7 on
  /// TUM, points ~1 and lines ~1.1 on ICL-NUIM. false: one pooled scale, weight 1
  /// (docs/estimator.md, "What limits ICL-NUIM").
  bool family_robust_scales = true;

  /// IRLS: outer re-weighting iterations around a Ceres Levenberg-Marquardt solve.
  int max_irls_iterations = 6;
  int max_lm_iterations = 10;  ///< per Ceres solve
  /// Stop the IRLS loop when the pose moves less than this between two solves.
  double irls_tolerance_m = 1e-5;
  double irls_tolerance_rad = 1e-5;
  /// Points (and line endpoints) closer than this to the current image plane are dropped.
  double min_depth_m = 1e-3;

  /// Rejection (status != kOk). Inlier residual rows (points and lines count 2, planes 3) an
  /// estimate needs to stand alone; 9 admits 3 planes alone or 5 points. From 7 rows (one
  /// more than the six parameters) to this the pose is solved but weak (kUncertain): with so little
  /// redundancy a wrong match cannot be told from a right one, so it is only combined with a
  /// prediction (MotionChainOptions::fuse_weak_estimates).
  int min_residuals = 9;
  /// Smallest / largest eigenvalue of the Jacobi-scaled information J^T W J; below this the
  /// configuration is degenerate (an unobservable direction).
  double min_relative_eigenvalue = 1e-9;
  /// Largest eigenvalue of the translation block of Sigma_xi (m^2), paper Sec. "Pose
  /// Uncertainty". 1e-4 m^2 = (1 cm)^2; see docs/estimator.md for the values seen on synthetic
  /// data (well-conditioned frames: ~1e-7..1e-5 m^2).
  double max_translation_variance_m2 = 1e-4;
  /// Largest eigenvalue of the q_xyz block (q_xyz ~ half the rotation angle in rad):
  /// 2.5e-5 = (0.005)^2, i.e. ~0.57 deg std of the rotation angle.
  double max_rotation_variance = 2.5e-5;
};

/// Schema of PoseEstimatorOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, PoseEstimatorOptions& o) {
  v.field("use_points", o.use_points, "use point residuals (the paper's ablations)");
  v.field("use_lines", o.use_lines, "use line residuals");
  v.field("use_planes", o.use_planes, "use plane residuals");
  v.field("point_sigma_px", o.point_sigma_px,
          "keypoint pixel std: sigma_p^2 = 1/12 px^2 (Sec. 4.2, uniform quantisation)",
          config::positive());
  v.field("octave_sigma_scale", o.octave_sigma_scale,
          "point sigma multiplied by scale^octave (1 = same at every octave)", config::positive());
  v.field("line_sigma_px", o.line_sigma_px,
          "std of the 2D line distance at a projected endpoint (px)", config::positive());
  v.field("plane_scale_alpha", o.plane_scale_alpha,
          "alpha, scale of the plane terms in the joint cost E (eq. 22: 0.02, coarse tuning)",
          config::atLeast(0));
  v.field("plane_weight_from_residuals", o.plane_weight_from_residuals,
          "plane terms weigh min(alpha, 1/k), k = max(1, median plane chi-square / 2.366) at "
          "each IRLS step; the covariance takes k Sigma_r (false: alpha alone, the paper)");
  v.field("covariance_sandwich", o.covariance_sandwich,
          "pose covariance H^-1 M H^-1 (true) or the paper's eq. 23 (J^T W J)^-1 (false)");
  v.field("full_whitening", o.full_whitening,
          "false (paper): w = 1/diag(Sigma_r); true: full Sigma_r^(-1/2)");
  v.field("use_tukey", o.use_tukey, "Tukey M-estimator on point and line residuals (Sec. 4.6)");
  v.field("tukey_c", o.tukey_c, "Tukey constant on the whitened residuals (4.685)",
          config::positive());
  v.field("tukey_mad_scale", o.tukey_mad_scale,
          "robust scale max(1, 1.4826 MAD) of the whitened residuals (false: 1)");
  v.field("family_robust_scales", o.family_robust_scales,
          "points and lines each get their own robust scale s (Tukey at c s); the noisier "
          "weighs (s_min / s)^2 (false: one pooled scale, weight 1)");
  v.field("max_irls_iterations", o.max_irls_iterations, "IRLS re-weighting iterations",
          config::atLeast(1));
  v.field("max_lm_iterations", o.max_lm_iterations, "Levenberg-Marquardt iterations per solve",
          config::atLeast(1));
  v.field("irls_tolerance_m", o.irls_tolerance_m, "IRLS stops below this translation step (m)",
          config::atLeast(0));
  v.field("irls_tolerance_rad", o.irls_tolerance_rad, "IRLS stops below this rotation step (rad)",
          config::atLeast(0));
  v.field("min_depth_m", o.min_depth_m,
          "points closer than this to the current image plane are dropped (m)", config::atLeast(0));
  v.field("min_residuals", o.min_residuals,
          "inlier residual rows (points, lines 2; planes 3) to stand alone; from 7 to this the "
          "pose is solved but weak (uncertain: only combined with the prediction)",
          config::atLeast(6));
  v.field("min_relative_eigenvalue", o.min_relative_eigenvalue,
          "degenerate if the smallest/largest eigenvalue of the scaled J^T W J is below this",
          config::atLeast(0));
  v.field("max_translation_variance_m2", o.max_translation_variance_m2,
          "reject if the largest eigenvalue of the translation covariance exceeds this (Sec. "
          "4.6 Pose Uncertainty; no value in the paper: (1 cm)^2)",
          config::positive());
  v.field("max_rotation_variance", o.max_rotation_variance,
          "reject if the largest eigenvalue of the q_xyz covariance exceeds this",
          config::positive());
}

enum class EstimateStatus : int8_t {
  kOk = 0,
  kNoConstraints,      ///< no usable match at all
  kTooFewConstraints,  ///< 6 inlier residual rows or fewer: nothing solved
  kDegenerate,         ///< J^T W J (numerically) singular: unobservable direction
  kUncertain,          ///< covariance above the thresholds, or fewer rows than min_residuals
  kSolverFailure,      ///< Ceres failed or produced a non-finite pose
};
const char* toString(EstimateStatus s);

struct PoseEstimate {
  EstimateStatus status = EstimateStatus::kNoConstraints;
  bool accepted() const { return status == EstimateStatus::kOk; }

  /// The optimised pose (the initial guess when the solve could not run). Always finite.
  Pose3 T_curr_prev = Pose3::Identity();
  /// Sigma_xi (eq. 23) over xi = [t; q_xyz] of T_curr_prev; finite. When the information is
  /// singular, the unobservable directions get a large variance (kLargeVariance).
  Matrix6d covariance = Matrix6d::Identity();
  /// The same with each family's residual spread as measured where it is below the model
  /// (`covariance` keeps the model as its floor for every decision; this one is what the
  /// residuals say of the estimate's error: docs/estimator.md, "The published covariance").
  /// Unset: `covariance`.
  std::optional<Matrix6d> covariance_at_measured_spread;
  double max_translation_variance_m2 = 0;
  double max_rotation_variance = 0;
  double min_relative_eigenvalue = 0;  ///< of the Jacobi-scaled J^T W J
  /// d xi / d e for a rigid error e (xi units) of the current frame's depth: H^-1 H_planes, the
  /// share of the solution its planes carry (zero without planes; identity when they carry it
  /// all). The depth filter's time alignment is such an error (docs/estimator.md).
  Matrix6d current_depth_sensitivity = Matrix6d::Zero();

  // Diagnostics.
  int n_points_in = 0, n_lines_in = 0, n_planes_in = 0;        ///< after validation
  int n_points_used = 0, n_lines_used = 0, n_planes_used = 0;  ///< inliers at the end
  int n_residuals = 0;                                         ///< inlier residual rows
  CorrespondenceStats skipped;  ///< input matches dropped by validation
  int irls_iterations = 0;
  int lm_iterations = 0;
  double initial_cost = 0, final_cost = 0;  ///< 0.5 * sum of squared weighted residuals
  double robust_scale = 1;                  ///< MAD scale of the whitened residuals
  double point_scale = 1, line_scale = 1;   ///< each family's (= robust_scale when pooled)
  /// The planes' residual scale k (1 = their covariance is right) and weight (alpha or less).
  double plane_scale = 1;
  double plane_weight = 0;
};

/// Variance put on unobservable directions of a singular information matrix.
constexpr double kLargeVariance = 1e6;

/// Builds 3D-to-2D / 3D-to-3D correspondences from features of two frames and their matches
/// (prev index, curr index). Points and lines need has_3d in prev; the current point pixel
/// and line equation are used. Matches with bad indices or without 3D are counted in
/// `skipped`; values are validated again by PoseEstimator::estimate.
Correspondences buildCorrespondences(const FrameFeatures& prev, const FrameFeatures& curr,
                                     const FeatureMatches& matches,
                                     const PoseEstimatorOptions& options);

/// Single-frame pose estimator (stateless apart from its options).
class PoseEstimator {
 public:
  explicit PoseEstimator(PoseEstimatorOptions options = {});
  const PoseEstimatorOptions& options() const { return options_; }

  /// Estimates T_curr_prev starting from `T_curr_prev_guess` (e.g. the constant-velocity
  /// prediction). `camera` is the current frame's camera (signed focal lengths are fine).
  /// Never throws on bad data: invalid matches are skipped and counted, failure is a status.
  /// With a `prior` the solve is the maximum a posteriori one: six more rows pull xi towards
  /// the prior's mean, weighted by its covariance, and the covariance is the posterior's (a
  /// prior that is not a valid pose with a positive definite covariance is ignored).
  PoseEstimate estimate(const Correspondences& correspondences, const PinholeCamera& camera,
                        const Pose3& T_curr_prev_guess = Pose3::Identity(),
                        const std::optional<MotionPrior>& prior = std::nullopt) const;

  /// Convenience: buildCorrespondences() + estimate() with curr.camera.
  PoseEstimate estimate(const FrameFeatures& prev, const FrameFeatures& curr,
                        const FeatureMatches& matches,
                        const Pose3& T_curr_prev_guess = Pose3::Identity()) const;

 private:
  PoseEstimatorOptions options_;
};

}  // namespace pplvo::estimator
