#pragma once
/// Depth moved from the instant it was captured to the colour image's instant.
///
/// Free-running RGB-D sensors (Kinect v1 through libfreenect or OpenNI, TUM's fr1/fr2) capture
/// depth and colour up to half a frame apart: in TUM fr1_xyz the associated depth image is a
/// median 13 ms older than its colour image (range -17 to +17 ms). A hand-held camera moves
/// 3-5 mm in that time, and every 3D-3D measurement (planes, ICP) then measures the depth
/// camera's motion between two depth instants instead of the colour camera's between two colour
/// instants: on fr1 the per-frame error of plane-based (and of OpenCV's ICP) estimates follows
/// v (dt_depth_j - dt_depth_i) (docs/depth_filter.md, "Depth at the colour instant"). Features
/// are located in the colour image, so the depth is what has to move.
///
/// The motion over the offset is predicted from the camera's velocity (the last two tracked
/// poses, constant velocity as in the tracker), and the depth map is forward-warped with it:
/// each pixel's 3D point is moved into the colour camera, the nearest surface wins where two
/// land on one pixel, and one-pixel cracks between two near-equal neighbours are closed (a
/// continuous surface stretched by the motion); no depth is invented across a discontinuity.
/// Without a velocity (start, after a loss) or without an offset the depth is returned as is.
#include <cstdint>
#include <optional>
#include <vector>
#include <opencv2/core.hpp>

#include "pplvo/core/camera.h"
#include "pplvo/core/depth_time_alignment.h"
#include "pplvo/core/geometry.h"

namespace pplvo::depth_filter {

/// Depth (CV_32FC1, z along the optical axis, pinhole model of `camera`) seen from a camera
/// moved by `T_target_source` (maps points of the source camera into the target camera).
cv::Mat warpDepth(const PinholeCamera& camera, const cv::Mat& depth_m, const Pose3& T_target_source);

struct DepthTimeAlignmentStats {
  int64_t frames_aligned = 0;       ///< depth moved to the colour instant
  int64_t frames_without_velocity = 0;  ///< an offset but no velocity yet: left as captured
  double last_offset_ms = 0;        ///< depth minus colour instant of the last frame
};

/// The motion a frame's depth is moved by, and what it was computed from.
struct AlignmentMotion {
  Pose3 T_colour_depth = Pose3::Identity();
  DepthTimeAlignment alignment;  ///< the scale and the measured motion it scales
};

class DepthTimeAligner {
 public:
  /// The velocity for frame `seq` comes from the poses of frames `seq - kPoseLag - 1` and
  /// `seq - kPoseLag` (or the newest consecutive pair before them): in a lockstep pipeline with
  /// two frames in flight (pplvo-run's and pplvo-launch's default) those are the newest poses
  /// published before the frame (pplvo-depth-filter waits for the second when it is handled
  /// after the frame), so every layout uses the same motion.
  static constexpr int64_t kPoseLag = 2;

  /// True when a frame's depth was captured at another instant than its colour (depth_utime 0
  /// means the same instant): the frames this stage moves.
  static bool needed(int64_t colour_utime, int64_t depth_utime) {
    return depth_utime != 0 && depth_utime != colour_utime;
  }

  /// Largest |depth - colour| instant corrected; beyond it the frame is left as is (a pair
  /// that far apart is an association problem, not a sensor offset).
  explicit DepthTimeAligner(double max_offset_s = 0.05) : max_offset_s_(max_offset_s) {}

  /// The pose of frame `seq` at its colour instant. `tracked` false (lost, reinitialised)
  /// breaks the motion: no velocity spans it.
  void observePose(int64_t seq, int64_t colour_utime, const Pose3& T_w_c, bool tracked);

  /// T_colour_depth for frame `seq`, constant velocity; nullopt without a velocity.
  std::optional<AlignmentMotion> colourFromDepth(int64_t seq, int64_t colour_utime,
                                                 int64_t depth_utime) const;

  /// The motion that moves frame `seq`'s depth to its colour instant (T_colour_depth, counted
  /// in the stats as apply() counts it); nullopt when there is nothing to correct (no offset,
  /// an offset beyond max_offset_s, or no velocity yet). DepthRegistration composes it with
  /// the rig's extrinsics, so unregistered depth is moved once.
  std::optional<AlignmentMotion> motion(int64_t seq, int64_t colour_utime, int64_t depth_utime);

  /// `depth_m` of frame `seq` moved to the colour instant (itself when nothing to correct);
  /// `alignment`, when given, receives how (default: not moved).
  cv::Mat apply(const PinholeCamera& camera, const cv::Mat& depth_m, int64_t seq,
                int64_t colour_utime, int64_t depth_utime, DepthTimeAlignment* alignment = nullptr);

  /// True when the pose of frame `seq` was observed (and is still kept).
  bool hasPose(int64_t seq) const;

  void reset() { poses_.clear(); }
  const DepthTimeAlignmentStats& stats() const { return stats_; }

 private:
  struct KnownPose {
    int64_t seq;
    int64_t utime;
    Pose3 T_w_c;
    bool tracked;
  };
  double max_offset_s_;
  std::vector<KnownPose> poses_;  ///< the last few, by seq
  DepthTimeAlignmentStats stats_;
};

}  // namespace pplvo::depth_filter
