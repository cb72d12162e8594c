#pragma once
/// Absolute trajectory error as defined by the TUM RGB-D benchmark's evaluate_ate.py:
/// stamp association, rigid (no scale) Horn alignment of the estimate onto the ground truth,
/// per-pose position error norms. See docs/evaluation.md.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "pplvo/eval/error_stats.h"
#include "pplvo/eval/tum_file.h"

namespace pplvo {
namespace eval {

struct AssociationOptions {
  double max_difference_s = 0.02;  ///< TUM default --max_difference 0.02
  double offset_s = 0.0;           ///< added to the second list's stamps (TUM --offset)
};

/// A matched stamp pair (first list, second list).
struct StampMatch {
  double first_s = 0.0;
  double second_s = 0.0;
};

/// TUM associate(): every pair (a, b) with |a - (b + offset)| < max_difference, sorted by
/// (difference, a, b), taken greedily so that each stamp is used at most once; the result is
/// sorted by (a, b). `first_s` and `second_s` are the distinct stamps of each list.
std::vector<StampMatch> associateStamps(const std::vector<double>& first_s,
                                        const std::vector<double>& second_s,
                                        const AssociationOptions& options = {});

/// TUM align(model, data): rotation and translation, without scale, that best map `model`
/// (estimated positions, 3xN) onto `data` (ground-truth positions, 3xN), and the residual
/// norms |R model_i + t - data_i|.
struct HornAlignment {
  Eigen::Matrix3d R_data_model = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_data_model = Eigen::Vector3d::Zero();
  std::vector<double> errors_m;
};
HornAlignment alignHorn(const Eigen::Matrix3Xd& model, const Eigen::Matrix3Xd& data);

struct AteOptions {
  AssociationOptions association;
};

/// One associated pose pair after alignment.
struct AtePair {
  double gt_stamp_s = 0.0;
  double est_stamp_s = 0.0;
  Eigen::Vector3d p_gt_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_est_aligned_m = Eigen::Vector3d::Zero();  ///< R * p_est + t
  double error_m = 0.0;
};

struct AteResult {
  bool ok = false;
  std::string error;   ///< set when ok == false (fewer than 2 pairs)
  ErrorStats error_m;  ///< statistics of the per-pair position errors [m]
  std::vector<AtePair> pairs;
  Eigen::Matrix3d R_gt_est = Eigen::Matrix3d::Identity();  ///< alignment rotation
  Eigen::Vector3d t_gt_est = Eigen::Vector3d::Zero();      ///< alignment translation [m]
  int skipped_non_finite_gt = 0;  ///< rows dropped for a NaN/inf stamp or position
  int skipped_non_finite_est = 0;
};

/// ATE of `est` against `gt` (TUM evaluate_ate.py with --scale 1).
AteResult evaluateAte(const TumFile& gt, const TumFile& est, const AteOptions& options = {});

}  // namespace eval
}  // namespace pplvo
