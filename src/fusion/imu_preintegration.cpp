/// @file imu_preintegration.cpp
/// On-manifold IMU preintegration (imu_preintegration.h; equations in docs/fusion/imu_preintegration.md).

#include "planetary_vo/fusion/imu_preintegration.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

namespace planetary_vo {
namespace {

// Below this angle the SO(3) functions use Taylor series (their closed forms lose digits to cancellation).
constexpr double kSmallAngleRad = 1e-3;
// Tolerance of predict() on the state's timestamp.
constexpr double kTimeToleranceS = 1e-6;

std::string str(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

void requireFinite(double v, const char* what) {
  if (!std::isfinite(v))
    throw std::invalid_argument(std::string("IMU preintegration: ") + what + " is not finite");
}

void checkSample(const ImuSample& s, size_t index) {
  if (!std::isfinite(s.timestamp_s) || !s.angular_velocity_radps.allFinite() ||
      !s.specific_force_mps2.allFinite())
    throw std::invalid_argument("IMU preintegration: sample " + std::to_string(index) +
                                " (t = " + str(s.timestamp_s) + " s) has a non-finite value");
}

void checkBias(const ImuBias& b) {
  if (!b.gyro_radps.allFinite() || !b.accel_mps2.allFinite())
    throw std::invalid_argument("IMU preintegration: the bias is not finite");
}

/// Linear interpolation of two samples at t (a.timestamp_s <= t <= b.timestamp_s, a before b).
ImuSample interpolate(const ImuSample& a, const ImuSample& b, double t) {
  const double u = (t - a.timestamp_s) / (b.timestamp_s - a.timestamp_s);
  ImuSample s;
  s.timestamp_s = t;
  s.angular_velocity_radps = (1.0 - u) * a.angular_velocity_radps + u * b.angular_velocity_radps;
  s.specific_force_mps2 = (1.0 - u) * a.specific_force_mps2 + u * b.specific_force_mps2;
  return s;
}

/// The value of the (piecewise linear) IMU signal at t: interpolated between the bracketing samples, or the
/// nearest sample held when t lies outside them (the caller has checked the hold distance).
ImuSample signalAt(const std::vector<ImuSample>& samples, size_t first, size_t last, double t) {
  if (t <= samples[first].timestamp_s) {
    ImuSample s = samples[first];
    s.timestamp_s = t;
    return s;
  }
  if (t >= samples[last].timestamp_s) {
    ImuSample s = samples[last];
    s.timestamp_s = t;
    return s;
  }
  // first sample with timestamp > t within [first, last]
  const auto it = std::upper_bound(samples.begin() + first, samples.begin() + last + 1, t,
                                   [](double v, const ImuSample& s) { return v < s.timestamp_s; });
  const size_t k = static_cast<size_t>(it - samples.begin());
  return interpolate(samples[k - 1], samples[k], t);
}

/// The knots of [t0, t1]: the signal at t0, every sample strictly inside, the signal at t1. Validates the
/// samples read, the times and the hold distance.
std::vector<ImuSample> extractKnots(const std::vector<ImuSample>& samples, double t0, double t1,
                                    double max_hold_s) {
  requireFinite(t0, "the start time");
  requireFinite(t1, "the end time");
  requireFinite(max_hold_s, "max_hold_s");
  if (max_hold_s < 0.0) throw std::invalid_argument("IMU preintegration: max_hold_s must be >= 0");
  if (!(t1 > t0))
    throw std::invalid_argument("IMU preintegration: the end time " + str(t1) +
                                " s must be after the start time " + str(t0) + " s");
  if (samples.empty()) throw std::invalid_argument("IMU preintegration: no IMU sample");
  const auto by_time = [](const ImuSample& s, double v) { return s.timestamp_s < v; };
  // Last sample at or before t0 (or the first sample) .. first sample at or after t1 (or the last sample).
  size_t first =
      static_cast<size_t>(std::lower_bound(samples.begin(), samples.end(), t0, by_time) - samples.begin());
  if (first == samples.size() || (first > 0 && samples[first].timestamp_s > t0))
    first = first > 0 ? first - 1 : 0;
  size_t last =
      static_cast<size_t>(std::lower_bound(samples.begin(), samples.end(), t1, by_time) - samples.begin());
  if (last == samples.size()) last = samples.size() - 1;
  if (last < first) last = first;
  for (size_t k = first; k <= last; ++k) {
    checkSample(samples[k], k);
    if (k > first && !(samples[k].timestamp_s > samples[k - 1].timestamp_s))
      throw std::invalid_argument("IMU preintegration: sample timestamps must increase strictly (sample " +
                                  std::to_string(k) + " at " + str(samples[k].timestamp_s) + " s follows " +
                                  str(samples[k - 1].timestamp_s) + " s)");
  }
  if (samples[first].timestamp_s - t0 > max_hold_s)
    throw std::invalid_argument("IMU preintegration: the start time " + str(t0) +
                                " s is before the first sample (" + str(samples[first].timestamp_s) +
                                " s) by more than max_hold_s = " + str(max_hold_s) + " s");
  if (t1 - samples[last].timestamp_s > max_hold_s)
    throw std::invalid_argument("IMU preintegration: the end time " + str(t1) +
                                " s is after the last sample (" + str(samples[last].timestamp_s) +
                                " s) by more than max_hold_s = " + str(max_hold_s) + " s");
  std::vector<ImuSample> knots;
  knots.reserve(last - first + 2);
  knots.push_back(signalAt(samples, first, last, t0));
  for (size_t k = first; k <= last; ++k)
    if (samples[k].timestamp_s > t0 && samples[k].timestamp_s < t1) knots.push_back(samples[k]);
  knots.push_back(signalAt(samples, first, last, t1));
  return knots;
}

/// Unit quaternion of the rotation vector phi.
Eigen::Quaterniond expQuaternion(const Eigen::Vector3d& phi) {
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  double w, sinc_half;  // cos(theta/2), sin(theta/2)/theta
  if (theta < kSmallAngleRad) {
    w = 1.0 - theta2 / 8.0 + theta2 * theta2 / 384.0;
    sinc_half = 0.5 - theta2 / 48.0 + theta2 * theta2 / 3840.0;
  } else {
    w = std::cos(0.5 * theta);
    sinc_half = std::sin(0.5 * theta) / theta;
  }
  const Eigen::Vector3d v = sinc_half * phi;
  return Eigen::Quaterniond(w, v.x(), v.y(), v.z());
}

/// Everything the integration of a knot sequence produces.
struct IntegrationResult {
  Eigen::Matrix3d dR = Eigen::Matrix3d::Identity();
  Eigen::Vector3d dv = Eigen::Vector3d::Zero(), dp = Eigen::Vector3d::Zero();
  Eigen::Matrix3d dR_dbg = Eigen::Matrix3d::Zero(), dv_dbg = Eigen::Matrix3d::Zero(),
                  dv_dba = Eigen::Matrix3d::Zero(), dp_dbg = Eigen::Matrix3d::Zero(),
                  dp_dba = Eigen::Matrix3d::Zero();
  ImuPreintegration::Matrix15d covariance = ImuPreintegration::Matrix15d::Zero();
};

/// The midpoint scheme of imu_preintegration.h over the knots. With `linearize` false only the deltas.
IntegrationResult integrateKnots(const std::vector<ImuSample>& knots, const ImuBias& bias,
                                 const ImuNoiseParams& noise, bool linearize) {
  IntegrationResult r;
  Eigen::Quaterniond dq = Eigen::Quaterniond::Identity();
  const double ng2 = std::pow(noise.gyro_noise_density_radps_per_sqrt_hz, 2);
  const double na2 = std::pow(noise.accel_noise_density_mps2_per_sqrt_hz, 2);
  const double nbg2 = std::pow(noise.gyro_random_walk_radps2_per_sqrt_hz, 2);
  const double nba2 = std::pow(noise.accel_random_walk_mps3_per_sqrt_hz, 2);
  using Matrix15d = ImuPreintegration::Matrix15d;
  Matrix15d F;
  Eigen::Matrix<double, 15, 12> G;
  for (size_t k = 0; k + 1 < knots.size(); ++k) {
    const ImuSample& a = knots[k];
    const ImuSample& b = knots[k + 1];
    const double dt = b.timestamp_s - a.timestamp_s;
    const Eigen::Vector3d w = 0.5 * (a.angular_velocity_radps + b.angular_velocity_radps) - bias.gyro_radps;
    const Eigen::Vector3d f = 0.5 * (a.specific_force_mps2 + b.specific_force_mps2) - bias.accel_mps2;
    const Eigen::Vector3d theta = w * dt;
    const Eigen::Quaterniond q_half = expQuaternion(0.5 * theta);
    const Eigen::Quaterniond q_full = q_half * q_half;
    const Eigen::Matrix3d R_half = q_half.toRotationMatrix();
    const Eigen::Matrix3d dR_old = r.dR;
    const Eigen::Vector3d f_half = R_half * f;  // mean specific force in the body frame of the step start
    const Eigen::Vector3d acc = dR_old * f_half;

    if (linearize) {
      // Error-state transition of one step (right perturbation dR = dR_true Exp(dphi)):
      //   dphi' = A dphi + Bw dw;   dv' = dv + dt (Cphi dphi + Cw dw + Cf df);   dp' = dp + dt dv + dt^2/2
      //   (...)
      // with dw, df the errors of the mean gyro and accelerometer inputs (dw = -dbg - noise, ...).
      const Eigen::Matrix3d A = q_full.toRotationMatrix().transpose();
      const Eigen::Matrix3d Bw = rightJacobianSO3(theta) * dt;
      const Eigen::Matrix3d Cphi = -dR_old * skew(f_half);
      const Eigen::Matrix3d Cw = -dR_old * R_half * skew(f) * rightJacobianSO3(0.5 * theta) * (0.5 * dt);
      const Eigen::Matrix3d Cf = dR_old * R_half;
      const double hdt2 = 0.5 * dt * dt;

      // Bias Jacobians (the bias error enters as dw = -dbg, df = -dba); old values on the right-hand side.
      r.dp_dbg += dt * r.dv_dbg + hdt2 * (Cphi * r.dR_dbg - Cw);
      r.dp_dba += dt * r.dv_dba - hdt2 * Cf;
      r.dv_dbg += dt * (Cphi * r.dR_dbg - Cw);
      r.dv_dba -= dt * Cf;
      r.dR_dbg = A * r.dR_dbg - Bw;

      // Covariance of [dphi, dv, dp, dbg, dba]: the errors of the measured deltas and the bias drift
      // b(t) - b(t_i), a random walk that adds to the inputs (dw = dbg + noise, df = dba + noise).
      F.setIdentity();
      F.block<3, 3>(0, 0) = A;
      F.block<3, 3>(0, 9) = Bw;
      F.block<3, 3>(3, 0) = dt * Cphi;
      F.block<3, 3>(3, 9) = dt * Cw;
      F.block<3, 3>(3, 12) = dt * Cf;
      F.block<3, 3>(6, 0) = hdt2 * Cphi;
      F.block<3, 3>(6, 3) = dt * Eigen::Matrix3d::Identity();
      F.block<3, 3>(6, 9) = hdt2 * Cw;
      F.block<3, 3>(6, 12) = hdt2 * Cf;
      G.setZero();
      G.block<3, 3>(0, 0) = Bw;
      G.block<3, 3>(3, 0) = dt * Cw;
      G.block<3, 3>(3, 3) = dt * Cf;
      G.block<3, 3>(6, 0) = hdt2 * Cw;
      G.block<3, 3>(6, 3) = hdt2 * Cf;
      G.block<3, 3>(9, 6).setIdentity();
      G.block<3, 3>(12, 9).setIdentity();
      Eigen::Matrix<double, 12, 1> q;
      q << Eigen::Vector3d::Constant(ng2 / dt), Eigen::Vector3d::Constant(na2 / dt),
          Eigen::Vector3d::Constant(nbg2 * dt), Eigen::Vector3d::Constant(nba2 * dt);
      r.covariance = F * r.covariance * F.transpose() + G * q.asDiagonal() * G.transpose();
    }

    r.dp += r.dv * dt + 0.5 * acc * dt * dt;
    r.dv += acc * dt;
    dq = (dq * q_full).normalized();
    r.dR = dq.toRotationMatrix();
  }
  r.covariance = 0.5 * (r.covariance + r.covariance.transpose()).eval();
  return r;
}

}  // namespace

void validate(const ImuNoiseParams& noise) {
  const std::pair<const char*, double> fields[] = {
      {"gyro_noise_density_radps_per_sqrt_hz", noise.gyro_noise_density_radps_per_sqrt_hz},
      {"accel_noise_density_mps2_per_sqrt_hz", noise.accel_noise_density_mps2_per_sqrt_hz},
      {"gyro_random_walk_radps2_per_sqrt_hz", noise.gyro_random_walk_radps2_per_sqrt_hz},
      {"accel_random_walk_mps3_per_sqrt_hz", noise.accel_random_walk_mps3_per_sqrt_hz}};
  for (const auto& [name, value] : fields)
    if (!std::isfinite(value) || value < 0.0)
      throw std::invalid_argument(std::string("IMU noise: ") + name + " = " + str(value) +
                                  " must be finite and >= 0");
}

// ---------------------------------------------------------------------------------------------------------
// SO(3)
// ---------------------------------------------------------------------------------------------------------

Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi) { return expQuaternion(phi).toRotationMatrix(); }

Eigen::Vector3d logSO3(const Eigen::Matrix3d& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() *= -1.0;
  const double n = q.vec().norm();
  // theta = 2 atan2(n, w); phi = theta * vec / n, with atan2(n, w) / n -> 1 / w for small n.
  if (n < 1e-10) return (2.0 / q.w()) * q.vec();
  return (2.0 * std::atan2(n, q.w()) / n) * q.vec();
}

Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& phi) {
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  double c1, c2;  // (1 - cos t) / t^2, (t - sin t) / t^3
  if (t < kSmallAngleRad) {
    c1 = 0.5 - t2 / 24.0 + t2 * t2 / 720.0;
    c2 = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0;
  } else {
    c1 = (1.0 - std::cos(t)) / t2;
    c2 = (t - std::sin(t)) / (t2 * t);
  }
  const Eigen::Matrix3d S = skew(phi);
  return Eigen::Matrix3d::Identity() - c1 * S + c2 * S * S;
}

