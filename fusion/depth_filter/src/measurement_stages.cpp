#include "pplvo/depth_filter/measurement_stages.h"

#include <memory>

namespace pplvo::depth_filter {

MeasurementStages::MeasurementStages(const DepthFilterOptions& options)
    : options_(options),
      sensor_(options.sensor),
      cgm_(options.cgm, std::make_shared<QuadraticSensorModel>(options.sensor)) {}

bool MeasurementStages::timeAligns(const RgbdFrame& frame) const {
  return options_.time_alignment && DepthTimeAligner::needed(frame.utime, frame.depth_utime);
}

DepthWithVariance MeasurementStages::apply(const RgbdFrame& frame, StageTimings& timings) {
  if (frame.depth_camera) return applyUnregistered(frame, timings);
  // Depth in the undistorted pinhole model and at the colour instant, as every later stage
  // reads it.
  cv::Mat depth_m = rectifier_.apply(frame.camera, frame.depth_m);
  DepthTimeAlignment alignment;
  if (timeAligns(frame)) {
    ScopedStageTimer t(timings, "time_align");
    depth_m = time_aligner_.apply(frame.camera, depth_m, frame.seq, frame.utime, frame.depth_utime,
                                  &alignment);
  }
  DepthWithVariance out;
  if (options_.model == DepthModel::kSensor) {
    ScopedStageTimer t(timings, "sensor");
    out = applySensorModel(sensor_, depth_m);
  } else {
    ScopedStageTimer t(timings, "cgm");
    out = cgm_.apply(depth_m);
  }
  out.time_alignment = alignment;
  return out;
}

DepthWithVariance MeasurementStages::applyUnregistered(const RgbdFrame& frame,
                                                      StageTimings& timings) {
  // Registration and time alignment are one warp: depth camera -> colour camera at the depth
  // instant (the rig) -> colour camera at the colour instant (the motion).
  DepthWithVariance registered;
  {
    ScopedStageTimer t(timings, "register");
    std::optional<AlignmentMotion> motion;
    if (timeAligns(frame)) {
      motion = time_aligner_.motion(frame.seq, frame.utime, frame.depth_utime);
    }
    registered = registration_.apply(frame.camera, *frame.depth_camera, frame.depth_m, sensor_,
                                     motion ? motion->T_colour_depth : Pose3::Identity());
    if (motion) registered.time_alignment = motion->alignment;
  }
  if (options_.model == DepthModel::kSensor) return registered;
  ScopedStageTimer t(timings, "cgm");
  DepthWithVariance out = cgm_.apply(registered);
  out.time_alignment = registered.time_alignment;
  return out;
}

}  // namespace pplvo::depth_filter
