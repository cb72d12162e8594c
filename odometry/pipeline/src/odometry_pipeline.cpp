#include "pplvo/pipeline/odometry_pipeline.h"

#include <stdexcept>

namespace pplvo::pipeline {

OdometryPipeline::OdometryPipeline(const PipelineOptions& options)
    : options_(options),
      sensor_(options.depth_filter.sensor),
      cgm_(options.depth_filter.cgm,
           std::make_shared<depth_filter::QuadraticSensorModel>(options.depth_filter.sensor)),
      ogm_(options.depth_filter.ogm),
      frontend_(options.frontend),
      odometry_(options.odometry) {}

PipelineFrameResult OdometryPipeline::process(const RgbdFrame& frame) {
  if (frame.depth_m.empty() || frame.depth_m.type() != CV_32FC1 ||
      frame.depth_m.rows != frame.camera.height || frame.depth_m.cols != frame.camera.width) {
    throw std::invalid_argument("frame " + std::to_string(frame.seq) +
                                ": depth size or type disagrees with the camera");
  }
  PipelineFrameResult r;
  // Stage 1-2 of the depth filter, on depth in the undistorted pinhole model.
  cv::Mat depth_m = rectifier_.apply(frame.camera, frame.depth_m);
  if (options_.depth_filter.time_alignment &&
      depth_filter::DepthTimeAligner::needed(frame.utime, frame.depth_utime)) {
    ScopedStageTimer t(depth_timings_, "time_align");
    depth_m = time_aligner_.apply(frame.camera, depth_m, frame.seq, frame.utime, frame.depth_utime);
  }
  DepthWithVariance depth;
  if (options_.depth_filter.model == depth_filter::DepthModel::kSensor) {
    ScopedStageTimer t(depth_timings_, "sensor");
    depth = depth_filter::applySensorModel(sensor_, depth_m);
  } else {
    ScopedStageTimer t(depth_timings_, "cgm");
    depth = cgm_.apply(depth_m);
  }
  // Frontend, 2D stage; then the pose against the last frame's 3D features.
  FrameFeatures features = frontend_.extract2d(frame, depth, &r.frontend);
  r.tracking = reference_ ? odometry_.track(*reference_, features, &r.odometry)
                          : odometry_.initialise(features);
  r.pose = toFramePose(r.tracking);
  r.pose.utime = frame.utime;
  r.pose.seq = frame.seq;
  r.pose.stamp = frame.stamp;
  time_aligner_.observePose(frame.seq, frame.utime, r.pose.T_w_c,
                            r.pose.status == TrackingStatus::kTracking);
  // O-GM on the new pose (as the depth filter process does on pose_t).
  const DepthWithVariance* fused = &depth;
  if (options_.depth_filter.model == depth_filter::DepthModel::kOgm) {
    ScopedStageTimer t(depth_timings_, "ogm");
    if (r.pose.status == TrackingStatus::kLost || r.pose.status == TrackingStatus::kReinitialised) {
      ogm_.reset();  // poses across a tracking loss cannot register the window
    }
    for (const WindowUncertainty& w : r.pose.window) {
      ogm_.setWindowUncertainty(w.seq, w.max_translation_variance_m2);
    }
    ogm_.addFrame(frame.seq, frame.camera, depth);
    ogm_.fuse(frame.seq, r.pose.T_w_c, &fused_);
    if (fused_.ok) fused = &fused_.depth;
  }
  r.fused_window_length = fused->window_length;
  // Frontend, 3D stage: this frame becomes the next one's reference.
  frontend_.lift3d(features, *fused, &r.frontend);
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