Eigen::Matrix3d rightJacobianInverseSO3(const Eigen::Vector3d& phi) {
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  double c;  // 1 / t^2 - (1 + cos t) / (2 t sin t)
  if (t < kSmallAngleRad)
    c = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0;
  else
    c = 1.0 / t2 - (1.0 + std::cos(t)) / (2.0 * t * std::sin(t));
  const Eigen::Matrix3d S = skew(phi);
  return Eigen::Matrix3d::Identity() + 0.5 * S + c * S * S;
}

// ---------------------------------------------------------------------------------------------------------
// ImuPreintegration
// ---------------------------------------------------------------------------------------------------------

ImuPreintegration::ImuPreintegration(const std::vector<ImuSample>& samples, double t_start_s, double t_end_s,
                                     const ImuBias& bias, const ImuNoiseParams& noise, double max_hold_s)
    : t_start_s_(t_start_s), t_end_s_(t_end_s), bias_(bias), noise_(noise) {
  validate(noise);
  checkBias(bias);
  knots_ = extractKnots(samples, t_start_s, t_end_s, max_hold_s);
  integrate();
}

void ImuPreintegration::repropagate(const ImuBias& bias) {
  checkBias(bias);
  bias_ = bias;
  integrate();
}

void ImuPreintegration::integrate() {
  const IntegrationResult r = integrateKnots(knots_, bias_, noise_, true);
  dR_ = r.dR;
  dv_ = r.dv;
  dp_ = r.dp;
  dR_dbg_ = r.dR_dbg;
  dv_dbg_ = r.dv_dbg;
  dv_dba_ = r.dv_dba;
  dp_dbg_ = r.dp_dbg;
  dp_dba_ = r.dp_dba;
  covariance_ = r.covariance;
}

