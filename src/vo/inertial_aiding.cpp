#include "planetary_vo/vo/inertial_aiding.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

namespace planetary_vo {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

std::string str(double v) { return std::to_string(v); }

}  // namespace

InertialAiding::InertialAiding(const ImuAidingConfig& config)
    : config_(config), gravity_world_(0.0, 0.0, -config.gravity_mps2) {
  noise_.gyro_noise_density_radps_per_sqrt_hz = config.gyro_noise_density_radps_per_sqrt_hz;
  noise_.accel_noise_density_mps2_per_sqrt_hz = config.accel_noise_density_mps2_per_sqrt_hz;
  noise_.gyro_random_walk_radps2_per_sqrt_hz = config.gyro_random_walk_radps2_per_sqrt_hz;
  noise_.accel_random_walk_mps3_per_sqrt_hz = config.accel_random_walk_mps3_per_sqrt_hz;
  validate(noise_);
  T_cam_imu_.linear() = (Eigen::AngleAxisd(config.cam_imu_yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(config.cam_imu_pitch_deg * kDegToRad, Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(config.cam_imu_roll_deg * kDegToRad, Eigen::Vector3d::UnitX()))
                            .toRotationMatrix();
  T_cam_imu_.translation() = Eigen::Vector3d(config.cam_imu_x_m, config.cam_imu_y_m, config.cam_imu_z_m);
}

void InertialAiding::add(const ImuSample& sample) {
  if (!std::isfinite(sample.timestamp_s)) throw std::invalid_argument("IMU sample: non-finite timestamp");
  if (!sample.angular_velocity_radps.allFinite() || !sample.specific_force_mps2.allFinite())
    throw std::invalid_argument("IMU sample at t = " + str(sample.timestamp_s) + " s: non-finite value");
  // Issue 12 (fuzz test): one finite but absurd sample (1e300 m/s^2) made the propagated state infinite for
  // good, every later image refused. No IMU measures beyond these bounds (a tactical gyro saturates near
  // 35 rad/s, a lander's accelerometer near 500 m/s^2): such a sample is corrupt.
  if (!(sample.angular_velocity_radps.norm() <= kMaxAngularRateRadps) ||
      !(sample.specific_force_mps2.norm() <= kMaxSpecificForceMps2))
    throw std::invalid_argument("IMU sample at t = " + str(sample.timestamp_s) + " s: angular rate " +
                                str(sample.angular_velocity_radps.norm()) + " rad/s or specific force " +
                                str(sample.specific_force_mps2.norm()) + " m/s^2 beyond any IMU's range (" +
                                str(kMaxAngularRateRadps) + " rad/s, " + str(kMaxSpecificForceMps2) +
                                " m/s^2)");
  ImuSample s = sample;
  s.timestamp_s -= config_.time_offset_s;
  if (first_ < samples_.size() && !(s.timestamp_s > samples_.back().timestamp_s))
    throw std::invalid_argument("IMU sample at t = " + str(sample.timestamp_s) +
                                " s is not after the last one (" +
                                str(samples_.back().timestamp_s + config_.time_offset_s) + " s)");
  samples_.push_back(s);
  while (first_ < samples_.size() && samples_[first_].timestamp_s < s.timestamp_s - kHistoryS) ++first_;
  // Erase the expired head in batches, so that adding stays O(1) amortised.
  if (first_ > 4096 && first_ * 2 > samples_.size()) {
    samples_.erase(samples_.begin(), samples_.begin() + static_cast<std::ptrdiff_t>(first_));
    first_ = 0;
  }
}

std::string InertialAiding::coverageProblem(double t0_s, double t1_s) const {
  if (!(t1_s > t0_s)) return "empty interval";
  if (first_ >= samples_.size()) return "no IMU samples";
  const auto begin = samples_.begin() + static_cast<std::ptrdiff_t>(first_);
  const double max_gap = config_.max_gap_s;
  if (begin->timestamp_s > t0_s + 1e-9) return "the IMU buffer starts after " + str(t0_s) + " s";
  if (samples_.back().timestamp_s < t1_s - max_gap) return "no IMU samples up to " + str(t1_s) + " s";
  // Last sample at or before t0 and first after t1: every step in between must be short.
  auto lo = std::upper_bound(begin, samples_.end(), t0_s,
                             [](double t, const ImuSample& s) { return t < s.timestamp_s; });
  --lo;
  auto hi = std::lower_bound(begin, samples_.end(), t1_s,
                             [](const ImuSample& s, double t) { return s.timestamp_s < t; });
  if (hi == samples_.end()) --hi;
  for (auto it = lo; it != hi; ++it) {
    const double gap = (it + 1)->timestamp_s - it->timestamp_s;
    if (gap > max_gap) return "IMU gap of " + str(gap) + " s at " + str(it->timestamp_s) + " s";
  }
  return "";
}

std::shared_ptr<const ImuPreintegration> InertialAiding::preintegrate(double t0_s, double t1_s,
                                                                     const ImuBias& bias) const {
  if (!coverageProblem(t0_s, t1_s).empty()) return nullptr;
  // ImuPreintegration reads only the samples around and inside the interval (binary search), so the whole
  // buffer can be passed.
  return std::make_shared<const ImuPreintegration>(samples_, t0_s, t1_s, bias, noise_, config_.max_gap_s);
}

std::optional<NavState> InertialAiding::propagate(const NavState& state, double t_s) const {
  if (t_s == state.timestamp_s) return state;
  if (!coverageProblem(state.timestamp_s, t_s).empty()) return std::nullopt;
  return propagateNavState(state, samples_, t_s, gravity_world_, config_.max_gap_s);
}

NavState InertialAiding::bodyState(double t_s, const Pose& T_world_cam, const Eigen::Vector3d& v_world_mps,
                                   const ImuBias& bias) const {
  NavState s;
  s.timestamp_s = t_s;
  s.T_world_body = T_world_cam * T_cam_imu_;
  s.v_world_mps = v_world_mps;
  s.setBias(bias);
  return s;
}

}  // namespace planetary_vo
