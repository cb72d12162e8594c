#pragma once
/// Peer odometry for benchmarking: OpenCV contrib's dense RGB-D odometries
/// (cv::rgbd::RgbdOdometry, ICPOdometry, RgbdICPOdometry) behind pplvo's frame and pose types.
/// No LCM, no I/O. See docs/peer_odometry.md for the conventions and measured figures.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo::peer {

/// Which OpenCV odometry runs.
enum class PeerMethod {
  kRgbd,     ///< cv::rgbd::RgbdOdometry: photometric, Steinbruecker et al. ICCV 2011
  kIcp,      ///< cv::rgbd::ICPOdometry: point-to-plane ICP on depth only
  kRgbdIcp,  ///< cv::rgbd::RgbdICPOdometry: both energies summed
};

/// "rgbd", "icp", "rgbd_icp".
const char* methodName(PeerMethod method);
/// Parses "rgbd", "icp" or "rgbd_icp"; returns false (and leaves *method alone) otherwise.
bool parseMethod(const std::string& text, PeerMethod* method);

/// What the pose of a frame whose motion could not be estimated is.
enum class FailurePolicy {
  /// The failed frame gets the pose of the last tracked frame (zero motion assumed).
  kHoldPose,
  /// The failed frame gets the last tracked pose moved on by the last estimated
  /// frame-to-frame motion times the frames elapsed (constant velocity).
  kConstantVelocity,
};

/// What each frame is registered to.
enum class ReferenceMode {
  /// The last tracked frame (frame to frame; the default, and the benchmark's original peer).
  kPreviousFrame,
  /// The current keyframe, as DVO and Fovis do: a frame becomes the keyframe when its motion
  /// from the keyframe passes keyframe_translation_m or keyframe_rotation_deg, or when it could
  /// be tracked only against the previous frame (docs/peer_odometry.md, "Keyframe mode").
  kKeyframe,
};

/// "previous_frame", "keyframe".
const char* referenceModeName(ReferenceMode mode);

/// How a mirrored camera model (fx < 0 and/or fy < 0, e.g. ICL-NUIM's fy = -480) is handed
/// to OpenCV.
enum class MirrorHandling {
  /// Flip the image rows (fy < 0) and/or columns (fx < 0) and pass |fx|, |fy| with
  /// cx' = W - 1 - cx, cy' = H - 1 - cy. Backprojection of the flipped image with the flipped
  /// camera gives exactly the same 3D points in the same camera frame, so OpenCV's motion needs
  /// no conversion. The default: OpenCV's pyramids, gradients and normals are only exercised
  /// with positive focal lengths.
  kFlipImage,
  /// Pass the signed camera matrix unchanged (for comparison; see docs/peer_odometry.md).
  kSignedMatrix,
};

/// Parameters. OpenCV's defaults unless stated (cv::rgbd::Odometry::DEFAULT_*()).
struct PeerOdometryOptions {
  PeerMethod method = PeerMethod::kRgbd;
  /// Depths at or below this are ignored, metres (OpenCV default 0; 0 = missing anyway).
  float min_depth_m = 0.0f;
  /// Depths at or above this are ignored, metres (OpenCV default 4 m; Kinect noise grows as
  /// z^2, paper eq. 1, so far depth carries little information).
  float max_depth_m = 4.0f;
  /// Correspondences whose depths differ more than this are rejected, metres (OpenCV 0.07).
  float max_depth_diff_m = 0.07f;
  /// Fraction of the valid pixels used per pyramid level, [0, 1] (OpenCV 0.07).
  float max_points_part = 0.07f;
  /// Iterations per pyramid level, finest first (empty: OpenCV's {7, 7, 7, 10}).
  std::vector<int> iter_counts;
  /// Minimum grey gradient magnitude per level for the photometric term (empty: OpenCV's
  /// {10, 10, 10, 10}); not used by kIcp.
  std::vector<float> min_gradient_magnitudes;
  /// Frame-to-frame motions larger than these are rejected as failures (OpenCV 0.15 m, 15 deg).
  double max_translation_m = 0.15;
  double max_rotation_deg = 15.0;
  /// Start OpenCV's iterations from the last estimated frame-to-frame motion (scaled by the
  /// frames elapsed since the reference) instead of the identity.
  bool use_motion_prior = true;
  /// A frame with fewer valid depth pixels (finite, inside (min, max) depth) fails at once
  /// without calling OpenCV.
  int min_valid_depth_pixels = 1000;
  FailurePolicy failure_policy = FailurePolicy::kHoldPose;
  /// After this many consecutive failures the reference frame is given up and the current
  /// frame (with its predicted pose) becomes the reference, so that tracking can restart.
  int max_consecutive_failures = 5;
  MirrorHandling mirror_handling = MirrorHandling::kFlipImage;
  ReferenceMode reference_mode = ReferenceMode::kPreviousFrame;
  /// kKeyframe: a tracked frame whose motion from the keyframe has a translation above this
  /// (metres) or a rotation above keyframe_rotation_deg (degrees) becomes the new keyframe.
  /// 0 makes every tracked frame a keyframe (the same poses as kPreviousFrame).
  double keyframe_translation_m = 0.10;
  double keyframe_rotation_deg = 10.0;
};