ImuPreintegration::Deltas ImuPreintegration::correctedDeltas(const ImuBias& bias) const {
  checkBias(bias);
  const Eigen::Vector3d dbg = bias.gyro_radps - bias_.gyro_radps;
  const Eigen::Vector3d dba = bias.accel_mps2 - bias_.accel_mps2;
  Deltas d;
  d.dR = dR_ * expSO3(dR_dbg_ * dbg);
  d.dv_mps = dv_ + dv_dbg_ * dbg + dv_dba_ * dba;
  d.dp_m = dp_ + dp_dbg_ * dbg + dp_dba_ * dba;
  return d;
}

NavState ImuPreintegration::predict(const NavState& state_i,
                                    const Eigen::Vector3d& gravity_world_mps2) const {
  if (!isFinite(state_i) || !gravity_world_mps2.allFinite())
    throw std::invalid_argument("IMU preintegration: predict() with a non-finite state or gravity");
  if (std::abs(state_i.timestamp_s - t_start_s_) > kTimeToleranceS)
    throw std::invalid_argument("IMU preintegration: predict() from a state at " + str(state_i.timestamp_s) +
                                " s, but the preintegration starts at " + str(t_start_s_) + " s");
  const Deltas d = correctedDeltas(state_i.bias());
  const double dt = deltaTime_s();
  const Eigen::Matrix3d R_i = state_i.T_world_body.linear();
  const Eigen::Vector3d& p_i = state_i.T_world_body.translation();
  NavState j = state_i;
  j.timestamp_s = t_end_s_;
  Eigen::Quaterniond q_j(R_i * d.dR);
  q_j.normalize();
  j.T_world_body.linear() = q_j.toRotationMatrix();
  j.T_world_body.translation() =
      p_i + state_i.v_world_mps * dt + 0.5 * gravity_world_mps2 * dt * dt + R_i * d.dp_m;
  j.v_world_mps = state_i.v_world_mps + gravity_world_mps2 * dt + R_i * d.dv_mps;
  return j;
}

