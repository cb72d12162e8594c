#pragma once
/// The whole method in one object, without LCM: depth filter -> frontend (2D) -> odometry ->
/// depth filter (O-GM with the new pose) -> frontend (3D) for each frame, in the order the
/// processes run it over LCM. Used by tests and tools that want the algorithm without
/// messages; pplvo-run runs the processes themselves over memq:// and must agree with it.
#include <optional>

#include "pplvo/core/features.h"
#include "pplvo/core/frame_pose.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/depth_filter/measurement_stages.h"
#include "pplvo/pipeline/pipeline_options.h"

namespace pplvo::pipeline {

struct PipelineFrameResult {
  estimator::MotionChainOutput tracking;
  FramePose pose;  ///< published form (utime, seq, stamp of the frame)
  FrontendStats frontend;
  tracking::TrackingStats odometry;
  int fused_window_length = 1;  ///< frames fused into this frame's depth
};

class OdometryPipeline {
 public:
  explicit OdometryPipeline(const PipelineOptions& options = {});

  /// Processes the next frame. Throws std::invalid_argument on a frame whose depth or image
  /// disagrees with its camera (the caller counts and skips it; tracking then reinitialises).
  PipelineFrameResult process(const RgbdFrame& frame);

  /// The last frame's features with their 3D estimates (the next frame's reference).
  const std::optional<FrameFeatures>& reference() const { return reference_; }
  const PipelineOptions& options() const { return options_; }
  /// depth filter stages, frontend stages and odometry stages, in one table.
  StageTimings timings() const;

 private:
  PipelineOptions options_;
  depth_filter::MeasurementStages measurement_;  ///< stages 0-2
  depth_filter::OgmFusion ogm_;
  depth_filter::OgmResult fused_;
  Frontend frontend_;
  tracking::FrameTracker odometry_;
  std::optional<FrameFeatures> reference_;
  StageTimings depth_timings_;
};

/// Merges several timing tables (stage names are kept; equal names add up).
StageTimings mergeTimings(const std::vector<const StageTimings*>& tables);

}  // namespace pplvo::pipeline
