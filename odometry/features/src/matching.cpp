#include "pplvo/features/matching.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/core/hal/hal.hpp>

namespace pplvo::features {

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Distance between two descriptor rows (Hamming bits or L2).
struct DescriptorDistance {
  const cv::Mat& a;
  const cv::Mat& b;
  bool binary;
  int bytes;
  int floats;

  DescriptorDistance(const cv::Mat& a_, const cv::Mat& b_)
      : a(a_), b(b_), binary(a_.type() == CV_8U), bytes(a_.cols), floats(a_.cols) {}

  double operator()(int i, int j) const {
    if (binary) {
      // OpenCV's, dispatched to the CPU's popcount and SIMD at run time (a baseline x86-64
      // build of __builtin_popcountll calls a library routine per word).
      return cv::hal::normHamming(a.ptr<uint8_t>(i), b.ptr<uint8_t>(j), bytes);
    }
    const float* pa = a.ptr<float>(i);
    const float* pb = b.ptr<float>(j);
    double s = 0;
    for (int k = 0; k < floats; ++k) {
      const double d = pa[k] - pb[k];
      s += d * d;
    }
    return std::sqrt(s);
  }
};

bool descriptorsCompatible(const cv::Mat& a, int na, const cv::Mat& b, int nb) {
  if (a.empty() || b.empty() || na == 0 || nb == 0) return false;
  if (a.type() != b.type() || a.cols != b.cols) return false;
  if (a.type() != CV_8U && a.type() != CV_32F) return false;
  return a.rows == na && b.rows == nb;
}

struct BestPair {
  int j = -1;
  double d1 = std::numeric_limits<double>::infinity();
  double d2 = std::numeric_limits<double>::infinity();
};

/// Generic gated mutual-best matcher. candidates(i, fn) calls fn(j) for every current feature j
/// geometrically admissible for query i.
template <typename Candidates>
MatchResult gatedMatch(int n_prev, const cv::Mat& d_prev, int n_curr, const cv::Mat& d_curr,
                       bool ratio_test, double ratio, double max_distance, bool cross_check,
                       const Candidates& candidates) {
  MatchResult r;
  if (!descriptorsCompatible(d_prev, n_prev, d_curr, n_curr)) {
    r.stats.queries = (d_prev.rows == n_prev) ? n_prev : 0;
    r.stats.no_candidate = r.stats.queries;
    return r;
  }
  const DescriptorDistance dist(d_prev, d_curr);
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::vector<double> best_prev_d(n_curr, kInf);
  std::vector<int> best_prev_i(n_curr, -1);
  std::vector<BestPair> best(n_prev);
  r.stats.queries = n_prev;
  for (int i = 0; i < n_prev; ++i) {
    BestPair& b = best[i];
    candidates(i, [&](int j) {
      ++r.stats.candidates;
      const double d = dist(i, j);
      if (d < b.d1) {
        b.d2 = b.d1;
        b.d1 = d;
        b.j = j;
      } else if (d < b.d2) {
        b.d2 = d;
      }
      if (d < best_prev_d[j]) {
        best_prev_d[j] = d;
        best_prev_i[j] = i;
      }
    });
  }
  for (int i = 0; i < n_prev; ++i) {
    const BestPair& b = best[i];
    if (b.j < 0) {
      ++r.stats.no_candidate;
      continue;
    }
    if (max_distance >= 0 && b.d1 > max_distance) {
      ++r.stats.rejected_distance;
      continue;
    }
    if (ratio_test && std::isfinite(b.d2) && !(b.d1 < ratio * b.d2)) {
      ++r.stats.rejected_ratio;
      continue;
    }
    if (cross_check && best_prev_i[b.j] != i) {
      ++r.stats.rejected_cross_check;
      continue;
    }
    r.pairs.emplace_back(i, b.j);
    r.descriptor_distance.push_back(static_cast<float>(b.d1));
  }
  // Without cross-check, still enforce one-to-one on the current side: keep the best.
  if (!cross_check) {
    std::vector<int> owner(n_curr, -1);
    for (int k = 0; k < static_cast<int>(r.pairs.size()); ++k) {
      int& o = owner[r.pairs[k].second];
      if (o < 0 || r.descriptor_distance[k] < r.descriptor_distance[o]) o = k;
    }
    MatchResult kept;
    kept.stats = r.stats;
    for (int k = 0; k < static_cast<int>(r.pairs.size()); ++k) {
      if (owner[r.pairs[k].second] == k) {
        kept.pairs.push_back(r.pairs[k]);
        kept.descriptor_distance.push_back(r.descriptor_distance[k]);
      } else {
        ++kept.stats.rejected_cross_check;
      }
    }
    r = std::move(kept);
  }
  r.stats.matches = static_cast<int>(r.pairs.size());
  return r;
}

}  // namespace

