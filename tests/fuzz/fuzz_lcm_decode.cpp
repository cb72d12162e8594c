// libFuzzer harness: any bytes as each pplvo LCM message type (the decoders bounded by
// cmake/HardenLcmDecoders.cmake), then the node-side conversions of what decodes. A decode
// failure or a std::exception from a conversion is what a node counts (msgs::guarded); a crash,
// a sanitizer report or another exception is a finding.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <pplvo_msgs/depth_map_t.hpp>
#include <pplvo_msgs/features_t.hpp>
#include <pplvo_msgs/node_status_t.hpp>
#include <pplvo_msgs/pose_t.hpp>
#include <pplvo_msgs/rgbd_frame_t.hpp>
#include <pplvo_msgs/stream_event_t.hpp>

#include "pplvo/msgs/convert.h"
#include "pplvo/msgs/convert_features.h"
#include "pplvo/msgs/convert_pose.h"
#include "pplvo/msgs/decode.h"

namespace {

template <class M, class Convert>
void decodeAndConvert(const uint8_t* data, size_t size, Convert&& convert) {
  M msg;
  if (!pplvo::msgs::decodeMessage(data, size, &msg).empty()) return;
  try {
    convert(msg);
  } catch (const std::exception&) {
    // a counted error in a node
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pplvo;
  // The type hash is the first 8 bytes: every type is tried, so that the corpus of each one
  // (a valid packet with some bytes changed) reaches its decoder.
  decodeAndConvert<pplvo_msgs::rgbd_frame_t>(data, size, [](const auto& m) { msgs::fromMsg(m); });
  decodeAndConvert<pplvo_msgs::depth_map_t>(data, size, [](const auto& m) { msgs::fromMsg(m); });
  decodeAndConvert<pplvo_msgs::features_t>(data, size, [](const auto& m) { msgs::fromMsg(m); });
  decodeAndConvert<pplvo_msgs::pose_t>(data, size, [](const auto& m) { msgs::fromMsg(m); });
  decodeAndConvert<pplvo_msgs::node_status_t>(data, size, [](const auto&) {});
  decodeAndConvert<pplvo_msgs::stream_event_t>(data, size, [](const auto&) {});
  return 0;
}
