#pragma once
/// Stage 3 of the probabilistic depth filter (paper sections 3.3-3.4, eqs. 7-8): Optimal-GM
/// temporal fusion of the C-GM measurements of a sliding window of frames, with the
/// consistency gate against occlusions and the window shortened by pose uncertainty.
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/config_schema.h"
#include "pplvo/core/frame_pose.h"
#include "pplvo/core/geometry.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo::depth_filter {

struct OgmStats {
  int64_t frames_added = 0;
  int64_t frames_fused = 0;
  int64_t window_resets = 0;         ///< camera/size changed (warning) or reset() called
  int64_t size_changes = 0;          ///< frames whose camera differs from the window's
  int64_t unknown_frame_poses = 0;   ///< fuse() for a seq not in the window
  int64_t invalid_poses = 0;         ///< NaN / non-rigid T_w_c given to fuse()
  int64_t invalid_inputs = 0;        ///< frames rejected by addFrame (bad type/size)
  int64_t invalid_pixels = 0;        ///< non-finite / non-positive variance, treated missing
  int64_t evicted_capacity = 0;      ///< oldest frame dropped because the window was full
  int64_t evicted_uncertainty = 0;   ///< frames dropped by the pose-uncertainty threshold
  int64_t points_projected = 0;      ///< past-frame points that landed in the image
  int64_t points_gated = 0;          ///< rejected by the consistency gate
  int64_t pixels_filled = 0;         ///< output pixels with no current measurement
  int64_t frames_fused_limited = 0;  ///< fusions that left past frames out (window_limit)
  int64_t warnings = 0;
  std::string last_warning;
  int last_window_length = 0;
};

/// Result of one fusion. ok = false (with `warning`) for an unknown frame or invalid pose; the
/// depth is then empty.
struct OgmResult {
  bool ok = false;
  DepthWithVariance depth;  ///< fused depth (m) and variance (m^2); window_length = frames used
  std::string warning;
};

struct OgmOptions {
  /// Frames in the sliding window including the current one (paper: O-GM_10).
  int max_window = 10;
  /// Points a pixel accepts before the consistency gate applies (section 3.4: k = 5).
  int k_consistency = 5;
  /// Gate half-width in standard deviations of the pixel state (section 3.4: 3 sigma_r).
  double gate_sigma = 3.0;
  /// Frames whose propagated transform uncertainty to the current frame (largest eigenvalue
  /// of the translation covariance block, m^2) exceeds this leave the window (section 3.4).
  /// 1e-4 m^2 = (1 cm)^2: a misregistration of one sensor sigma at 2.6 m (eq. 1). The paper
  /// gives no value.
  double max_translation_variance_m2 = 1e-4;
  /// Projected points closer than this (m) in the current camera are ignored.
  double min_depth_m = 0.05;
  /// Threads of fuse() (OpenCV's parallel_for_ pool): the output image is split into this many
  /// horizontal bands, each accumulating the points that land in it in the serial order.
  /// 1 = serial; 0 = one fewer than the machine's hardware threads (at least 1), since in the
  /// pipeline the frontend extracts the next frame on one while a frame is fused: on two cores
  /// a second band only adds its share of re-projected rows and a hand-off
  /// (docs/decisions/0006). pplvo-run, which fuses on a worker beside the pose loop, resolves 0 to
  /// two bands instead. The results (depth, variance, stats) do not depend on it, bit for bit.
  int threads = 0;
};

/// The bands OgmOptions::threads asks for on this machine (0 resolved; >= 1).
int ogmThreads(const OgmOptions& options);