int descriptorNormOf(const cv::Mat& descriptors) {
  return descriptors.type() == CV_32F ? cv::NORM_L2 : cv::NORM_HAMMING;
}

MatchResult matchPoints(const std::vector<PointFeature>& prev_points,
                        const cv::Mat& prev_descriptors,
                        const std::vector<PointFeature>& curr_points,
                        const cv::Mat& curr_descriptors, const PointMatchOptions& options,
                        const std::vector<Eigen::Vector2d>& predicted_px) {
  const int n_prev = static_cast<int>(prev_points.size());
  const int n_curr = static_cast<int>(curr_points.size());
  const bool use_pred = static_cast<int>(predicted_px.size()) == n_prev;
  // Per query: centre and squared radius of its gate.
  std::vector<Eigen::Vector2d> centre(n_prev);
  std::vector<double> r2(n_prev);
  for (int i = 0; i < n_prev; ++i) {
    const bool pred_ok = use_pred && predicted_px[i].allFinite();
    centre[i] = pred_ok ? predicted_px[i] : prev_points[i].px;
    const double r = pred_ok ? options.predicted_max_px_distance : options.max_px_distance;
    r2[i] = r * r;
  }
  // Bucket the current points on a grid of cells as large as the largest gate radius, so each
  // query only looks at the 3x3 cells around its gate centre.
  const double cell = std::max(1.0, std::max(options.max_px_distance,
                                             use_pred ? options.predicted_max_px_distance : 0.0));
  double min_u = 0, min_v = 0, max_u = 0, max_v = 0;
  bool finite = n_curr > 0;
  for (int j = 0; j < n_curr; ++j) {
    const Eigen::Vector2d& q = curr_points[j].px;
    if (!q.allFinite()) {
      finite = false;
      break;
    }
    if (j == 0 || q.x() < min_u) min_u = q.x();
    if (j == 0 || q.y() < min_v) min_v = q.y();
    if (j == 0 || q.x() > max_u) max_u = q.x();
    if (j == 0 || q.y() > max_v) max_v = q.y();
  }
  const int gc = finite ? std::min(4096, static_cast<int>((max_u - min_u) / cell) + 1) : 1;
  const int gr = finite ? std::min(4096, static_cast<int>((max_v - min_v) / cell) + 1) : 1;
  std::vector<std::vector<int>> grid(static_cast<size_t>(gc) * gr);
  const auto cellOf = [&](double u, double v, int* cu, int* cv) {
    *cu = std::clamp(static_cast<int>(std::floor((u - min_u) / cell)), -1, gc);
    *cv = std::clamp(static_cast<int>(std::floor((v - min_v) / cell)), -1, gr);
  };
  if (finite) {
    for (int j = 0; j < n_curr; ++j) {
      int cu, cv;
      cellOf(curr_points[j].px.x(), curr_points[j].px.y(), &cu, &cv);
      grid[std::clamp(cv, 0, gr - 1) * gc + std::clamp(cu, 0, gc - 1)].push_back(j);
    }
  }
  const auto candidates = [&](int i, const auto& fn) {
    if (!finite) {  // NaN pixels: fall back to testing every pair
      for (int j = 0; j < n_curr; ++j) {
        if ((curr_points[j].px - centre[i]).squaredNorm() < r2[i]) fn(j);
      }
      return;
    }
    if (!centre[i].allFinite()) return;
    int cu, cv;
    cellOf(centre[i].x(), centre[i].y(), &cu, &cv);
    for (int y = std::max(0, cv - 1); y <= std::min(gr - 1, cv + 1); ++y) {
      for (int x = std::max(0, cu - 1); x <= std::min(gc - 1, cu + 1); ++x) {
        for (int j : grid[y * gc + x]) {
          if ((curr_points[j].px - centre[i]).squaredNorm() < r2[i]) fn(j);
        }
      }
    }
  };
  const bool binary = prev_descriptors.type() == CV_8U;
  const double max_d = binary ? options.max_hamming_bits : options.max_l2;
  return gatedMatch(n_prev, prev_descriptors, n_curr, curr_descriptors, options.ratio_test,
                    options.ratio, max_d, options.cross_check, candidates);
}

