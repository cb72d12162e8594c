#include "pplvo/eval/rpe.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>

namespace pplvo {
namespace eval {
namespace {

// TUM read_trajectory: drop rows whose quaternion is exactly (0, 0, 0, 0) or that hold a NaN;
// build a dict stamp -> pose (last wins). Rows with an infinite stamp are dropped as well.
std::map<double, Eigen::Matrix4d> posesByStamp(const TumFile& file, int* skipped) {
  std::map<double, Eigen::Matrix4d> by_stamp;
  for (const TumRow& row : file.rows) {
    const bool zero_q = row.values[3] == 0.0 && row.values[4] == 0.0 && row.values[5] == 0.0 &&
                        row.values[6] == 0.0;
    bool has_nan = std::isnan(row.stamp_s) || !std::isfinite(row.stamp_s);
    for (double v : row.values) has_nan = has_nan || std::isnan(v);
    if (zero_q || has_nan) {
      ++*skipped;
      continue;
    }
    by_stamp[row.stamp_s] = transform44(row.values);
  }
  return by_stamp;
}

// TUM ominus(a, b) = inv(a) * b (general 4x4 inverse, as numpy.linalg.inv).
Eigen::Matrix4d ominus(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
  return a.inverse() * b;
}

double medianOf(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 == 1 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

std::string num(double v) {
  std::ostringstream ss;
  ss << v;
  return ss.str();
}

}  // namespace

std::size_t findClosestIndex(const std::vector<double>& L, double t) {
  std::size_t beginning = 0;
  double difference = std::abs(L[0] - t);
  std::size_t best = 0;
  std::size_t end = L.size();
  while (beginning < end) {
    const std::size_t middle = (end + beginning) / 2;
    if (std::abs(L[middle] - t) < difference) {
      difference = std::abs(L[middle] - t);
      best = middle;
    }
    if (t == L[middle]) {
      return middle;
    } else if (L[middle] > t) {
      end = middle;
    } else {
      beginning = middle + 1;
    }
  }
  return best;
}

Eigen::Matrix4d transform44(const std::array<double, 7>& l) {
  const double eps = std::numeric_limits<double>::epsilon() * 4.0;
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T(0, 3) = l[0];
  T(1, 3) = l[1];
  T(2, 3) = l[2];
  Eigen::Vector4d q(l[3], l[4], l[5], l[6]);  // x y z w
  const double nq = q.dot(q);
  if (nq < eps) return T;
  q *= std::sqrt(2.0 / nq);
  const Eigen::Matrix4d o = q * q.transpose();
  T(0, 0) = 1.0 - o(1, 1) - o(2, 2);
  T(0, 1) = o(0, 1) - o(2, 3);
  T(0, 2) = o(0, 2) + o(1, 3);
  T(1, 0) = o(0, 1) + o(2, 3);
  T(1, 1) = 1.0 - o(0, 0) - o(2, 2);
  T(1, 2) = o(1, 2) - o(0, 3);
  T(2, 0) = o(0, 2) - o(1, 3);
  T(2, 1) = o(1, 2) + o(0, 3);
  T(2, 2) = 1.0 - o(0, 0) - o(1, 1);
  return T;
}

RpeResult evaluateRpe(const TumFile& gt, const TumFile& est, const RpeOptions& options) {
  RpeResult result;
  const auto traj_gt = posesByStamp(gt, &result.skipped_rows_gt);
  const auto traj_est = posesByStamp(est, &result.skipped_rows_est);
  if (traj_gt.size() < 2 || traj_est.size() < 2) {
    result.error =
        "fewer than 2 usable poses in '" + (traj_gt.size() < 2 ? gt.name : est.name) + "'";
    return result;
  }
  std::vector<double> stamps_gt, stamps_est;
  for (const auto& kv : traj_gt) stamps_gt.push_back(kv.first);
  for (const auto& kv : traj_est) stamps_est.push_back(kv.first);
  const double offset = options.offset_s;

  // TUM's overlap check: estimated stamps reached by a round trip through the ground truth.
  std::set<double> stamps_est_return;
  for (double t_est : stamps_est) {
    const double t_gt = stamps_gt[findClosestIndex(stamps_gt, t_est + offset)];
    stamps_est_return.insert(stamps_est[findClosestIndex(stamps_est, t_gt - offset)]);
  }
  if (stamps_est_return.size() < 2) {
    result.error =
        "the time overlap of the two trajectories is too small: are the stamps "
        "in the same clock?";
    return result;
  }

  // Fixed delta in seconds; TUM drops every pair whose end is the last estimated pose.
  struct IndexPair {
    std::size_t i, j;
  };
  std::vector<IndexPair> pairs;
  const std::size_t n_est = stamps_est.size();
  for (std::size_t i = 0; i < n_est; ++i) {
    const std::size_t j = findClosestIndex(stamps_est, stamps_est[i] + options.delta_s);
    if (j != n_est - 1) pairs.push_back({i, j});
  }
  result.candidate_pairs = static_cast<int>(pairs.size());
  result.exceeds_max_pairs = options.max_pairs != 0 && pairs.size() > options.max_pairs;

  std::vector<double> intervals;
  for (std::size_t k = 1; k < stamps_gt.size(); ++k) {
    intervals.push_back(stamps_gt[k] - stamps_gt[k - 1]);
  }
  result.gt_max_time_difference_s = 2.0 * medianOf(intervals);

  std::vector<double> trans, rot;
  double est_dot_gt = 0.0, gt_sq = 0.0;
  for (const IndexPair& p : pairs) {
    const double est0 = stamps_est[p.i], est1 = stamps_est[p.j];
    const double gt0 = stamps_gt[findClosestIndex(stamps_gt, est0 + offset)];
    const double gt1 = stamps_gt[findClosestIndex(stamps_gt, est1 + offset)];
    if (std::abs(gt0 - (est0 + offset)) > result.gt_max_time_difference_s ||
        std::abs(gt1 - (est1 + offset)) > result.gt_max_time_difference_s) {
      ++result.skipped_gt_time;
      continue;
    }
    const Eigen::Matrix4d rel_est = ominus(traj_est.at(est1), traj_est.at(est0));
    const Eigen::Matrix4d rel_gt = ominus(traj_gt.at(gt1), traj_gt.at(gt0));
    const Eigen::Matrix4d error44 = ominus(rel_est, rel_gt);
    est_dot_gt += rel_est.block<3, 1>(0, 3).dot(rel_gt.block<3, 1>(0, 3));
    gt_sq += rel_gt.block<3, 1>(0, 3).squaredNorm();
    RpePair out;
    out.est0_s = est0;
    out.est1_s = est1;
    out.gt0_s = gt0;
    out.gt1_s = gt1;
    out.trans_m = error44.block<3, 1>(0, 3).norm();
    out.rot_rad =
        std::acos(std::min(1.0, std::max(-1.0, (error44.block<3, 3>(0, 0).trace() - 1.0) / 2.0)));
    trans.push_back(out.trans_m);
    rot.push_back(out.rot_rad);
    result.pairs.push_back(out);
  }
  if (result.pairs.size() < 2) {
    result.error = "only " + std::to_string(result.pairs.size()) + " pose pair(s) " +
                   num(options.delta_s) + " s apart with ground truth within " +
                   num(result.gt_max_time_difference_s) +
                   " s (need at least 2): is the estimate longer than the delta and in the same "
                   "clock as the ground truth?";
    return result;
  }
  result.trans_m = computeErrorStats(trans);
  result.rot_rad = computeErrorStats(rot);
  result.trans_scale = gt_sq > 0.0 ? est_dot_gt / gt_sq : std::numeric_limits<double>::quiet_NaN();
  result.ok = true;
  return result;
}

}  // namespace eval
}  // namespace pplvo
