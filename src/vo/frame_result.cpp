#include "planetary_vo/vo/frame_result.h"

namespace planetary_vo {

const char* toString(TrackingState state) {
  switch (state) {
    case TrackingState::kInitialising:
      return "initialising";
    case TrackingState::kTracking:
      return "tracking";
    case TrackingState::kLost:
      return "lost";
    case TrackingState::kRecovered:
      return "recovered";
  }
  return "unknown";
}

const char* toString(MotionEstimate motion) {
  switch (motion) {
    case MotionEstimate::kNone:
      return "none";
    case MotionEstimate::kFundamental:
      return "fundamental";
    case MotionEstimate::kEssential:
      return "essential";
    case MotionEstimate::kHomography:
      return "homography";
    case MotionEstimate::kPnp:
      return "pnp";
  }
  return "unknown";
}

const char* toString(ScaleSource source) {
  switch (source) {
    case ScaleSource::kNone:
      return "none";
    case ScaleSource::kAltimeter:
      return "altimeter";
    case ScaleSource::kImu:
      return "imu";
  }
  return "unknown";
}

}  // namespace planetary_vo