/// Schema of OgmOptions (pplvo/core/config_schema.h): the one place of their names, docs and
/// ranges (OgmFusion asserts them in debug builds).
template <class V>
void visit(V& v, OgmOptions& o) {
  v.field("max_window", o.max_window,
          "frames in the fusion sliding window, current included (paper Sec. 5: 10, O-GM_10)",
          config::atLeast(1));
  v.field("k_consistency", o.k_consistency,
          "points a pixel accepts before the consistency gate applies (Sec. 3.4: k = 5)",
          config::atLeast(1));
  v.field("gate_sigma", o.gate_sigma,
          "consistency gate half-width r_bar +- gate_sigma * sigma_r (Sec. 3.4: 3)",
          config::positive());
  v.field("max_translation_variance_m2", o.max_translation_variance_m2,
          "a window frame whose transform to the current frame has a larger translation "
          "variance (largest eigenvalue, m^2) leaves the window (Sec. 3.4; no value in the "
          "paper: (1 cm)^2)",
          config::positive());
  v.field("min_depth_m", o.min_depth_m,
          "projected points closer than this to the current camera are ignored (m)",
          config::atLeast(0));
  v.field("threads", o.threads,
          "threads of the fusion (OpenCV's pool; bands of the image): 1 = serial, 0 = one "
          "fewer than the hardware threads (at least 1; the frontend extracts the next frame "
          "on the other), 2 in pplvo-run (it fuses beside the pose loop). The results do not "
          "depend on it, bit for bit",
          config::atLeast(0));
}

/// O-GM fusion. Each window frame is stored as its C-GM depth and range variance
/// sigma_r^2 = sigma_z^2 / cos^2(alpha) (eq. 7, cosines precomputed from the intrinsics).
/// fuse(seq, T_w_c) moves the points of all window frames with a pose into the camera of
/// `seq`, projects them to the nearest pixel NEWEST TO OLDEST (frame `seq` first, at its own
/// pixels) and accumulates per pixel S_w = sum 1/s_i^2, S_wr = sum r_i/s_i^2,
/// S_wq = sum (r_i^2 + s_i^2)/s_i^2 and the count. Once a pixel holds k points, a further point
/// is accepted only if |r - r_bar| <= gate_sigma * sigma_r of the pixel's current state
/// (section 3.4). The output range is r_bar = S_wr / S_w (eq. 8), its variance the GM variance
/// S_wq / S_w - r_bar^2 (eq. 5 with weights 1/s_i^2: intra- plus inter-group spread), and depth
/// z = r_bar cos(alpha), var_z = var_r cos^2(alpha). Pixels without a current measurement but
/// with projected points are filled. Memory: max_window frames of two float images plus one
/// accumulator image, all allocated once per camera.
/// Parallel (options.threads > 1): the output image is split into horizontal bands, one task
/// each; every task walks the frames in the serial order and accumulates only the points that
/// land in its band, so each pixel sees its points in the same order as in the serial fusion.
/// A past-frame row is projected only by the tasks whose band it can reach (bound from the
/// row's depth range and the transform); rows without depth are skipped.
/// Fused variances come from float sums centred per pixel; relative precision ~1e-6.
class OgmFusion {
 public:
  using Options = OgmOptions;

  explicit OgmFusion(const Options& options = Options());

  /// Stores the C-GM (or stage-1) output of frame `seq` in the window. A camera different
  /// from the window's resets the window (counted warning). A seq already in the window is
  /// replaced. When the window is full the oldest frame leaves. Returns false (counted) when
  /// depth is not CV_32FC1/var not CV_32FC1 of the camera's size.
  bool addFrame(int64_t seq, const PinholeCamera& camera, const DepthWithVariance& cgm);

  /// Propagated transform uncertainty of window frame `seq` relative to the current frame
  /// (estimator's pose_t.window_max_translation_variance). Above the threshold the frame leaves
  /// the window. Unknown seqs are ignored. Returns true if the frame was evicted.
  bool setWindowUncertainty(int64_t seq, double max_translation_variance_m2);

