#pragma once
/// pose_t <-> FramePose. fromMsg throws MessageError on non-finite values, an invalid rotation
/// or inconsistent window arrays, so no NaN pose enters a library.
#include <pplvo_msgs/odometry_t.hpp>
#include <pplvo_msgs/pose_t.hpp>

#include "pplvo/core/body_odometry.h"
#include "pplvo/core/frame_pose.h"
#include "pplvo/msgs/convert.h"

namespace pplvo::msgs {

pplvo_msgs::pose_t toMsg(const FramePose& pose);
FramePose fromMsg(const pplvo_msgs::pose_t& msg);

/// odometry_t <-> BodyOdometry (frame ids "odom" and "base_link"). fromMsg throws MessageError
/// on non-finite values, an invalid rotation or an unknown status.
pplvo_msgs::odometry_t toMsg(const BodyOdometry& odometry);
BodyOdometry fromMsg(const pplvo_msgs::odometry_t& msg);

}  // namespace pplvo::msgs
