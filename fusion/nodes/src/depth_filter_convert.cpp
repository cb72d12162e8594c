#include "pplvo/depth_filter_node/depth_filter_convert.h"

#include "pplvo/msgs/convert.h"

namespace pplvo::nodes {

pplvo_msgs::depth_map_t depthToMsg(const DepthWithVariance& depth, const PinholeCamera& camera,
                                   int64_t utime, int64_t seq, const std::string& stamp,
                                   int8_t stage, bool compress) {
  return msgs::toMsg(depth, camera, utime, seq, stamp, stage, compress);
}

void encodeDepthPacket(const DepthWithVariance& depth, const PinholeCamera& camera, int64_t utime,
                       int64_t seq, const std::string& stamp, int8_t stage, int8_t reference,
                       std::vector<uint8_t>* packet) {
  msgs::encodeRawDepthMap(depth, camera, utime, seq, stamp, stage, reference, packet);
}

DepthWithVariance depthFromMsg(const pplvo_msgs::depth_map_t& msg) { return msgs::fromMsg(msg); }

}  // namespace pplvo::nodes
