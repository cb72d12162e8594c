#pragma once
/// features_t <-> FrameFeatures. Validates array sizes, descriptor shapes and finiteness;
/// throws MessageError on inconsistent messages.
#include <pplvo_msgs/features_t.hpp>

#include "pplvo/core/features.h"
#include "pplvo/msgs/convert.h"

namespace pplvo::msgs {

/// `encoded_labels`, if given, is features.plane_labels as an earlier toMsg encoded it (the
/// stage-2D message of the same frame): reused instead of compressing the labels again.
pplvo_msgs::features_t toMsg(const FrameFeatures& features, int8_t stage,
                             const pplvo_msgs::image_t* encoded_labels = nullptr);
FrameFeatures fromMsg(const pplvo_msgs::features_t& msg);

}  // namespace pplvo::msgs
