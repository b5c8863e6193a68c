/// Tests of alignVisualInertial() on an analytic descent: keyframe poses of a map at an unknown scale, in a map
/// frame rotated away from gravity, and the IMU sampled from the same trajectory (with the flight IMU's white
/// noise and a gyro bias). The alignment must find the scale, the gravity direction, the velocities and the gyro
/// bias, and refuse a constant-velocity descent, where the accelerometer sees only gravity.

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "planetary_vo/vo/inertial_initializer.h"

namespace planetary_vo {
namespace {

constexpr double kImuRateHz = 200.0;
constexpr double kRadToDeg = 180.0 / M_PI;

struct Scene {
  InertialAlignmentInput input;
  double true_scale = 0.0;                   // metres per map unit
  Eigen::Vector3d true_gravity_map;          // gravity in the map frame
  std::vector<Eigen::Vector3d> true_v_map;   // velocities in the map frame
  Eigen::Vector3d gyro_bias;
};

/// Keyframes every 0.5 s over `duration_s` with the acceleration a(t) = accel + vary sin(1.5 t) (a throttled
/// engine) and an oscillating attitude; the map frame is the world rotated by `R_map_world` and scaled by
/// 1 / true_scale.
Scene makeScene(const Eigen::Vector3d& accel, const Eigen::Vector3d& vary, double duration_s, uint64_t seed) {
  constexpr double w = 1.5;
  auto acceleration = [&](double t) { return Eigen::Vector3d(accel + vary * std::sin(w * t)); };
  auto velocity = [&](double t, const Eigen::Vector3d& v0) {
    return Eigen::Vector3d(v0 + accel * t + vary * (1.0 - std::cos(w * t)) / w);
  };
  auto position = [&](double t, const Eigen::Vector3d& v0) {
    return Eigen::Vector3d(v0 * t + 0.5 * accel * t * t + vary * (t / w - std::sin(w * t) / (w * w)));
  };
  const Eigen::Vector3d gravity(0.0, 0.0, -1.62), c0(0.0, 0.0, 500.0), v0(30.0, 4.0, -6.0);
  auto R_world_cam = [](double t) {
    Eigen::Matrix3d nadir;
    nadir << 1, 0, 0, 0, -1, 0, 0, 0, -1;
    return Eigen::Matrix3d(Eigen::AngleAxisd(0.05 * std::sin(0.5 * t), Eigen::Vector3d::UnitZ()) *
                           Eigen::AngleAxisd(0.03 * std::sin(0.7 * t), Eigen::Vector3d::UnitX()) * nadir);
  };
  const Eigen::Matrix3d R_map_world =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  Scene s;
  s.true_scale = 37.5;
  s.gyro_bias = Eigen::Vector3d(2e-4, -1e-4, 3e-4);
  s.true_gravity_map = R_map_world * gravity;
  std::mt19937 rng(seed);
  std::normal_distribution<double> gyro_noise(0.0, 4.4e-5 * std::sqrt(kImuRateHz)),
      accel_noise(0.0, 1e-3 * std::sqrt(kImuRateHz));
  std::vector<ImuSample> imu;
  const double h = 1e-5;
  for (int k = 0; k <= static_cast<int>(duration_s * kImuRateHz); ++k) {
    const double t = k / kImuRateHz;
    ImuSample sample;
    sample.timestamp_s = t;
    sample.angular_velocity_radps =
        logSO3(R_world_cam(t - h).transpose() * R_world_cam(t + h)) / (2.0 * h) + s.gyro_bias +
        Eigen::Vector3d(gyro_noise(rng), gyro_noise(rng), gyro_noise(rng));
    sample.specific_force_mps2 = R_world_cam(t).transpose() * (acceleration(t) - gravity) +
                                 Eigen::Vector3d(accel_noise(rng), accel_noise(rng), accel_noise(rng));
    imu.push_back(sample);
  }
  ImuNoiseParams noise;
  noise.gyro_noise_density_radps_per_sqrt_hz = 4.4e-5;
  noise.accel_noise_density_mps2_per_sqrt_hz = 1e-3;
  noise.gyro_random_walk_radps2_per_sqrt_hz = 2.5e-8;
  noise.accel_random_walk_mps3_per_sqrt_hz = 1.6e-5;
  for (double t = 0.0; t <= duration_s + 1e-9; t += 0.5) {
    Pose T = Pose::Identity();
    T.linear() = R_map_world * R_world_cam(t);
    T.translation() = R_map_world * position(t, v0) / s.true_scale;
    s.input.timestamps_s.push_back(t);
    s.input.T_map_cam.push_back(T);
    s.true_v_map.push_back(R_map_world * velocity(t, v0));
    if (t > 0.0)
      s.input.preintegrations.push_back(
          std::make_shared<const ImuPreintegration>(imu, t - 0.5, t, ImuBias(), noise));
  }
  return s;
}

const Eigen::Vector3d kBraking(0.0, 3.0, -1.6), kThrottle(0.8, -1.0, 0.6);

TEST(InertialInitializer, RecoversScaleGravityVelocityAndGyroBias) {
  const Scene s = makeScene(kBraking, kThrottle, 4.0, 1);
  const InertialAlignment a = alignVisualInertial(s.input);
  ASSERT_TRUE(a.valid) << a.reason;
  const double scale_error = a.scale / s.true_scale - 1.0;
  const double gravity_error_deg =
      std::acos(std::min(1.0, a.gravity_map.normalized().dot(s.true_gravity_map.normalized()))) * kRadToDeg;
  double max_v_error = 0.0;
  for (size_t k = 0; k < s.true_v_map.size(); ++k)
    max_v_error = std::max(max_v_error, (a.velocities_map_mps[k] - s.true_v_map[k]).norm());
  std::printf("  scale error %.4f %% (1-sigma %.4f %%), gravity %.4f deg, velocity <= %.4f m/s, gyro bias error "
              "%.2e rad/s\n",
              100.0 * scale_error, 100.0 * a.scale_sigma, gravity_error_deg, max_v_error,
              (a.gyro_bias_radps - s.gyro_bias).norm());
  EXPECT_LT(std::abs(scale_error), 0.01);
  EXPECT_LT(gravity_error_deg, 0.1);
  EXPECT_LT(max_v_error, 0.1);
  // Eight 0.5 s intervals of a 4.4e-5 rad/s/sqrt(Hz) gyro: about 2e-5 rad/s per axis of noise.
  EXPECT_LT((a.gyro_bias_radps - s.gyro_bias).norm(), 1e-4);
  EXPECT_LT((a.gyro_bias_radps - s.gyro_bias).norm(), 0.3 * s.gyro_bias.norm());
  EXPECT_NEAR(a.gravity_map.norm(), 1.62, 1e-9);

  // The gravity direction known (a gravity-aligned map): the same scale.
  InertialAlignmentInput known = s.input;
  known.known_gravity_map = s.true_gravity_map;
  const InertialAlignment b = alignVisualInertial(known);
  ASSERT_TRUE(b.valid) << b.reason;
  EXPECT_LT(std::abs(b.scale / s.true_scale - 1.0), 0.01);
}

// Constant velocity: the accelerometer measures gravity only, the scale is not observable and is refused, also
// with the gravity direction known.
TEST(InertialInitializer, RefusesAConstantVelocityDescent) {
  const Scene s = makeScene(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 4.0, 2);
  const InertialAlignment a = alignVisualInertial(s.input);
  std::printf("  constant velocity: valid %d, scale %.3f of %.3f: %s\n", a.valid, a.scale, s.true_scale,
              a.reason.c_str());
  EXPECT_FALSE(a.valid);
  InertialAlignmentInput known = s.input;
  known.known_gravity_map = s.true_gravity_map;
  const InertialAlignment b = alignVisualInertial(known);
  std::printf("  constant velocity, gravity known: valid %d, scale %.3f of %.3f: %s\n", b.valid, b.scale,
              s.true_scale, b.reason.c_str());
  EXPECT_FALSE(b.valid);
}

// A constant braking acceleration: gravity and scale cannot be told apart without the attitude (refused), but
// with the gravity direction known (pose handed over) the scale is found.
TEST(InertialInitializer, ConstantAccelerationNeedsTheGravityDirection) {
  const Scene s = makeScene(kBraking, Eigen::Vector3d::Zero(), 4.0, 4);
  const InertialAlignment a = alignVisualInertial(s.input);
  EXPECT_FALSE(a.valid);
  InertialAlignmentInput known = s.input;
  known.known_gravity_map = s.true_gravity_map;
  const InertialAlignment b = alignVisualInertial(known);
  ASSERT_TRUE(b.valid) << b.reason;
  std::printf("  constant acceleration, gravity known: scale error %.4f %%\n", 100.0 * (b.scale / s.true_scale - 1));
  EXPECT_LT(std::abs(b.scale / s.true_scale - 1.0), 0.01);
}

TEST(InertialInitializer, RejectsInconsistentInput) {
  Scene s = makeScene(kBraking, kThrottle, 2.0, 3);
  InertialAlignmentInput bad = s.input;
  bad.preintegrations.pop_back();
  EXPECT_THROW(alignVisualInertial(bad), std::invalid_argument);
  bad = s.input;
  bad.timestamps_s[1] += 0.01;
  EXPECT_THROW(alignVisualInertial(bad), std::invalid_argument);
  bad = s.input;
  bad.preintegrations[0].reset();
  EXPECT_THROW(alignVisualInertial(bad), std::invalid_argument);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
