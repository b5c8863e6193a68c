/// @file nav_state.cpp
/// Small helpers of the navigation state (nav_state.h).

#include "planetary_vo/fusion/nav_state.h"

#include <cmath>

namespace planetary_vo {

bool isFinite(const NavState& state) {
  return std::isfinite(state.timestamp_s) && state.T_world_body.matrix().allFinite() &&
         state.v_world_mps.allFinite() && state.gyro_bias_radps.allFinite() &&
         state.accel_bias_mps2.allFinite();
}

}  // namespace planetary_vo
