#include "pplvo/pipeline/odometry_pipeline.h"

#include <stdexcept>

namespace pplvo::pipeline {

OdometryPipeline::OdometryPipeline(const PipelineOptions& options)
    : options_(options),
      measurement_(options.depth_filter),
      ogm_(options.depth_filter.ogm),
      frontend_(options.frontend),
      odometry_(options.odometry) {}

PipelineFrameResult OdometryPipeline::process(const RgbdFrame& frame) {
  // Depth has the colour camera's size, or its own camera's when not registered.
  const PinholeCamera& depth_camera =
      frame.depth_camera ? frame.depth_camera->camera : frame.camera;
  if (frame.depth_m.empty() || frame.depth_m.type() != CV_32FC1 ||
      frame.depth_m.rows != depth_camera.height || frame.depth_m.cols != depth_camera.width) {
    throw std::invalid_argument("frame " + std::to_string(frame.seq) +
                                ": depth size or type disagrees with the camera");
  }
  PipelineFrameResult r;
  // Stages 0-2 of the depth filter, on depth in the undistorted pinhole model.
  DepthWithVariance depth = measurement_.apply(frame, depth_timings_);
  // Frontend, 2D stage; then the pose against the last frame's 3D features.
  FrameFeatures features = frontend_.extract2d(frame, depth, &r.frontend);
  r.tracking = reference_ ? odometry_.track(*reference_, features, &r.odometry)
                          : odometry_.initialise(features);
  r.pose = estimator::toFramePose(r.tracking);
  r.pose.utime = frame.utime;
  r.pose.seq = frame.seq;
  r.pose.stamp = frame.stamp;
  r.pose.reference = odometry_.referenceRole(frame.seq);
  measurement_.observePose(frame.seq, frame.utime, r.pose.T_w_c,
                            r.pose.status == TrackingStatus::kTracking);
  // O-GM on the new pose (as the depth filter process does on pose_t).
  const DepthWithVariance* fused = &depth;
  if (options_.depth_filter.model == depth_filter::DepthModel::kOgm) {
    ScopedStageTimer t(depth_timings_, "ogm");
    ogm_.fuseOnPose(frame.seq, r.pose, frame.camera, depth, &fused_);
    if (fused_.ok) fused = &fused_.depth;
  }
  r.fused_window_length = fused->window_length;
  // Frontend, 3D stage: this frame becomes the next one's reference.
  frontend_.lift3d(features, *fused, &r.frontend, r.pose.reference);
  reference_ = std::move(features);
  return r;
}

StageTimings OdometryPipeline::timings() const {
  const StageTimings frontend = frontend_.timings();
  return mergeTimings({&depth_timings_, &frontend, &odometry_.timings()});
}

StageTimings mergeTimings(const std::vector<const StageTimings*>& tables) {
  StageTimings merged;
  for (const StageTimings* t : tables) {
    for (const StageStats& s : t->stages()) merged.merge(s);
  }
  return merged;
}

}  // namespace pplvo::pipeline
