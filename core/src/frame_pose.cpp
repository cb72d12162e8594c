#include "pplvo/core/frame_pose.h"

namespace pplvo {

const char* toString(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::kFirstFrame: return "first_frame";
    case TrackingStatus::kTracking: return "tracking";
    case TrackingStatus::kVelocityModel: return "velocity_model";
    case TrackingStatus::kLost: return "lost";
    case TrackingStatus::kReinitialised: return "reinitialised";
  }
  return "unknown";
}

}  // namespace pplvo
