#pragma once
/// Stages 0-2 of the probabilistic depth filter on one frame, as every caller runs them
/// (pplvo-depth-filter's node and the in-process OdometryPipeline): depth onto the colour
/// camera's undistorted pinhole grid (DepthRectifier), moved to the colour instant
/// (DepthTimeAligner), then stage 1 (sensor model) or stages 1-2 (C-GM) as options.model
/// says. Stage 3 (O-GM) needs the frame's pose and stays with the caller. No LCM.
/// Depth of a separate depth camera (RgbdFrame::depth_camera set) is registered into the
/// colour camera instead of rectified (DepthRegistration, one warp with the time alignment's
/// motion), carrying the sensor model's variance, which C-GM then uses.
#include <cstdint>

#include "pplvo/core/geometry.h"
#include "pplvo/core/rgbd_frame.h"
#include "pplvo/core/stage_timer.h"
#include "pplvo/depth_filter/cgm_filter.h"
#include "pplvo/depth_filter/depth_filter_options.h"
#include "pplvo/depth_filter/depth_rectification.h"
#include "pplvo/depth_filter/depth_registration.h"
#include "pplvo/depth_filter/depth_time_alignment.h"
#include "pplvo/depth_filter/sensor_model.h"

namespace pplvo::depth_filter {

class MeasurementStages {
 public:
  explicit MeasurementStages(const DepthFilterOptions& options);

  /// Depth and variance of `frame` in its colour camera's undistorted pinhole model, at the
  /// colour instant, after stage 1 (model sensor) or stages 1-2 (cgm, ogm). The time of each
  /// stage that ran is added to `timings` ("time_align", "sensor" or "cgm"; "register" for
  /// unregistered depth, which includes the sensor model and the time alignment). Throws
  /// std::invalid_argument when the depth disagrees with the camera.
  DepthWithVariance apply(const RgbdFrame& frame, StageTimings& timings);

  /// True when apply() will move this frame's depth to the colour instant (it needs the
  /// pose of frame seq - DepthTimeAligner::kPoseLag for that).
  bool timeAligns(const RgbdFrame& frame) const;

  /// The pose of frame `seq` at its colour instant (the time alignment's velocity).
  void observePose(int64_t seq, int64_t colour_utime, const Pose3& T_w_c, bool tracked) {
    time_aligner_.observePose(seq, colour_utime, T_w_c, tracked);
  }
  const DepthTimeAligner& timeAligner() const { return time_aligner_; }
  const CgmFilter& cgm() const { return cgm_; }
  const DepthRegistration& registration() const { return registration_; }

 private:
  DepthWithVariance applyUnregistered(const RgbdFrame& frame, StageTimings& timings);

  DepthFilterOptions options_;
  DepthRectifier rectifier_;
  DepthTimeAligner time_aligner_;
  QuadraticSensorModel sensor_;
  CgmFilter cgm_;
  DepthRegistration registration_;
};

}  // namespace pplvo::depth_filter
