#pragma once
/// The keyframe and its landmarks: the data that frames are tracked against, apart from the
/// rules that decide when a keyframe is taken (keyframe_rule.h) and how a frame is tracked
/// (frame_tracker.h). docs/estimator.md, "Keyframes" and "Keyframe landmarks".
///
/// The store holds the active keyframe: its 3D features (points, lines and planes lifted on
/// its fused depth, each with its covariance), its world pose, and what the first frame
/// tracked against it achieved. Landmark fusion refines its points with the observations of
/// later frames. It is the home a windowed local map grows into (several keyframes, queries by
/// covisibility).
///
/// Thread safety: none. One owner (the FrameTracker) uses it from one thread.
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "pplvo/core/features.h"
#include "pplvo/core/geometry.h"

namespace pplvo::tracking {

/// A frame tracked against the active keyframe, as an observation of its landmarks: the
/// frame's pose in the keyframe with its covariance, and which of the frame's points matched
/// which landmark. It is fused once the frame's own 3D points (lifted on its fused depth) are in.
struct KeyframeObservation {
  int64_t seq = -1;  ///< the observing frame
  Pose3 T_kf_frame = Pose3::Identity();
  Matrix6d covariance = Matrix6d::Zero();   ///< of xi(T_kf_frame)
  std::vector<std::pair<int, int>> points;  ///< (landmark index, frame point index)
};

/// What the first frame tracked against a keyframe achieved; the keyframe rule compares every
/// later frame with it (keyframe_rule.h).
struct KeyframeBaseline {
  int rows = 0;      ///< inlier residual rows
  double var_t = 0;  ///< largest translation variance, robust scale removed (m^2)
  double var_q = 0;  ///< largest rotation (q_xyz) variance, robust scale removed
};

struct Keyframe {
  FrameFeatures landmarks;  ///< 3D features in the keyframe's camera frame (points fused)
  Pose3 T_w_kf = Pose3::Identity();
  /// Unset until a frame was tracked against the keyframe and kept tracking.
  std::optional<KeyframeBaseline> baseline;
  int64_t seq() const { return landmarks.seq; }
};

class KeyframeStore {
 public:
  /// Makes `landmarks` (a frame's 3D stage), at world pose `T_w_kf`, the active keyframe.
  void insert(FrameFeatures landmarks, const Pose3& T_w_kf);
  /// No active keyframe (tracking restarts, or the keyframe failed).
  void clear() { active_.reset(); }
  /// Forgets everything, the count of keyframes included.
  void reset();

  const Keyframe* active() const { return active_ ? &*active_ : nullptr; }
  /// The active keyframe's sequence number, if there is one.
  std::optional<int64_t> activeSeq() const;
  /// Keyframes inserted since construction or reset().
  int64_t insertedCount() const { return inserted_; }

  /// Sets the active keyframe's baseline (no-op without one).
  void setBaseline(const KeyframeBaseline& baseline);

  /// Fuses the points of `observed` (the 3D stage of observation.seq) into the active
  /// keyframe's landmarks they were matched to: each observation is moved into the keyframe
  /// by T_kf_frame, the pose's uncertainty added to first order, and fused by information
  /// weighting when its squared Mahalanobis distance to the landmark is below `gate_chi2`
  /// (3 dof). Returns the number of landmarks fused. No-op without an active keyframe.
  int fuse(const KeyframeObservation& observation, const FrameFeatures& observed, double gate_chi2);

 private:
  std::optional<Keyframe> active_;
  int64_t inserted_ = 0;
};

}  // namespace pplvo::tracking
