#include "pplvo/depth_filter_node/depth_filter_convert.h"

#include "pplvo/msgs/convert.h"

namespace pplvo::nodes {

pplvo_msgs::depth_map_t depthToMsg(const DepthWithVariance& depth, const PinholeCamera& camera,
                                   int64_t utime, int64_t seq, const std::string& stamp,
                                   int8_t stage, bool compress) {
  return msgs::toMsg(depth, camera, utime, seq, stamp, stage, compress);
}

DepthWithVariance depthFromMsg(const pplvo_msgs::depth_map_t& msg) { return msgs::fromMsg(msg); }

}  // namespace pplvo::nodes
