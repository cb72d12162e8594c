#include "pplvo/eval/ate.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <tuple>

namespace pplvo {
namespace eval {
namespace {

// TUM read_file_list builds a dict: the last line with a given stamp wins. Rows whose stamp or
// position is not finite are dropped here (TUM would carry NaN into every figure).
std::map<double, const TumRow*> positionsByStamp(const TumFile& file, int* skipped) {
  std::map<double, const TumRow*> by_stamp;
  for (const TumRow& row : file.rows) {
    if (!std::isfinite(row.stamp_s) || !std::isfinite(row.values[0]) ||
        !std::isfinite(row.values[1]) || !std::isfinite(row.values[2])) {
      ++*skipped;
      continue;
    }
    by_stamp[row.stamp_s] = &row;
  }
  return by_stamp;
}

std::string formatSeconds(double s) {
  std::ostringstream ss;
  ss << s;
  return ss.str();
}

}  // namespace

std::vector<StampMatch> associateStamps(const std::vector<double>& first_s,
                                        const std::vector<double>& second_s,
                                        const AssociationOptions& options) {
  std::vector<double> first = first_s, second = second_s;
  std::sort(first.begin(), first.end());
  std::sort(second.begin(), second.end());
  const double max_diff = options.max_difference_s;
  if (!(max_diff > 0.0)) return {};
  // Candidates (difference, index in first, index in second). Only stamps inside a window of
  // twice the tolerance can qualify; the exact TUM test decides.
  std::vector<std::tuple<double, std::size_t, std::size_t>> candidates;
  for (std::size_t ib = 0; ib < second.size(); ++ib) {
    const double target = second[ib] + options.offset_s;
    auto it = std::lower_bound(first.begin(), first.end(), target - 2.0 * max_diff);
    for (; it != first.end() && *it <= target + 2.0 * max_diff; ++it) {
      const double diff = std::abs(*it - target);
      if (diff < max_diff) {
        candidates.emplace_back(diff, static_cast<std::size_t>(it - first.begin()), ib);
      }
    }
  }
  // Python sorts the tuples (diff, a, b); indices into sorted lists order like the stamps.
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> used_first(first.size(), false), used_second(second.size(), false);
  std::vector<std::pair<std::size_t, std::size_t>> taken;
  for (const auto& c : candidates) {
    const std::size_t ia = std::get<1>(c), ib = std::get<2>(c);
    if (used_first[ia] || used_second[ib]) continue;
    used_first[ia] = used_second[ib] = true;
    taken.emplace_back(ia, ib);
  }
  std::sort(taken.begin(), taken.end());
  std::vector<StampMatch> matches;
  matches.reserve(taken.size());
  for (const auto& t : taken) matches.push_back({first[t.first], second[t.second]});
  return matches;
}

HornAlignment alignHorn(const Eigen::Matrix3Xd& model, const Eigen::Matrix3Xd& data) {
  HornAlignment result;
  const Eigen::Index n = model.cols();
  if (n == 0 || data.cols() != n) return result;
  const Eigen::Vector3d model_mean = model.rowwise().mean();
  const Eigen::Vector3d data_mean = data.rowwise().mean();
  Eigen::Matrix3d W = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    W += (model.col(i) - model_mean) * (data.col(i) - data_mean).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(W.transpose(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d Vh = svd.matrixV().transpose();
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (U.determinant() * Vh.determinant() < 0.0) S(2, 2) = -1.0;
  result.R_data_model = U * S * Vh;
  result.t_data_model = data_mean - result.R_data_model * model_mean;
  result.errors_m.resize(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    result.errors_m[static_cast<std::size_t>(i)] =
        (result.R_data_model * model.col(i) + result.t_data_model - data.col(i)).norm();
  }
  return result;
}

AteResult evaluateAte(const TumFile& gt, const TumFile& est, const AteOptions& options) {
  AteResult result;
  const auto gt_by_stamp = positionsByStamp(gt, &result.skipped_non_finite_gt);
  const auto est_by_stamp = positionsByStamp(est, &result.skipped_non_finite_est);
  if (gt_by_stamp.empty() || est_by_stamp.empty()) {
    result.error = "no usable poses in '" + (gt_by_stamp.empty() ? gt.name : est.name) + "'";
    return result;
  }
  std::vector<double> gt_stamps, est_stamps;
  for (const auto& kv : gt_by_stamp) gt_stamps.push_back(kv.first);
  for (const auto& kv : est_by_stamp) est_stamps.push_back(kv.first);
  const std::vector<StampMatch> matches =
      associateStamps(gt_stamps, est_stamps, options.association);
  if (matches.size() < 2) {
    const std::string tol = formatSeconds(options.association.max_difference_s);
    result.error = matches.empty()
                       ? "no pose pairs within " + tol + " s: are the stamps in the same clock?"
                       : "only 1 pose pair within " + tol +
                             " s (need at least 2): are the stamps in the same clock?";
    return result;
  }
  const Eigen::Index n = static_cast<Eigen::Index>(matches.size());
  Eigen::Matrix3Xd model(3, n), data(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const TumRow* g = gt_by_stamp.at(matches[static_cast<std::size_t>(i)].first_s);
    const TumRow* e = est_by_stamp.at(matches[static_cast<std::size_t>(i)].second_s);
    data.col(i) << g->values[0], g->values[1], g->values[2];
    model.col(i) << e->values[0], e->values[1], e->values[2];
  }
  const HornAlignment alignment = alignHorn(model, data);
  result.R_gt_est = alignment.R_data_model;
  result.t_gt_est = alignment.t_data_model;
  result.pairs.resize(matches.size());
  for (Eigen::Index i = 0; i < n; ++i) {
    AtePair& p = result.pairs[static_cast<std::size_t>(i)];
    p.gt_stamp_s = matches[static_cast<std::size_t>(i)].first_s;
    p.est_stamp_s = matches[static_cast<std::size_t>(i)].second_s;
    p.p_gt_m = data.col(i);
    p.p_est_aligned_m = alignment.R_data_model * model.col(i) + alignment.t_data_model;
    p.error_m = alignment.errors_m[static_cast<std::size_t>(i)];
  }
  result.error_m = computeErrorStats(alignment.errors_m);
  result.ok = true;
  return result;
}

}  // namespace eval
}  // namespace pplvo
