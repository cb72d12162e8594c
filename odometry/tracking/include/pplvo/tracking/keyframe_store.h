#pragma once
/// The keyframe and its landmarks: the data that frames are tracked against, apart from the
/// rules that decide when a keyframe is taken (keyframe_rule.h) and how a frame is tracked
/// (frame_tracker.h). docs/estimator.md, "Keyframes", "Returns to an earlier place" and
/// "Keyframe landmarks".
///
/// The store holds the active keyframe: its 3D features (points, lines and planes lifted on
/// its fused depth, each with its covariance), its world pose, and what the first frame
/// tracked against it achieved. Landmark fusion refines its points with the observations of
/// later frames. The keyframes it replaced are kept, bounded, unchanged, so that the tracker
/// can make one active again when the camera returns ("Returns to an earlier place").
///
/// Thread safety: none. One owner (the FrameTracker) uses it from one thread.
#include <cstdint>
#include <deque>
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
  /// Whether its 3D features were moved to their stamp (rolling shutter): a frame is tracked
  /// against it at its own stamp only then.
  bool at_stamp = false;
  int64_t seq() const { return landmarks.seq; }
};

class KeyframeStore {
 public:
  /// Keeps up to `max_retired` keyframes after they were replaced (0: none), oldest dropped
  /// first: a camera that returns can be tracked against them again.
  explicit KeyframeStore(int max_retired = 0) : max_retired_(max_retired) {}

  /// Makes `landmarks` (a frame's 3D stage), at world pose `T_w_kf`, the active keyframe; the
  /// one it replaces is retired if a frame was tracked against it (it has a baseline).
  void insert(FrameFeatures landmarks, const Pose3& T_w_kf, bool at_stamp = false);
  /// No active keyframe (the keyframe failed); it is retired as insert() does.
  void clear();
  /// Forgets everything, the retired keyframes and the count of keyframes included.
  void reset();
  /// Forgets the retired keyframes (tracking restarts: the world poses of what came before
  /// are not related to what comes next).
  void forgetRetired() { retired_.clear(); }

  /// Keyframes replaced earlier, oldest first; their world poses never change.
  const std::deque<Keyframe>& retired() const { return retired_; }
  /// Makes the retired keyframe `seq` active again, the active one retired in its place.
  /// False (nothing changed) if there is no such retired keyframe.
  bool reactivate(int64_t seq);

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
  void retireActive();

  std::optional<Keyframe> active_;
  std::deque<Keyframe> retired_;
  int max_retired_ = 0;
  int64_t inserted_ = 0;
};

}  // namespace pplvo::tracking
