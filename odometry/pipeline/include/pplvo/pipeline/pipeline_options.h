#pragma once
/// Every parameter of the pipeline in one struct: what config/pplvo.yaml holds, what
/// pplvo-run and the processes read, and what the tests set.
#include <string>

#include "pplvo/depth_filter/cgm_filter.h"
#include "pplvo/depth_filter/depth_model.h"
#include "pplvo/depth_filter/ogm_fusion.h"
#include "pplvo/depth_filter/sensor_model.h"
#include "pplvo/pipeline/frame_odometry.h"
#include "pplvo/pipeline/frontend.h"

namespace pplvo::pipeline {

/// Load shedding of the pplvo-depth-filter process when a live pipeline falls behind the sensor
/// (not in the paper; nodes::DepthFilterNodeOptions::overload_backlog). pplvo-run and lockstep
/// launches never shed: every frame is fused over the full window there.
struct DepthFilterOverloadOptions {
  int backlog = 3;      ///< newer frames waiting for their pose beyond which the window shortens
  int window_step = 2;  ///< frames shorter per frame of backlog beyond that (at least 2 left)
};

struct DepthFilterOptions {
  depth_filter::DepthModel model = depth_filter::DepthModel::kOgm;
  depth_filter::QuadraticSensorModel::Options sensor;
  depth_filter::CgmOptions cgm;
  depth_filter::OgmOptions ogm;
  DepthFilterOverloadOptions overload;
};

struct PipelineOptions {
  DepthFilterOptions depth_filter;
  FrontendOptions frontend;
  FrameOdometryOptions odometry;

  /// Feature families, set in the frontend and the estimator alike.
  FeatureFamilies families() const { return frontend.families; }
  void setFamilies(const FeatureFamilies& f);
};

inline void PipelineOptions::setFamilies(const FeatureFamilies& f) {
  frontend.families = f;
  odometry.tracker.estimator.use_points = f.points;
  odometry.tracker.estimator.use_lines = f.lines;
  odometry.tracker.estimator.use_planes = f.planes;
}

}  // namespace pplvo::pipeline
