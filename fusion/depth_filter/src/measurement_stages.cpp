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
  // Depth in the undistorted pinhole model and at the colour instant, as every later stage
  // reads it.
  cv::Mat depth_m = rectifier_.apply(frame.camera, frame.depth_m);
  if (timeAligns(frame)) {
    ScopedStageTimer t(timings, "time_align");
    depth_m = time_aligner_.apply(frame.camera, depth_m, frame.seq, frame.utime,
                                  frame.depth_utime);
  }
  if (options_.model == DepthModel::kSensor) {
    ScopedStageTimer t(timings, "sensor");
    return applySensorModel(sensor_, depth_m);
  }
  ScopedStageTimer t(timings, "cgm");
  return cgm_.apply(depth_m);
}

}  // namespace pplvo::depth_filter
