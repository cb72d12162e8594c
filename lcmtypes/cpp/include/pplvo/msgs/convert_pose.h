#pragma once
/// pose_t <-> FramePose. fromMsg throws MessageError on non-finite values, an invalid rotation
/// or inconsistent window arrays, so no NaN pose enters a library.
#include <pplvo_msgs/pose_t.hpp>

#include "pplvo/core/frame_pose.h"
#include "pplvo/msgs/convert.h"

namespace pplvo::msgs {

pplvo_msgs::pose_t toMsg(const FramePose& pose);
FramePose fromMsg(const pplvo_msgs::pose_t& msg);

}  // namespace pplvo::msgs
