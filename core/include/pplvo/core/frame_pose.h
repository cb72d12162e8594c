#pragma once
/// The pose of one frame as the pipeline publishes it (library-neutral; pose_t on the wire).
#include <cstdint>
#include <string>
#include <vector>

#include "pplvo/core/geometry.h"

namespace pplvo {

enum class TrackingStatus : int8_t {
  kFirstFrame = 0,
  kTracking = 1,
  kVelocityModel = 2,  ///< estimate rejected; decaying constant-velocity model used
  kLost = 3,           ///< velocity model exhausted; pose held
  kReinitialised = 4,  ///< first good estimate after kLost
};
const char* toString(TrackingStatus status);

/// How many poses had each status (the estimator node and pplvo-run count the same way).
struct TrackingStatusCounts {
  int64_t first = 0, tracking = 0, velocity_model = 0, lost = 0, reinitialised = 0;
  void add(TrackingStatus status);
};

/// Whether later frames are tracked against a frame's 3D features (pose_t.reference).
enum class ReferenceRole : int8_t {
  kUnknown = 0,       ///< not said: treated as kReference
  kReference = 1,     ///< a new keyframe, or every frame when tracking frame to frame
  kFallbackOnly = 2,  ///< used only if the next frame cannot be tracked against the keyframe
};

/// Transform uncertainty from an earlier frame to this one (paper eq. 24).
struct WindowUncertainty {
  int64_t seq = 0;
  double max_translation_variance_m2 = 0.0;
};

struct FramePose {
  int64_t utime = 0;
  int64_t seq = 0;
  std::string stamp;
  TrackingStatus status = TrackingStatus::kFirstFrame;
  Pose3 T_w_c = Pose3::Identity();
  Pose3 T_prev_curr = Pose3::Identity();
  Matrix6d rel_covariance = Matrix6d::Zero();  ///< over xi = [t; q_xyz] of T_prev_curr
  /// The part of rel_covariance that is the per-frame shared error of the two frames, which
  /// does not accumulate along a chain of motions (not in pose_t: zero when decoded).
  Matrix6d frame_error_covariance = Matrix6d::Zero();
  double max_translation_variance_m2 = 0.0;
  int n_point_matches = 0, n_line_matches = 0, n_plane_matches = 0;
  int iterations = 0;
  double final_cost = 0.0;
  ReferenceRole reference = ReferenceRole::kUnknown;
  std::vector<WindowUncertainty> window;
};

}  // namespace pplvo
