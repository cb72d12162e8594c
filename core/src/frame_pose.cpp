#include "pplvo/core/frame_pose.h"

#include "pplvo/core/enum_names.h"

namespace pplvo {

namespace {
constexpr EnumName<TrackingStatus> kTrackingStatusNames[] = {
    {TrackingStatus::kFirstFrame, "first_frame"},
    {TrackingStatus::kTracking, "tracking"},
    {TrackingStatus::kVelocityModel, "velocity_model"},
    {TrackingStatus::kLost, "lost"},
    {TrackingStatus::kReinitialised, "reinitialised"}};
}  // namespace

const char* toString(TrackingStatus status) {
  return enumName(kTrackingStatusNames, status, "unknown");
}

}  // namespace pplvo
