#pragma once
/// Message conversions of the pplvo-depth-filter process (the only place it touches message
/// layouts besides pplvo/msgs/convert.h). Round-trip tested in test_depth_filter_node.
#include <cstdint>
#include <pplvo_msgs/depth_map_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <string>
#include <utility>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/geometry.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo::nodes {

/// What the depth filter needs from a pose_t.
struct PoseInput {
  int64_t utime = 0;
  int64_t seq = 0;
  std::string stamp;
  int8_t status = 0;
  Pose3 T_w_c = Pose3::Identity();  ///< may hold NaN: the fusion checks and counts it
  /// (window frame seq, largest eigenvalue of its propagated translation covariance, m^2)
  std::vector<std::pair<int64_t, double>> window_uncertainty;
};

/// Throws msgs::MessageError when n_window disagrees with the array sizes.
PoseInput poseFromMsg(const pplvo_msgs::pose_t& msg);
/// Inverse of poseFromMsg (fields the filter does not use are zero); for tests and replay.
pplvo_msgs::pose_t poseToMsg(const PoseInput& pose);

/// Depth map message of a filter stage (depth_map_t::STAGE_*).
pplvo_msgs::depth_map_t depthToMsg(const DepthWithVariance& depth, const PinholeCamera& camera,
                                   int64_t utime, int64_t seq, const std::string& stamp,
                                   int8_t stage, bool compress);
/// Throws msgs::MessageError on inconsistent messages.
DepthWithVariance depthFromMsg(const pplvo_msgs::depth_map_t& msg);

}  // namespace pplvo::nodes
