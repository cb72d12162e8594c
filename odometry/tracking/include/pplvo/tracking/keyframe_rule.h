#pragma once
/// When a new keyframe is taken (docs/estimator.md, "Keyframes"): a predicate on an accepted
/// estimate against the active keyframe, compared with what the first frame tracked against
/// that keyframe achieved (its KeyframeBaseline).
#include <cstdint>

#include "pplvo/core/config_schema.h"
#include "pplvo/estimator/pose_estimator.h"
#include "pplvo/tracking/keyframe_store.h"

namespace pplvo::tracking {

/// The current frame becomes the keyframe of the next one when any of these holds.
struct KeyframeOptions {
  /// Feature overlap: the estimate against the keyframe kept fewer inlier residual rows than
  /// this fraction of the rows the first frame tracked against it kept (the keyframe's view
  /// is leaving the image, or its features no longer match).
  double min_inlier_fraction = 0.5;
  /// Uncertainty: the largest eigenvalue of the translation (or q_xyz) block of the pose
  /// covariance relative to the keyframe grew beyond this factor of the first frame's; a
  /// new keyframe then restarts from the smaller frame-to-frame uncertainty.
  double max_variance_growth = 2.0;
  /// Parallax bound: translation (m) and rotation (deg) from the keyframe; beyond either,
  /// depth errors of the keyframe's primitives weigh more than a keyframe change costs.
  double max_translation_m = 0.3;
  double max_rotation_deg = 20.0;
  /// The keyframe's 3D points are refined by every later frame tracked against it: the
  /// frame's own 3D point (lifted on its fused depth), moved into the keyframe by the
  /// estimated pose (its covariance included), is fused by information weighting when it
  /// passes the chi-square gate below (docs/estimator.md, "Keyframe landmarks").
  bool fuse_landmarks = true;
  /// Gate on the squared Mahalanobis distance between the keyframe point and the moved
  /// observation (3 dof; 7.81 = 95 %).
  double fusion_gate_chi2 = 7.81;
  /// Keyframes kept after they were replaced (reference: keyframe), oldest dropped first.
  /// When the active keyframe is exhausted, the nearest of them that still serves the frame
  /// (the rules above, against its own first frame) becomes active again instead of a new
  /// keyframe: a camera that returns is tracked against what it measured there before, and
  /// the error of the keyframes taken since does not stay in its pose. 0: none kept.
  /// About 0.5 MB each at VGA (the plane labels are most of it).
  int retired_keyframes = 128;
};

/// Schema of KeyframeOptions (pplvo/core/config_schema.h): names, docs and ranges, once.
template <class V>
void visit(V& v, KeyframeOptions& o) {
  v.field("min_inlier_fraction", o.min_inlier_fraction,
          "new keyframe when the inlier rows against it fall below this fraction of the first "
          "frame's (feature overlap)",
          config::between(0, 1));
  v.field("max_variance_growth", o.max_variance_growth,
          "new keyframe when the pose variance relative to it grows beyond this factor of the "
          "first frame's (largest eigenvalue, translation or rotation block)",
          config::atLeast(1));
  v.field("max_translation_m", o.max_translation_m, "new keyframe beyond this translation (m)",
          config::positive());
  v.field("max_rotation_deg", o.max_rotation_deg, "new keyframe beyond this rotation (deg)",
          config::openClosed(0, 180));
  v.field("fuse_landmarks", o.fuse_landmarks,
          "refine the keyframe's 3D points with every frame tracked against it (information "
          "weighting, chi-square gate)");
  v.field("fusion_gate_chi2", o.fusion_gate_chi2,
          "gate on the squared Mahalanobis distance of an observation (3 dof; 7.81 = 95 %)",
          config::positive());
  v.field("retired_keyframes", o.retired_keyframes,
          "keyframes kept after they were replaced (reference: keyframe); when the active one "
          "is exhausted, the nearest of them that still serves the frame becomes active again "
          "instead of a new keyframe (a return to an earlier place); 0: none",
          config::between(0, 4096));
}

/// Why a frame was chosen as the next keyframe.
enum class KeyframeReason : int8_t {
  kNone = 0,
  kStart,        ///< first frame, or tracking restarted / not tracking
  kFallback,     ///< the keyframe's estimate failed
  kOverlap,      ///< inlier rows below min_inlier_fraction of the first frame's
  kUncertainty,  ///< pose variance grew beyond max_variance_growth
  kMotion,       ///< translation or rotation bound
};
constexpr int kKeyframeReasons = 6;
const char* toString(KeyframeReason reason);

/// The baseline a keyframe's first tracked frame sets (its rows and geometric variances).
KeyframeBaseline keyframeBaseline(const estimator::PoseEstimate& first_against_keyframe);

/// Whether the keyframe is exhausted for the next frame, given an accepted estimate against
/// it (`T_curr_kf` its pose) and the keyframe's baseline; kNone if it still serves.
KeyframeReason keyframeExhausted(const KeyframeOptions& options, const KeyframeBaseline& baseline,
                                 const estimator::PoseEstimate& against_keyframe, const Pose3& T_curr_kf);

}  // namespace pplvo::tracking
