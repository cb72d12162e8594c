#pragma once
/// Message conversions of the pplvo-depth-filter process (the only place it touches message
/// layouts besides pplvo/msgs/convert.h; poses are decoded by msgs::fromMsg of
/// pplvo/msgs/convert_pose.h). Round-trip tested in test_depth_filter_node.
#include <cstdint>
#include <pplvo_msgs/depth_map_t.hpp>
#include <string>
#include <vector>

#include "pplvo/core/camera.h"
#include "pplvo/core/rgbd_frame.h"

namespace pplvo::nodes {

/// Depth map message of a filter stage (depth_map_t::STAGE_*).
pplvo_msgs::depth_map_t depthToMsg(const DepthWithVariance& depth, const PinholeCamera& camera,
                                   int64_t utime, int64_t seq, const std::string& stamp,
                                   int8_t stage, bool compress);
/// The packet of depthToMsg(..., compress = false) with `reference` set, without building the
/// message (msgs::encodeRawDepthMap): for Bus::publish(channel, data, size).
void encodeDepthPacket(const DepthWithVariance& depth, const PinholeCamera& camera, int64_t utime,
                       int64_t seq, const std::string& stamp, int8_t stage, int8_t reference,
                       std::vector<uint8_t>* packet);
/// Throws msgs::MessageError on inconsistent messages.
DepthWithVariance depthFromMsg(const pplvo_msgs::depth_map_t& msg);

}  // namespace pplvo::nodes
