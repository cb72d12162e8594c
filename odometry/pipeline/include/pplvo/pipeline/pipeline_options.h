#pragma once
/// Every parameter of the pipeline in one struct: what config/pplvo.yaml holds, what
/// pplvo-run and the processes read, and what the tests set. Composed of the modules' own
/// options structs; each module declares its schema beside its struct (a visit function), and
/// pipeline_config.cpp composes those schemas and adds the cross-module rules.
#include <string>

#include "pplvo/depth_filter/depth_filter_options.h"
#include "pplvo/pipeline/frontend.h"
#include "pplvo/tracking/frame_tracker.h"

namespace pplvo::pipeline {

/// The depth filter's options live with the depth filter (fusion/depth_filter), which the
/// pplvo-depth-filter process reads on its own.
using DepthFilterOptions = depth_filter::DepthFilterOptions;
using DepthFilterOverloadOptions = depth_filter::DepthFilterOverloadOptions;

struct PipelineOptions {
  DepthFilterOptions depth_filter;
  FrontendOptions frontend;
  tracking::TrackingOptions odometry;

  /// Feature families, set in the frontend and the estimator alike.
  FeatureFamilies families() const { return frontend.families; }
  void setFamilies(const FeatureFamilies& f);
  /// The sensor model has one source: the depth filter's sigma_z coefficient (paper eq. 1) and
  /// the lifting's pixel variance (Sec. 4.2) are copied to the frontend's other users (the
  /// planarity tests' fallback noise, the lifting's fallback noise, the plane fit).
  void shareSensorModel();
  /// Whether every copy of the sensor model equals its source.
  bool sensorModelShared() const;
};

inline void PipelineOptions::shareSensorModel() {
  const double coeff = depth_filter.sensor.sigma_z_coeff_per_m;
  frontend.planes.noise.sigma_z_coeff_per_m = coeff;
  frontend.lift.noise.sigma_z_coeff_per_m = coeff;
  frontend.planes.pixel_variance_px2 = frontend.lift.pixel_variance_px2;
}

inline bool PipelineOptions::sensorModelShared() const {
  const double coeff = depth_filter.sensor.sigma_z_coeff_per_m;
  return frontend.planes.noise.sigma_z_coeff_per_m == coeff &&
         frontend.lift.noise.sigma_z_coeff_per_m == coeff &&
         frontend.planes.pixel_variance_px2 == frontend.lift.pixel_variance_px2;
}

inline void PipelineOptions::setFamilies(const FeatureFamilies& f) {
  frontend.families = f;
  odometry.tracker.estimator.use_points = f.points;
  odometry.tracker.estimator.use_lines = f.lines;
  odometry.tracker.estimator.use_planes = f.planes;
}

}  // namespace pplvo::pipeline
