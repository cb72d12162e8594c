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

void TrackingStatusCounts::add(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::kFirstFrame:
      ++first;
      break;
    case TrackingStatus::kTracking:
      ++tracking;
      break;
    case TrackingStatus::kVelocityModel:
      ++velocity_model;
      break;
    case TrackingStatus::kLost:
      ++lost;
      break;
    case TrackingStatus::kReinitialised:
      ++reinitialised;
      break;
  }
}

}  // namespace pplvo
