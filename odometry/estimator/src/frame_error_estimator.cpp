#include "pplvo/estimator/frame_error_estimator.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "pplvo/estimator/pose_parameterisation.h"

namespace pplvo::estimator {

namespace {

/// A sample above this many times the median is clipped to it: a Gaussian 3-vector goes
/// beyond 10 x chi-square(3)'s median (23.7) with probability 3e-5, a wrong estimate (a
/// jump of centimetres) easily; one must not set the error of the whole window.
constexpr double kClipTimesMedian = 10.0;
/// Sum of the squared coefficients of e_k - 3 e_{k-1} + 3 e_{k-2} - e_{k-3}.
constexpr double kThirdDifferenceGain = 20.0;
/// Motions against a held reference: the published C of a motion should be 2 W, and
/// E|d|^2 / 3 = 20 W, so C + 2 sigma^2 = 2 W takes 20 / 2 = 10 mean C off E|d|^2 / 3.
constexpr double kHeldReferenceGain = kThirdDifferenceGain / 2.0;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

double mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

/// The mean of `v` with every value above kClipTimesMedian times its median clipped.
double clippedMean(const std::vector<double>& v) {
  const double cap = kClipTimesMedian * median(v);
  double sum = 0.0;
  for (double x : v) sum += std::min(x, cap);
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

}  // namespace

FrameErrorEstimator::FrameErrorEstimator(int window_samples, int min_samples)
    : window_samples_(std::max(1, window_samples)),
      min_samples_(std::clamp(min_samples, 1, std::max(1, window_samples))) {}

void FrameErrorEstimator::addMeasuredMotion(const Pose3& T_prev_curr, const Matrix6d& covariance,
                                            std::optional<int64_t> held_reference) {
  if (!T_prev_curr.matrix().allFinite() || !covariance.allFinite()) {
    addGap();
    return;
  }
  Motion motion;
  motion.m = motionToVector(T_prev_curr);
  // The rotation vector is twice q_xyz to first order: 4 times its variance.
  motion.var_t = covariance.topLeftCorner<3, 3>().trace() / 3.0;
  motion.var_r = 4.0 * covariance.bottomRightCorner<3, 3>().trace() / 3.0;
  motion.held_reference = held_reference;
  motions_.push_back(motion);
  if (motions_.size() > 3) motions_.pop_front();
  if (motions_.size() < 3) return;
  const Motion& a = motions_[0];
  const Motion& b = motions_[1];
  const Motion& c = motions_[2];
  const Vector6d d = c.m - 2.0 * b.m + a.m;
  Sample s;
  s.d_t_sq = d.head<3>().squaredNorm();
  s.d_r_sq = d.tail<3>().squaredNorm();
  if (a.held_reference && a.held_reference == b.held_reference &&
      b.held_reference == c.held_reference) {
    // Differences of estimates against one reference: take off what makes the published
    // C + 2 sigma^2 the motions' whole white error, 10 times their mean C (header).
    s.noise_t = kHeldReferenceGain * (a.var_t + b.var_t + c.var_t) / 3.0;
    s.noise_r = kHeldReferenceGain * (a.var_r + b.var_r + c.var_r) / 3.0;
  } else {
    // Independent motion errors: C_k + 4 C_{k-1} + C_{k-2}.
    s.noise_t = c.var_t + 4.0 * b.var_t + a.var_t;
    s.noise_r = c.var_r + 4.0 * b.var_r + a.var_r;
  }
  samples_.push_back(s);
  while (static_cast<int>(samples_.size()) > window_samples_) samples_.pop_front();
  sigma_ = estimate();
}

void FrameErrorEstimator::addGap() { motions_.clear(); }

FrameErrorSigma FrameErrorEstimator::estimate() const {
  FrameErrorSigma out;
  if (samples_.empty()) return out;
  std::vector<double> dt, dr, nt, nr;
  dt.reserve(samples_.size());
  dr.reserve(samples_.size());
  nt.reserve(samples_.size());
  nr.reserve(samples_.size());
  for (const Sample& s : samples_) {
    dt.push_back(s.d_t_sq);
    dr.push_back(s.d_r_sq);
    nt.push_back(s.noise_t);
    nr.push_back(s.noise_r);
  }
  const double excess_t = clippedMean(dt) / 3.0 - mean(nt);
  const double excess_r = clippedMean(dr) / 3.0 - mean(nr);
  out.t_m = std::sqrt(std::max(0.0, excess_t / kThirdDifferenceGain));
  out.rot_rad = std::sqrt(std::max(0.0, excess_r / kThirdDifferenceGain));
  return out;
}

}  // namespace pplvo::estimator
