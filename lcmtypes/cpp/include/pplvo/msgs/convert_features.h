#pragma once
/// features_t <-> FrameFeatures. Validates array sizes, descriptor shapes and finiteness;
/// throws MessageError on inconsistent messages.
#include <pplvo_msgs/features_t.hpp>

#include "pplvo/core/features.h"
#include "pplvo/msgs/convert.h"

namespace pplvo::msgs {

pplvo_msgs::features_t toMsg(const FrameFeatures& features, int8_t stage);
FrameFeatures fromMsg(const pplvo_msgs::features_t& msg);

}  // namespace pplvo::msgs