ImuPreintegration::Vector9d ImuPreintegration::residual(const NavState& state_i, const NavState& state_j,
                                                        const Eigen::Vector3d& gravity_world_mps2) const {
  const Deltas d = correctedDeltas(state_i.bias());
  const double dt = deltaTime_s();
  const Eigen::Matrix3d R_i = state_i.T_world_body.linear();
  const Eigen::Matrix3d R_j = state_j.T_world_body.linear();
  const Eigen::Vector3d& p_i = state_i.T_world_body.translation();
  const Eigen::Vector3d& p_j = state_j.T_world_body.translation();
  Vector9d r;
  r.segment<3>(kRotation) = logSO3(d.dR.transpose() * R_i.transpose() * R_j);
  r.segment<3>(kVelocity) =
      R_i.transpose() * (state_j.v_world_mps - state_i.v_world_mps - gravity_world_mps2 * dt) - d.dv_mps;
  r.segment<3>(kPosition) =
      R_i.transpose() * (p_j - p_i - state_i.v_world_mps * dt - 0.5 * gravity_world_mps2 * dt * dt) - d.dp_m;
  return r;
}

NavState propagateNavState(const NavState& state, const std::vector<ImuSample>& samples, double t_end_s,
                           const Eigen::Vector3d& gravity_world_mps2, double max_hold_s) {
  if (!isFinite(state) || !gravity_world_mps2.allFinite())
    throw std::invalid_argument("IMU propagation: non-finite state or gravity");
  requireFinite(t_end_s, "the end time");
  if (t_end_s < state.timestamp_s)
    throw std::invalid_argument("IMU propagation: the end time " + str(t_end_s) +
                                " s is before the state's time " + str(state.timestamp_s) + " s");
  if (t_end_s == state.timestamp_s) return state;
  const IntegrationResult r =
      integrateKnots(extractKnots(samples, state.timestamp_s, t_end_s, max_hold_s), state.bias(), {}, false);
  const double dt = t_end_s - state.timestamp_s;
  const Eigen::Matrix3d R_i = state.T_world_body.linear();
  NavState j = state;
  j.timestamp_s = t_end_s;
  Eigen::Quaterniond q_j(R_i * r.dR);
  q_j.normalize();
  j.T_world_body.linear() = q_j.toRotationMatrix();
  j.T_world_body.translation() = state.T_world_body.translation() + state.v_world_mps * dt +
                                 0.5 * gravity_world_mps2 * dt * dt + R_i * r.dp;
  j.v_world_mps = state.v_world_mps + gravity_world_mps2 * dt + R_i * r.dv;
  return j;
}

}  // namespace planetary_vo
