#pragma once
/// pplvo-run: every pplvo process (player, depth filter, frontend, estimator) in one process on
/// one memq:// LCM instance. The player publishes as fast as possible, at most `in_flight`
/// frames ahead of their poses, and dispatches the queue on this thread; the depth filter's
/// fusion and the frontend's extraction run on workers whose results it publishes when the
/// queue is idle. Deterministic (each stage's output depends on its inputs, not on their
/// order), every frame processed, the same code and messages as the separate processes.
/// Evaluations use this.
#include <cstdint>
#include <string>
#include <vector>

#include "pplvo/core/frame_pose.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/core/trajectory.h"
#include "pplvo/estimator/frame_error_estimator.h"
#include "pplvo/msgs/convert.h"
#include "pplvo/pipeline/pipeline_options.h"
#include "pplvo/player/player_node.h"

namespace pplvo::run {

struct RunOptions {
  std::string dataset_dir;  ///< --dataset
  /// --camera: camera file (YAML, or calib_params.xml) instead of DATASET/calib_params.xml,
  /// e.g. config/cameras/tum_fr1.yaml for a TUM folder from the official download.
  std::string camera_file;
  std::string output;       ///< --output: TUM trajectory (empty: not written)
  std::string summary;      ///< --summary: YAML run summary (empty: not written)
  std::string log;          ///< --log: every message as an LCM event log (for replay)
  /// --log-channels: the channels --log records (LCM regex, whole name), e.g.
  /// 'PPLVO_(POSE|ODOMETRY)' for a log of kilobytes instead of ~7 MB a frame.
  std::string log_channels = ".*";
  /// --log-mode compact: the player sends colour as JPEG (`jpeg_quality`) and depth as
  /// lossless zlib, so the pipeline runs on the frames the log keeps, and --log records only
  /// msgs channels::kCompactLogChannels (unless --log-channels says otherwise): ~200 KB a
  /// frame at 640x480 instead of 6.7 MB; `pplvo-replay --stage pipeline` reproduces the poses
  /// from it.
  bool compact_log = false;
  int jpeg_quality = 90;  ///< --jpeg-quality (compact frames; the player's default)
  std::string covariance;   ///< --covariance: T_prev_curr + covariance per frame (main)
  int64_t max_frames = 0;   ///< --max-frames (0: all)
  int64_t start = 0;        ///< --start: first associated frame
  double fps = 0.0;         ///< --fps: frame rate of integer-stamped datasets
  bool skip_bad = false;    ///< --skip-bad: skip corrupt frames (counted)
  /// --in-flight: frames published before the pose of the one before them (1: one frame at a
  /// time). With 2 the next frame's 2D features are extracted while this one is fused and
  /// lifted; the trajectory is the same.
  int in_flight = 2;
  bool progress = false;  ///< progress line on stderr
  /// --preload: the player decodes every frame before publishing the first (as a camera
  /// delivers decoded frames); the throughput then leaves the decoding out. Same trajectory.
  bool preload = false;
  pipeline::PipelineOptions pipeline;
};

/// Counters of one node as the run summary reports them.
struct NodeReport {
  std::string name;
  msgs::NodeCounters counters;
  StageTimings timings;
};

struct RunResult : TrackingStatusCounts {
  Trajectory trajectory;  ///< T_w_c per posed frame, stamps verbatim from the dataset
  /// Every published pose as received (stamp, status, T_prev_curr and its covariance), for
  /// --covariance (pplvo/eval/pose_records.h).
  std::vector<FramePose> frame_poses;
  int64_t frames_published = 0, frames_skipped = 0;
  int64_t poses = 0;
  int64_t keyframes = 0, keyframe_fallbacks = 0;  ///< the estimator's (reference: keyframe)
  int64_t keyframes_reused = 0;  ///< earlier keyframes made active again (retired_keyframes)
  /// The per-frame shared error at the last pose (std per axis) and which of its blocks were
  /// estimated online; zeros when nothing was posed.
  double frame_error_sigma_t_m = 0.0, frame_error_sigma_rot_deg = 0.0;
  /// The colour readout read from the frames (EstimatorCounts::readout_*).
  double readout_mean_s = 0.0, readout_standard_error_s = 0.0;
  int64_t readout_readings = 0;
  bool readout_used = false;
  estimator::FrameErrorSource frame_error_source;
  /// Weak estimates combined with the prediction; estimates refused by the prediction gate.
  int64_t weak_estimates_combined = 0, estimates_gated = 0;
  std::string keyframe_reasons;  ///< "overlap N, uncertainty N, ..." (chosen keyframes)
  double elapsed_s = 0.0;        ///< wall time of the run (reading the dataset included)
  double preload_s = 0.0;        ///< of which decoding the frames beforehand (--preload)
  std::vector<NodeReport> nodes;
  /// How the dataset's index was built: missing files, malformed lines, unsorted and
  /// duplicate stamps (what pplvo-player prints at start-up).
  dataset::IndexSummary index;
  bool failed = false;
  std::string error;

  /// Poses per second of wall time, the time spent preloading excluded.
  double framesPerSecond() const {
    const double s = elapsed_s - preload_s;
    return s > 0 ? poses / s : 0.0;
  }
  /// Sum of the mean stage times of every node except the player (ms per frame).
  double pipelineMsPerFrame() const;
  /// Human-readable summary: counts, per-stage timing per node, throughput.
  std::string text() const;
  /// The same as YAML (key: value), for scripts.
  std::string yaml() const;
};

/// Runs the whole sequence. Never throws: errors are returned in the result.
RunResult runPipeline(const RunOptions& options);

/// Empty when `path` can be written (created, or appended to; nothing is left behind), else
/// why not, e.g. "No such file or directory". For checking outputs before the first frame.
std::string outputFileError(const std::string& path);

}  // namespace pplvo::run
