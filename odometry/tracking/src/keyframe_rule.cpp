#include "pplvo/tracking/keyframe_rule.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "pplvo/core/enum_names.h"
#include "pplvo/estimator/pose_parameterisation.h"

namespace pplvo::tracking {

namespace {

constexpr EnumName<KeyframeReason> kKeyframeReasonNames[] = {
    {KeyframeReason::kNone, "none"},
    {KeyframeReason::kStart, "start"},
    {KeyframeReason::kFallback, "fallback"},
    {KeyframeReason::kOverlap, "overlap"},
    {KeyframeReason::kUncertainty, "uncertainty"},
    {KeyframeReason::kMotion, "motion"}};

/// A variance of an estimate without its frame's measured image noise: the covariance counts
/// the robust scale s^2 on the point and line terms (pose_estimator.h), which is the same for
/// an estimate against the keyframe and one against any other frame; the keyframe rule
/// compares what the geometry (overlap, parallax, depth of the landmarks) does to it.
double geometricVariance(const estimator::PoseEstimate& estimate, double variance) {
  const double s = std::max(1.0, estimate.robust_scale);
  return variance / (s * s);
}

}  // namespace

const char* toString(KeyframeReason reason) { return enumName(kKeyframeReasonNames, reason); }

KeyframeBaseline keyframeBaseline(const estimator::PoseEstimate& first_against_keyframe) {
  const estimator::PoseEstimate& e = first_against_keyframe;
  return {e.n_residuals, geometricVariance(e, e.max_translation_variance_m2),
          geometricVariance(e, e.max_rotation_variance)};
}

KeyframeReason keyframeExhausted(const KeyframeOptions& options, const KeyframeBaseline& baseline,
                                 const estimator::PoseEstimate& against_keyframe, const Pose3& T_curr_kf) {
  if (against_keyframe.n_residuals < options.min_inlier_fraction * baseline.rows) {
    return KeyframeReason::kOverlap;
  }
  const Matrix6d& cov = against_keyframe.covariance;
  const double var_t = geometricVariance(against_keyframe, maxTranslationVariance(cov));
  const double var_q = geometricVariance(against_keyframe, maxRotationVariance(cov));
  if (var_t > options.max_variance_growth * baseline.var_t ||
      var_q > options.max_variance_growth * baseline.var_q) {
    return KeyframeReason::kUncertainty;
  }
  const double angle_deg = Eigen::AngleAxisd(T_curr_kf.linear()).angle() * 180.0 / M_PI;
  if (T_curr_kf.translation().norm() > options.max_translation_m ||
      angle_deg > options.max_rotation_deg) {
    return KeyframeReason::kMotion;
  }
  return KeyframeReason::kNone;
}

}  // namespace pplvo::tracking
