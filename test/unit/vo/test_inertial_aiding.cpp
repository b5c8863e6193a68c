/// Tests of the IMU input of the camera + IMU mode (inertial_aiding.h): what add() refuses.

#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include "planetary_vo/vo/inertial_aiding.h"

namespace planetary_vo {
namespace {

ImuSample sample(double t, const Eigen::Vector3d& w, const Eigen::Vector3d& a) {
  ImuSample s;
  s.timestamp_s = t;
  s.angular_velocity_radps = w;
  s.specific_force_mps2 = a;
  return s;
}

// Issue 12, found by the fuzz test (vo_fuzz, seed 20261127): a finite but absurd sample (specific force
// 1e300 m/s^2) was accepted, and the propagated state became infinite for good (every later image refused
// with "IMU propagation: non-finite state or gravity"). Such samples are refused, the buffer unchanged.
TEST(InertialAiding, AbsurdSamplesThrowAndLeaveTheBufferUnchanged) {
  InertialAiding aiding{ImuAidingConfig()};
  const Eigen::Vector3d w(0.01, 0.0, 0.0), a(0.0, 0.0, 1.62);
  aiding.add(sample(1.0, w, a));
  EXPECT_THROW(aiding.add(sample(1.005, w, Eigen::Vector3d(0.0, 0.0, -1e300))), std::invalid_argument);
  EXPECT_THROW(aiding.add(sample(1.005, Eigen::Vector3d(1e6, 0.0, 0.0), a)), std::invalid_argument);
  EXPECT_THROW(aiding.add(sample(1.005, w, Eigen::Vector3d(std::nan(""), 0.0, 0.0))), std::invalid_argument);
  EXPECT_THROW(aiding.add(sample(1.0, w, a)), std::invalid_argument);  // not after the last one
  EXPECT_EQ(aiding.size(), 1u);
  // At the bounds: accepted (a violent but possible motion is the estimator's business, not the input
  // check's).
  aiding.add(sample(1.005, Eigen::Vector3d(InertialAiding::kMaxAngularRateRadps, 0.0, 0.0),
                    Eigen::Vector3d(0.0, 0.0, InertialAiding::kMaxSpecificForceMps2)));
  EXPECT_EQ(aiding.size(), 2u);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
