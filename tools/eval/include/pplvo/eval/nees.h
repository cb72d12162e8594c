#pragma once
/// Consistency of published relative-pose covariances against TUM ground truth: per frame pair
/// NEES = e^T (C_est + C_gt)^-1 e with e = xi(T_est) - xi(T_gt) in the estimator's
/// parameterisation xi = [t; q_xyz] of T_prev_curr, and C_gt the ground truth's own
/// uncertainty (motion-capture jitter and frame timestamp error). See docs/evaluation.md,
/// "Covariance consistency (NEES)".
#include <cmath>
#include <string>
#include <vector>

#include "pplvo/eval/relative_pose_file.h"
#include "pplvo/eval/tum_file.h"

namespace pplvo {
namespace eval {

/// Regularised lower incomplete gamma P(a, x) (series / continued fraction).
double regularisedGammaP(double a, double x);
/// Chi-square CDF with `dof` degrees of freedom.
double chiSquareCdf(double x, double dof);
/// Chi-square quantile: x with chiSquareCdf(x, dof) = p (0 < p < 1), by bisection.
double chiSquareQuantile(double p, double dof);

/// Assumed uncertainty of the ground truth (each default explained in docs/evaluation.md).
struct GtNoiseOptions {
  /// White noise of each ground-truth position, per axis (m). TUM's 100 Hz motion capture:
  /// the data's third differences give 0.07-0.17 mm; 0.2 mm keeps a margin.
  double sigma_t_m = 2e-4;
  /// White noise of each ground-truth orientation, per axis (rad). Data: 0.016-0.062 deg.
  double sigma_rot_rad = 0.07 * M_PI / 180.0;
  /// Error of each frame stamp against the instant the ground truth is interpolated at (s):
  /// Kinect stamp jitter and colour/depth offset; propagated through the ground truth's own
  /// velocity. 0 for ICL-NUIM and synthetic sequences (exact frame indices).
  double sigma_stamp_s = 2e-3;
};

/// White noise of the ground truth's samples estimated from the data: third differences of
/// consecutive samples cancel a motion that is quadratic over four samples and multiply white
/// noise of std s by sqrt(20); robust std (1.4826 MAD) per axis, RMS over the three axes.
/// Rotation from the body-frame increments log(R_i^T R_i+1) (second differences of them).
/// Positions per world axis, rotations per body axis. Needs >= 20 samples.
struct GtJitter {
  bool ok = false;
  double sigma_t_m = 0.0, sigma_rot_rad = 0.0;
  double per_axis_t_m[3] = {0, 0, 0}, per_axis_rot_rad[3] = {0, 0, 0};
};
GtJitter estimateGtJitter(const TumFile& gt);

struct NeesOptions {
  GtNoiseOptions gt;
  /// Replace gt.sigma_t_m and gt.sigma_rot_rad by estimateGtJitter(gt) (pplvo-eval's default;
  /// --gt-sigma-* or --exact-gt turn it off).
  bool gt_jitter_from_data = false;
  /// The two ground-truth samples around a stamp must be at most this far apart (s);
  /// <= 0: 2.5 times the median ground-truth interval.
  double max_gt_interval_s = 0.0;
  /// The ground truth is read at each frame stamp plus this (s): a clock offset between the
  /// motion capture and the camera, a property of the recording (TUM's tools take --offset).
  double gt_time_offset_s = 0.0;
  /// Added to each pair's covariance as 2 Q, Q = diag(sigma_t^2 I, (sigma_rot / 2)^2 I): a
  /// per-frame pose error shared by all of a frame's measurements (FrameErrorFit below). 0: the
  /// published covariance as it is.
  double added_frame_sigma_t_m = 0.0;
  double added_frame_sigma_rot_rad = 0.0;
  bool include_velocity_model = true;  ///< evaluate STATUS_VELOCITY_MODEL frames too
  double confidence = 0.95;            ///< of the chi-square bounds
};

/// One evaluated frame pair.
struct NeesPair {
  double stamp_s = 0.0, prev_stamp_s = 0.0;
  int status = 1;
  Vector6d error = Vector6d::Zero();    ///< xi(T_est) - xi(T_gt)
  Matrix6d cov_est = Matrix6d::Zero();  ///< published covariance
  Matrix6d cov_gt = Matrix6d::Zero();   ///< ground-truth noise + timestamp error
  Matrix6d cov_frame = Matrix6d::Zero();  ///< NeesOptions::added_frame_sigma_* as 2 Q
  double nees = 0.0;                    ///< 6 dof, with cov_est + cov_gt + cov_frame
  double nees_t = 0.0, nees_r = 0.0;    ///< 3 dof, marginal blocks
  double nees_est_only = 0.0;           ///< 6 dof, cov_est alone
};

struct NeesBlockStats {
  double mean = 0.0, median = 0.0;
  double share_inside = 0.0;  ///< share of pairs with NEES <= bound
  double bound = 0.0;         ///< chi-square quantile at `confidence`
};

struct NeesResult {
  bool ok = false;
  std::string error;
  std::vector<NeesPair> pairs;
  NeesBlockStats all, translation, rotation;
  double mean_est_only = 0.0;  ///< mean 6-dof NEES without the ground-truth terms
  /// Two-sided interval of the mean 6-dof NEES of N independent consistent pairs:
  /// [chi2_{(1-c)/2}(6N), chi2_{(1+c)/2}(6N)] / N.
  double mean_interval_lo = 0.0, mean_interval_hi = 0.0;
  // Sizes: RMS per axis of the predicted std and of the actual error.
  double rms_sigma_t_m = 0.0, rms_error_t_m = 0.0;      ///< translation, per axis
  double rms_sigma_q = 0.0, rms_error_q = 0.0;          ///< q_xyz, per axis (~ half angle)
  double rms_sigma_gt_t_m = 0.0, rms_sigma_gt_q = 0.0;  ///< ground-truth part of C
  int records = 0;
  int skipped_status = 0;    ///< first / lost (and velocity model when excluded)
  int skipped_no_gt = 0;     ///< a stamp outside the ground truth or in a gap
  int skipped_singular = 0;  ///< C not positive definite
  double max_gt_interval_s = 0.0;
  GtNoiseOptions gt_used;  ///< the ground-truth noise actually assumed
  double gt_time_offset_s = 0.0;
  double added_frame_sigma_t_m = 0.0, added_frame_sigma_rot_rad = 0.0;
};

/// Evaluates every record against `gt` (TUM file, T_w_c; stamps in seconds already).
NeesResult evaluateNees(const TumFile& gt, const std::vector<RelativePoseRecord>& records,
                        const NeesOptions& options = {});

/// Clock offset between ground truth and frames: the gt_time_offset_s in
/// [-max_abs_s, max_abs_s] (steps of step_s) that minimises the mean squared rotation error
/// of the pairs. Rotation, because a relative rotation does not depend on where the camera
/// is, only on when: a shifted clock changes it by the offset times the change of the angular
/// rate over the pair (large for a hand-held camera), while the translation error of TUM's
/// sequences does not depend on the offset (docs/estimator.md). ok = false when no pair
/// could be evaluated at some offset.
struct GtTimeOffsetEstimate {
  bool ok = false;
  double offset_s = 0.0;
  double rms_rot_rad = 0.0;       ///< per axis, at offset_s (rotation angle, not q)
  double rms_rot_zero_rad = 0.0;  ///< per axis, at offset 0
};
GtTimeOffsetEstimate estimateGtTimeOffset(const TumFile& gt,
                                          const std::vector<RelativePoseRecord>& records,
                                          const NeesOptions& options, double max_abs_s = 0.05,
                                          double step_s = 0.001);

/// The per-frame shared error that makes the published covariances consistent: sigma_t_m
/// and sigma_rot_rad (per axis, each frame's pose) such that adding 2 Q (as
/// NeesOptions::added_frame_sigma_*) brings the mean translation and rotation NEES of all
/// given pairs to 3 each (their degrees of freedom); 0 when the covariance is already
/// large enough. Pairs of every result are pooled, each pair counting once. The covariances
/// must be those of a run without a frame error of its own (or the result adds to it in
/// quadrature). docs/estimator.md, "The per-frame shared error".
struct FrameErrorFit {
  bool ok = false;
  double sigma_t_m = 0.0, sigma_rot_rad = 0.0;
  int pairs = 0;
};
FrameErrorFit fitFrameError(const std::vector<const NeesResult*>& results);

/// `nees.*` key value lines (text) and a JSON object.
std::string formatNeesText(const NeesResult& result);
std::string formatNeesJson(const NeesResult& result);
/// Per-pair data: `stamp_s prev_stamp_s status nees nees_t nees_r nees_est_only e(6) sd(6)`
/// with '#' header lines naming the bounds.
std::string formatNeesData(const NeesResult& result);

/// One row of formatNeesData as read back (pplvo-plot --nees).
struct NeesDataRow {
  double stamp_s = 0.0;
  double nees = 0.0, nees_t = 0.0, nees_r = 0.0;
};
struct NeesDataReadResult {
  bool ok = false;
  std::string error;
  std::vector<NeesDataRow> rows;
};
NeesDataReadResult readNeesData(const std::string& path);

}  // namespace eval
}  // namespace pplvo
