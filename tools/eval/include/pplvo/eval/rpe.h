#pragma once
/// Relative pose error as defined by the TUM RGB-D benchmark's evaluate_rpe.py run with
/// `--fixed_delta --delta 1 --delta_unit s`. See docs/evaluation.md for the quirks kept.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "pplvo/eval/error_stats.h"
#include "pplvo/eval/tum_file.h"

namespace pplvo {
namespace eval {

/// TUM find_closest_index(L, t): a binary search over the sorted list L that keeps the best of
/// the visited midpoints (strict <, initial best index 0) and returns at once on equality.
/// The result is always a nearest element, but on equal distances the one visited first wins,
/// which is not always the lower index. L must be non-empty and sorted ascending.
std::size_t findClosestIndex(const std::vector<double>& sorted, double t);

/// TUM transform44: 4x4 pose from (tx ty tz qx qy qz qw); the quaternion is normalised, and a
/// quaternion with squared norm below 4 * machine epsilon gives the identity rotation.
Eigen::Matrix4d transform44(const std::array<double, 7>& values);

struct RpeOptions {
  double delta_s = 1.0;           ///< TUM --delta 1 --delta_unit s --fixed_delta
  double offset_s = 0.0;          ///< added to estimated stamps (TUM --offset)
  std::size_t max_pairs = 10000;  ///< TUM --max_pairs; see RpeResult::exceeds_max_pairs
};

/// One evaluated pair.
struct RpePair {
  double est0_s = 0.0, est1_s = 0.0, gt0_s = 0.0, gt1_s = 0.0;
  double trans_m = 0.0;  ///< |translation of the error transform| [m per delta]
  double rot_rad = 0.0;  ///< rotation angle of the error transform [rad per delta]
};

struct RpeResult {
  bool ok = false;
  std::string error;  ///< set when ok == false
  std::vector<RpePair> pairs;
  ErrorStats trans_m;                     ///< over pairs, metres per delta
  ErrorStats rot_rad;                     ///< over pairs, radians per delta
  /// Least-squares scale s of the estimated relative translations against the ground truth's
  /// over the pairs (min sum |t_est - s t_gt|^2; not part of TUM's script). 1 = unbiased; < 1 =
  /// motion under-estimated, e.g. the attenuation that depth noise causes (docs/pipeline.md).
  /// NaN when the ground truth does not move.
  double trans_scale = 0.0;
  int candidate_pairs = 0;                ///< (i, j) pairs before the ground-truth time check
  int skipped_gt_time = 0;                ///< pairs dropped by the gt_max_time_difference check
  double gt_max_time_difference_s = 0.0;  ///< 2 * median ground-truth stamp interval
  /// More candidate pairs than max_pairs: TUM would draw a random subset; we keep all of them.
  bool exceeds_max_pairs = false;
  int skipped_rows_gt = 0;  ///< rows with an all-zero quaternion or a NaN value
  int skipped_rows_est = 0;
};

/// RPE of `est` against `gt` with a fixed time delta.
RpeResult evaluateRpe(const TumFile& gt, const TumFile& est, const RpeOptions& options = {});

}  // namespace eval
}  // namespace pplvo