/// Outcome of one frame.
enum class PeerStatus {
  kFirst,         ///< first frame (or first usable after a reset): defines the world frame
  kOk,            ///< motion estimated by OpenCV
  kNoDepth,       ///< too few valid depth pixels in this frame or in the reference
  kNotConverged,  ///< OpenCV returned false (too few correspondences, motion too large, ...)
  kBadInput,      ///< empty image, sizes that disagree, invalid camera, wrong types
  kOpenCvError,   ///< cv::Exception thrown inside OpenCV (message kept)
};
const char* statusName(PeerStatus status);

/// Result of one frame.
struct PeerFrameResult {
  PeerStatus status = PeerStatus::kBadInput;
  bool ok() const { return status == PeerStatus::kOk || status == PeerStatus::kFirst; }
  /// Camera-to-world pose; world = first camera. On failure: the pose chosen by
  /// PeerOdometryOptions::failure_policy.
  Pose3 T_w_c = Pose3::Identity();
  /// Estimated motion from the reference frame to this one (T_ref_c); identity on failure.
  /// kKeyframe: the reference is the keyframe, or the previous tracked frame after a fallback.
  Pose3 T_ref_c = Pose3::Identity();
  int64_t reference_seq = -1;  ///< RgbdFrame::seq of the reference frame used
  /// kKeyframe: tracking against the keyframe failed and this frame was registered to the last
  /// tracked frame instead (it then becomes the keyframe).
  bool fell_back = false;
  /// kKeyframe: this frame is the keyframe from now on (first frame, motion threshold passed,
  /// fallback, or reference reset).
  bool new_keyframe = false;
  int valid_depth_pixels = 0;  ///< in this frame: finite, inside (min, max) depth
  double compute_ms = 0.0;     ///< wall time of process(): conversion + OpenCV
  std::string message;         ///< why it failed (empty when ok)
};

/// Running counters.
struct PeerStats {
  int64_t frames = 0;
  int64_t tracked = 0;   ///< kOk
  int64_t failures = 0;  ///< every status other than kOk and kFirst
  int64_t no_depth = 0;
  int64_t not_converged = 0;
  int64_t bad_input = 0;
  int64_t opencv_errors = 0;
  int64_t reference_resets = 0;  ///< reference replaced after max_consecutive_failures
  /// kKeyframe only (0 in kPreviousFrame mode): frames that became the keyframe, of any cause
  /// (the first frame, resets and camera changes included) ...
  int64_t keyframes = 0;
  /// ... of which because the motion from the keyframe passed a threshold ...
  int64_t keyframes_by_motion = 0;
  /// ... and because only the fallback to the previous frame tracked them.
  int64_t keyframe_fallbacks = 0;
  double total_ms = 0.0;
  double max_ms = 0.0;
  double meanMs() const { return frames > 0 ? total_ms / static_cast<double>(frames) : 0.0; }
};

/// OpenCV odometry chained into camera poses, frame to frame or frame to keyframe.
///
/// kPreviousFrame: each frame is registered to the reference frame, which is the last frame
/// tracked (or the first frame). A failed frame does not become the reference: the next frame is
/// registered to the last good one, so one bad frame (no depth, motion blur) costs no drift.
/// kKeyframe: each frame is registered to the keyframe (OpenCV's source = the keyframe, target
/// = the frame, initial guess = the last tracked pose relative to the keyframe, moved on by the
/// motion prior); if that fails, to the last tracked frame, and the frame becomes the keyframe;
/// if that fails too, the frame is a failure as in kPreviousFrame. Failure poses follow
/// FailurePolicy. Not thread-safe; one instance per sequence.
class PeerOdometry {
 public:
  explicit PeerOdometry(const PeerOdometryOptions& options = {});
  ~PeerOdometry();
  PeerOdometry(PeerOdometry&&) noexcept;
  PeerOdometry& operator=(PeerOdometry&&) noexcept;

  /// Registers `frame` (bgr CV_8UC3 or grey CV_8UC1, depth_m CV_32FC1 metres, 0 = missing).
  /// Never throws for data problems: they come back as a failure status.
  PeerFrameResult process(const RgbdFrame& frame);
  /// Forgets the reference and the poses: the next frame starts a new world frame.
  void reset();

  const PeerStats& stats() const { return stats_; }
  const PeerOdometryOptions& options() const { return options_; }

 private:
  struct Impl;
  PeerOdometryOptions options_;
  PeerStats stats_;
  std::unique_ptr<Impl> impl_;
};

/// The camera OpenCV sees under kFlipImage: |fx|, |fy| with the principal point mirrored for
/// each negative focal length. Also returns the cv::flip code (-1 both, 0 rows, 1 columns,
/// 2 = no flip).
PinholeCamera unmirroredCamera(const PinholeCamera& camera, int* flip_code);

}  // namespace pplvo::peer