MatchResult matchPoints(const FrameFeatures& prev, const FrameFeatures& curr,
                        const PointMatchOptions& options,
                        const std::vector<Eigen::Vector2d>& predicted_px) {
  return matchPoints(prev.points, prev.point_descriptors, curr.points, curr.point_descriptors,
                     options, predicted_px);
}

void lineHessian(const Eigen::Vector3d& eq, double* theta_rad, double* rho_px) {
  *theta_rad = std::atan2(eq.y(), eq.x());
  *rho_px = -eq.z();
}

namespace {

/// A line's Hessian form (lineHessian), and that of its negated equation.
struct HessianPair {
  double theta, rho, theta_negated, rho_negated;
};

HessianPair hessianPair(const Eigen::Vector3d& eq) {
  HessianPair h;
  lineHessian(eq, &h.theta, &h.rho);
  lineHessian(Eigen::Vector3d(-eq), &h.theta_negated, &h.rho_negated);
  return h;
}

/// lineGate with both lines' Hessian forms computed beforehand (the same arithmetic).
bool lineGate(const Eigen::Vector3d& eq_prev, double theta_prev, double rho_prev,
              const Eigen::Vector3d& eq_curr, const HessianPair& curr, double max_angle_deg,
              double max_rho_px) {
  // Orient the current equation like the previous one: (a, b) and -(a, b) are the same line.
  const double dot = eq_prev.x() * eq_curr.x() + eq_prev.y() * eq_curr.y();
  const double t1 = dot >= 0 ? curr.theta : curr.theta_negated;
  const double r1 = dot >= 0 ? curr.rho : curr.rho_negated;
  double dt = std::abs(t1 - theta_prev);
  if (dt > kPi) dt = 2 * kPi - dt;
  return dt * 180.0 / kPi < max_angle_deg && std::abs(r1 - rho_prev) < max_rho_px;
}

}  // namespace

bool lineGate(const Eigen::Vector3d& eq_prev, const Eigen::Vector3d& eq_curr,
              double max_angle_deg, double max_rho_px) {
  double t0, r0;
  lineHessian(eq_prev, &t0, &r0);
  return lineGate(eq_prev, t0, r0, eq_curr, hessianPair(eq_curr), max_angle_deg, max_rho_px);
}

MatchResult matchLines(const std::vector<LineFeature>& prev_lines,
                       const cv::Mat& prev_descriptors,
                       const std::vector<LineFeature>& curr_lines,
                       const cv::Mat& curr_descriptors, const LineMatchOptions& options) {
  const int n_curr = static_cast<int>(curr_lines.size());
  // Every pair is gated: the angles once per line, not twice per pair (atan2 was 1-2 % of a
  // run's CPU).
  std::vector<HessianPair> curr_h(curr_lines.size());
  for (size_t j = 0; j < curr_lines.size(); ++j) curr_h[j] = hessianPair(curr_lines[j].eq);
  const auto candidates = [&](int i, const auto& fn) {
    double t0, r0;
    lineHessian(prev_lines[i].eq, &t0, &r0);
    for (int j = 0; j < n_curr; ++j) {
      if (lineGate(prev_lines[i].eq, t0, r0, curr_lines[j].eq, curr_h[static_cast<size_t>(j)],
                   options.max_angle_deg, options.max_rho_px))
        fn(j);
    }
  };
  return gatedMatch(static_cast<int>(prev_lines.size()), prev_descriptors, n_curr,
                    curr_descriptors, options.ratio_test, options.ratio,
                    options.max_hamming_bits, options.cross_check, candidates);
}

MatchResult matchLines(const FrameFeatures& prev, const FrameFeatures& curr,
                       const LineMatchOptions& options) {
  return matchLines(prev.lines, prev.line_descriptors, curr.lines, curr.line_descriptors,
                    options);
}

}  // namespace pplvo::features