  /// Sets the pose of frame `seq` (which must have been added) and fuses the window into it.
  /// Frames without a pose and frames newer than `seq` are not used.
  OgmResult fuse(int64_t seq, const Pose3& T_w_c);
  /// Same, writing into `result`, whose depth matrices are reused when they already have the
  /// camera's size (no allocation in steady state; they must not share data still in use).
  /// `window_limit` > 0 fuses at most that many frames, the current one and the newest past
  /// ones (the result of a full fusion stopped early, since frames are fused newest to
  /// oldest); the window itself keeps every frame for later fusions. A real-time caller that
  /// falls behind uses it to shed load (docs/depth_filter.md).
  void fuse(int64_t seq, const Pose3& T_w_c, OgmResult* result, int window_limit = 0);

  /// Empties the window (e.g. after tracking loss).
  void reset();

  /// One frame's O-GM step on the estimator's pose of it, as every caller runs it (the depth
  /// filter process on pose_t, OdometryPipeline): the window is reset after a tracking loss
  /// (poses across it cannot register the window), takes the window uncertainties the pose
  /// carries, receives the frame's depth (stage 2 output) and is fused into frame `seq`.
  void fuseOnPose(int64_t seq, const FramePose& pose, const PinholeCamera& camera,
                  const DepthWithVariance& depth, OgmResult* result, int window_limit = 0);

  /// Frames currently stored.
  int windowSize() const;
  bool contains(int64_t seq) const;
  const OgmStats& stats() const { return stats_; }
  const Options& options() const { return options_; }

 private:
  struct Slot {
    bool used = false;
    bool has_pose = false;
    int64_t seq = 0;
    Pose3 T_w_c = Pose3::Identity();
    cv::Mat depth_m;  ///< CV_32FC1, 0 = missing
    cv::Mat weight;   ///< CV_32FC1 1 / sigma_r^2 (eq. 7), 1/m^2; 0 where missing
    std::vector<float> row_zmin, row_zmax;  ///< depth range of each row's points (0: none)
  };
  /// One past frame of a fusion: its transform into the current camera (float, as projected).
  struct PastFrame {
    const Slot* slot;
    float r[9];                 ///< row-major rotation of T_c_k
    float tx, ty, tz;           ///< translation of T_c_k
    const float *ax, *ay, *az;  ///< R * (x_u, 0, 0) per column (in ray_rot_)
  };
  /// Output band [v0, v1) of one task, with its row buffers and counters.
  struct Band {
    int v0 = 0, v1 = 0;
    std::vector<int32_t> idx;  ///< target pixel per column of one row (-1: none)
    std::vector<float> range;  ///< range in the current camera per column of one row
    int64_t projected = 0, gated = 0, filled = 0;
  };
  /// Running sums of one pixel, centred on its first accepted range r0 (float precision
  /// suffices for d = r - r0): S_w, S_w d, S_w (d^2 + sigma^2). The count lives in count_.
  struct Acc {
    float r0, s_w, s_wd, s_wq;
  };

  void configure(const PinholeCamera& camera);
  /// fuse() on the output rows of one band.
  void fuseBand(const Slot& cur, DepthWithVariance& out, Band& band);
  /// False only if no point of row v of `f` can land in rows [v0, v1) of the current image.
  bool rowMayReach(const PastFrame& f, int v, int v0, int v1) const;
  void warn(const std::string& what);
  Slot* find(int64_t seq);

  Options options_;
  OgmStats stats_;
  PinholeCamera camera_;
  bool configured_ = false;
  std::vector<Slot> slots_;
  std::vector<float> ray_x_, ray_y_;  ///< (u - cx)/fx per column, (v - cy)/fy per row
  std::vector<float> cos_;            ///< cos(alpha) per pixel = 1 / |ray|
  std::vector<float> inv_cos_;        ///< |ray| per pixel
  std::vector<Acc> acc_;
  std::vector<Slot*> past_;        ///< window frames used by one fusion, newest first
  std::vector<PastFrame> frames_;  ///< the same with their transforms
  std::vector<uint8_t> count_;     ///< points per pixel (saturates at 255)
  std::vector<float> ray_rot_;     ///< ax, ay, az (w each) per window slot of one fusion
  std::vector<Band> bands_;        ///< one per task (min(threads, height))
};

}  // namespace pplvo::depth_filter
