#include "pplvo/estimator/frame_error_estimator.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Eigenvalues>

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

const char* FrameErrorSource::describe() const {
  if (online()) return "estimated online";
  if (translation_online) return "translation estimated online, rotation configured";
  if (rotation_online) return "rotation estimated online, translation configured";
  return "configured";
}

FrameErrorEstimator::FrameErrorEstimator(int window_samples, int min_samples)
    : window_samples_(std::max(1, window_samples)),
      min_samples_(std::clamp(min_samples, 1, std::max(1, window_samples))) {}

void FrameErrorEstimator::addMeasuredMotion(const Pose3& T_prev_curr, const Matrix6d& covariance,
                                            std::optional<int64_t> held_reference,
                                            MeasuredDirections measured) {
  if (!T_prev_curr.matrix().allFinite() || !covariance.allFinite()) {
    addGap();
    return;
  }
  const Vector6d m = motionToVector(T_prev_curr);  // [t; rotation vector]
  const BlockMotion t{m.head<3>(), covariance.topLeftCorner<3, 3>(),
                      measured.translation_max_variance, held_reference};
  // The rotation vector is twice q_xyz to first order: 4 times its variance.
  const BlockMotion r{m.tail<3>(), 4.0 * covariance.bottomRightCorner<3, 3>(),
                      4.0 * measured.rotation_max_variance, held_reference};
  if (translation_.add(t, window_samples_)) sigma_.t_m = translation_.sigma();
  if (rotation_.add(r, window_samples_)) sigma_.rot_rad = rotation_.sigma();
}

void FrameErrorEstimator::addGap() {
  translation_.gap();
  rotation_.gap();
}

bool FrameErrorEstimator::Block::add(const BlockMotion& motion, int window_samples) {
  if (!std::isinf(motion.max_variance) &&
      !(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(motion.cov, Eigen::EigenvaluesOnly)
            .eigenvalues()(0) <= motion.max_variance)) {
    gap();  // nothing of this block was measured
    return false;
  }
  motions_.push_back(motion);
  if (motions_.size() > 3) motions_.pop_front();
  if (motions_.size() < 3) return false;
  const BlockMotion& a = motions_[0];
  const BlockMotion& b = motions_[1];
  const BlockMotion& c = motions_[2];
  const Eigen::Vector3d d = c.m - 2.0 * b.m + a.m;
  // Per-axis variances of the three motions, over the directions all three measured.
  double var_a = a.cov.trace() / 3.0, var_b = b.cov.trace() / 3.0, var_c = c.cov.trace() / 3.0;
  Sample s;
  if (std::isinf(a.max_variance) && std::isinf(b.max_variance) && std::isinf(c.max_variance)) {
    s.d_sq = d.squaredNorm();
  } else {
    // The newest motion's measured directions that the two before measured as well.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(c.cov);
    int k = 0;
    double d_sq = 0.0;
    var_a = var_b = var_c = 0.0;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d v = es.eigenvectors().col(i);
      const double va = v.dot(a.cov * v), vb = v.dot(b.cov * v), vc = es.eigenvalues()(i);
      if (!(vc <= c.max_variance && va <= a.max_variance && vb <= b.max_variance)) continue;
      ++k;
      d_sq += v.dot(d) * v.dot(d);
      var_a += va;
      var_b += vb;
      var_c += vc;
    }
    if (k == 0) return false;  // the three share no measured direction: no sample
    s.d_sq = 3.0 * d_sq / k;  // as over three axes
    var_a /= k;
    var_b /= k;
    var_c /= k;
  }
  if (a.held_reference && a.held_reference == b.held_reference &&
      b.held_reference == c.held_reference) {
    // Differences of estimates against one reference: take off what makes the published
    // C + 2 sigma^2 the motions' whole white error, 10 times their mean C (header).
    s.noise = kHeldReferenceGain * (var_a + var_b + var_c) / 3.0;
  } else {
    // Independent motion errors: C_k + 4 C_{k-1} + C_{k-2}.
    s.noise = var_c + 4.0 * var_b + var_a;
  }
  samples_.push_back(s);
  while (static_cast<int>(samples_.size()) > window_samples) samples_.pop_front();
  return true;
}

double FrameErrorEstimator::Block::sigma() const {
  if (samples_.empty()) return 0.0;
  std::vector<double> d_sq, noise;
  d_sq.reserve(samples_.size());
  noise.reserve(samples_.size());
  for (const Sample& s : samples_) {
    d_sq.push_back(s.d_sq);
    noise.push_back(s.noise);
  }
  const double excess = clippedMean(d_sq) / 3.0 - mean(noise);
  return std::sqrt(std::max(0.0, excess / kThirdDifferenceGain));
}

}  // namespace pplvo::estimator
