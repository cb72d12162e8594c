#pragma once
/// The local map's policy (docs/estimator.md, "Local map"): when a keyframe is taken, its
/// points are associated with the landmarks of the keyframes around it, the recent keyframes
/// and their landmarks are adjusted together (local bundle adjustment), and the reference the
/// next frames are tracked against is rendered: every landmark of those keyframes in front of
/// the new keyframe, in its camera frame with its covariance, beside the keyframe's own lines
/// and planes. A frame is then tracked against many keyframes' landmarks through one
/// reference, with the estimator unchanged; returning to an earlier place brings that place's
/// landmarks back (keyframes near the new one join the window whatever their age).
///
/// Which keyframes move: the last `adjust_keyframes`; every other keyframe that observed one of
/// their landmarks is held fixed (the fixed lag, which is also the gauge). Each keyframe is tied
/// to the keyframe it was tracked against by tracking's measurement (a residual), so the
/// window's points refine the keyframes and cannot carry them where tracking says they are not. A keyframe that
/// leaves the window keeps its pose: its information is dropped, not marginalised, so nothing
/// in the window becomes more certain than its own observations make it (docs/estimator.md).
/// Thread safety: none; the FrameTracker owns it.
#include <cstdint>

#include "pplvo/core/config_schema.h"
#include "pplvo/core/features.h"
#include "pplvo/estimator/local_bundle_adjustment.h"
#include "pplvo/estimator/pose_estimator.h"
#include "pplvo/features/matching.h"
#include "pplvo/tracking/local_map.h"

namespace pplvo::tracking {

struct LocalMapOptions {
  /// The most recent keyframes whose landmarks a frame is tracked against.
  int track_keyframes = 5;
  /// Older keyframes that join them when near the new keyframe (a return to a place).
  int nearby_keyframes = 3;
  double nearby_distance_m = 0.5;
  double nearby_angle_deg = 30.0;
  /// The most recent keyframes adjusted by local bundle adjustment (the others held fixed);
  /// 2 from a sweep on the long suite (docs/estimator.md, "Local map").
  int adjust_keyframes = 2;
  int adjust_iterations = 8;
  /// Keyframes kept in the map (memory bound); the oldest leave first.
  int max_keyframes = 200;
  /// Association of a keyframe's points with the landmarks projected into it (pixels).
  double association_px = 8.0;
  /// A landmark's covariance in the keyframe it is tracked from: false, its observations'
  /// information with every keyframe pose taken as known; true, each observation carried in
  /// with its keyframe's pose uncertainty relative to that keyframe (the chain of tracking's
  /// relative poses). Measured on ten long seeds in docs/estimator.md ("Ten seeds").
  bool landmark_pose_uncertainty = false;
};

template <class V>
void visit(V& v, LocalMapOptions& o) {
  v.field("track_keyframes", o.track_keyframes,
          "recent keyframes whose landmarks a frame is tracked against", config::between(1, 50));
  v.field("nearby_keyframes", o.nearby_keyframes,
          "older keyframes near the new one that join them (a return to a place)",
          config::between(0, 50));
  v.field("nearby_distance_m", o.nearby_distance_m, "nearby: camera centres within (m)",
          config::atLeast(0));
  v.field("nearby_angle_deg", o.nearby_angle_deg, "nearby: viewing directions within (deg)",
          config::between(0, 180));
  v.field("adjust_keyframes", o.adjust_keyframes,
          "recent keyframes adjusted by local bundle adjustment (0: no adjustment)",
          config::between(0, 50));
  v.field("adjust_iterations", o.adjust_iterations, "Levenberg-Marquardt iterations",
          config::between(1, 100));
  v.field("max_keyframes", o.max_keyframes, "keyframes kept in the map (memory bound)",
          config::between(2, 100000));
  v.field("association_px", o.association_px,
          "gate of a keyframe point around a landmark's projection (px)", config::positive());
  v.field("landmark_pose_uncertainty", o.landmark_pose_uncertainty,
          "a landmark's covariance as tracked carries its keyframes' pose uncertainty relative "
          "to the new keyframe (false: their poses taken as known)");
}

/// What inserting a keyframe did.
struct KeyframeInsertion {
  Pose3 T_w_kf = Pose3::Identity();  ///< after adjustment
  /// The reference later frames are tracked against (points from the map, the keyframe's own
  /// lines and planes), in the keyframe's camera frame.
  FrameFeatures reference;
  int associated = 0;  ///< keyframe points matched to existing landmarks
  int new_points = 0;
  int window_keyframes = 0;
  int adjusted_keyframes = 0, fixed_keyframes = 0;
  int outliers_removed = 0;
  bool adjusted = false;
};

class LocalMapper {
 public:
  /// `pixel` gives the pixel noise of a keypoint (point_sigma_px, octave_sigma_scale).
  explicit LocalMapper(const LocalMapOptions& options = {},
                       const features::PointMatchOptions& matching = {},
                       const estimator::PoseEstimatorOptions& pixel = {});

  /// Adds `lifted` (a frame's 3D stage) at `T_w_kf` as a keyframe, adjusts the window and
  /// renders the reference for the next frames.
  /// `from_previous`: the keyframe's pose relative to an earlier keyframe as measured by lines
  /// and planes alone (bundle adjustment adjusts points; this brings the other features in).
  /// `tracked`: relative to the keyframe it was tracked against, as tracking measured it (every
  /// feature, with its covariance): a residual of the adjustment as well.
  KeyframeInsertion insert(const FrameFeatures& lifted, const Pose3& T_w_kf,
                           const std::optional<MapRelativePose>& from_previous = std::nullopt,
                           const std::optional<MapRelativePose>& tracked = std::nullopt);
  /// Forgets the map (tracking restarted).
  void reset() { map_.reset(); }

  const LocalMap& map() const { return map_; }

 private:
  /// Keyframes whose landmarks are associated and rendered around a keyframe at T_w_kf.
  std::vector<int64_t> window(const Pose3& T_w_kf) const;
  void adjust(KeyframeInsertion& out);
  FrameFeatures render(const FrameFeatures& lifted, const Pose3& T_w_kf,
                       const std::vector<int64_t>& window) const;

  LocalMapOptions options_;
  features::PointMatchOptions matching_;
  estimator::PoseEstimatorOptions pixel_;
  PinholeCamera camera_;  ///< of the keyframes (a change of camera restarts tracking)
  LocalMap map_;
};

}  // namespace pplvo::tracking
