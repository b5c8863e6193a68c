#pragma once
/// @file imu_preintegration.h
/// On-manifold IMU preintegration (Forster, Carlone, Dellaert, Scaramuzza, "On-Manifold Preintegration for
/// Real-Time Visual-Inertial Odometry", IEEE TRO 2017) between two instants t_i < t_j, and the IMU-rate
/// propagation of a NavState. The equations actually implemented are in docs/fusion/imu_preintegration.md.
///
/// What it computes, in the body frame of t_i, at a fixed linearisation bias b^ = (bg^, ba^):
///   dR = R_i^T R_j,  dv = R_i^T (v_j - v_i - g dt_ij),  dp = R_i^T (p_j - p_i - v_i dt_ij - g dt_ij^2 / 2)
/// (independent of the state at i and of gravity), their Jacobians w.r.t. the biases for the first-order bias
/// correction  dR(b) = dR^ Exp(dR/dbg (bg - bg^)),  dv(b) = dv^ + dv/dbg (bg - bg^) + dv/dba (ba - ba^),
/// likewise dp, and the 15x15 covariance of [dphi, dv, dp, dbg, dba]: the errors of the measured deltas
/// (dR = dR_true Exp(dphi), dv = dv_true + dv, ...) and the bias drift over the interval, b(t_j) - b(t_i).
///
/// Integration scheme (second order): between two consecutive samples k, k+1 the signals are taken as linear
/// in time, i.e. each step uses the mean of the two samples, w = (w_k + w_k+1)/2 - bg and
/// f = (f_k + f_k+1)/2 - ba, and the rotation at the middle of the step for the acceleration:
///   dR_k+1 = dR_k Exp(w dt);   a = dR_k Exp(w dt / 2) f;   dp_k+1 = dp_k + dv_k dt + a dt^2 / 2;
///   dv_k+1 = dv_k + a dt.
/// Its error on smooth motion is O(dt^2): against the Lunar descent trajectories at 200 Hz over 1 to 2 s it
/// is below 5e-8 rad, 2.1e-7 m/s and 9.3e-7 m; the first-order (Euler) scheme of the paper would be O(dt)
/// (~1e-4 rad on the Main Brake pitch manoeuvre).
///
/// Interval ends: samples straddling t_i or t_j are LINEARLY INTERPOLATED to t_i and t_j, so the deltas
/// cover exactly [t_i, t_j] whatever the IMU phase. Only if an end lies outside the samples (up to
/// `max_hold_s`) is the nearest sample HELD (extrapolated as constant) over the gap.
///
/// Noise model: per axis, continuous white noise of density sigma_g (rad/s/sqrt(Hz)) on the gyro and sigma_a
/// (m/s^2/sqrt(Hz)) on the accelerometer, discretised per step as variance sigma^2 / dt; bias random walks of
/// density sigma_bg (rad/s^2/sqrt(Hz)) and sigma_ba (m/s^3/sqrt(Hz)), variance sigma_b^2 dt per step. These
/// are the keys gyro_noise_density_radps_per_sqrt_hz, accel_noise_density_mps2_per_sqrt_hz,
/// gyro_random_walk_radps2_per_sqrt_hz and accel_random_walk_mps3_per_sqrt_hz of a dataset's sensors.yaml.
///
/// Contract (imu_preintegration.cpp): bad input is a caller bug and throws std::invalid_argument with a
/// message naming it: an empty sample list; non-finite or non-increasing timestamps among the samples read
/// (the two samples bracketing each end and all samples in between; the list must be sorted by time); a
/// non-finite sample value, bias, time or noise parameter; a negative noise parameter or max_hold_s;
/// t_end_s <= t_start_s; an end further than max_hold_s outside the samples; predict() with a state whose
/// timestamp is not t_start_s (1e-6 s tolerance).

#include <vector>

#include <Eigen/Core>

#include "planetary_vo/fusion/measurements.h"
#include "planetary_vo/fusion/nav_state.h"
#include "planetary_vo/geometry/pose.h"  // skew()

namespace planetary_vo {

/// Noise densities of the IMU (continuous time, per axis, 1 sigma). Zero is allowed (an exact IMU); the
/// covariance is then zero too and cannot whiten a factor.
struct ImuNoiseParams {
  double gyro_noise_density_radps_per_sqrt_hz = 0.0;  ///< angle random walk
  double accel_noise_density_mps2_per_sqrt_hz = 0.0;  ///< velocity random walk
  double gyro_random_walk_radps2_per_sqrt_hz = 0.0;   ///< gyro bias random walk
  double accel_random_walk_mps3_per_sqrt_hz = 0.0;    ///< accelerometer bias random walk
};
/// Throws std::invalid_argument naming the first field that is negative or not finite.
void validate(const ImuNoiseParams& noise);

// ---------------------------------------------------------------------------------------------------------
// SO(3) helpers (rotation vectors in rad; exact closed forms with Taylor series below 1e-3 rad)
// ---------------------------------------------------------------------------------------------------------
/// (skew(v), the cross-product matrix, is in geometry/pose.h.)
/// Rotation matrix of the rotation vector phi (Rodrigues).
Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi);
/// Rotation vector of R, angle in [0, pi].
Eigen::Vector3d logSO3(const Eigen::Matrix3d& R);
/// Right Jacobian Jr(phi): Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d).
Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& phi);
/// Inverse of the right Jacobian: Log(Exp(phi) Exp(d)) ~ phi + Jr^-1(phi) d.
Eigen::Matrix3d rightJacobianInverseSO3(const Eigen::Vector3d& phi);

/// Preintegrated IMU measurements between two instants.
class ImuPreintegration {
 public:
  using Matrix9d = Eigen::Matrix<double, 9, 9>;
  using Matrix15d = Eigen::Matrix<double, 15, 15>;
  using Vector9d = Eigen::Matrix<double, 9, 1>;
  /// Offsets of the error blocks in covariance() (and of the rows of the 9-vector residuals).
  enum Block : int { kRotation = 0, kVelocity = 3, kPosition = 6, kGyroBias = 9, kAccelBias = 12 };

  /// The bias-corrected deltas (see correctedDeltas()).
  struct Deltas {
    Eigen::Matrix3d dR = Eigen::Matrix3d::Identity();
    Eigen::Vector3d dv_mps = Eigen::Vector3d::Zero();
    Eigen::Vector3d dp_m = Eigen::Vector3d::Zero();
  };

  /// Preintegrates `samples` (IMU frame, sorted by strictly increasing time) over [t_start_s, t_end_s] at the
  /// linearisation bias `bias`. The samples may extend beyond the interval (only the ones bracketing and
  /// inside it are read); an end may lie outside them by at most max_hold_s (the nearest sample is held).
  /// Throws std::invalid_argument (see the file comment).
  ImuPreintegration(const std::vector<ImuSample>& samples, double t_start_s, double t_end_s,
                    const ImuBias& bias, const ImuNoiseParams& noise, double max_hold_s = 0.0);

  /// Integrates the same samples again at a new linearisation bias (deltas, Jacobians and covariance), e.g.
  /// when an optimiser has moved the bias so far that the first-order correction is no longer accurate.
  void repropagate(const ImuBias& bias);

  double startTime_s() const { return t_start_s_; }
  double endTime_s() const { return t_end_s_; }
  double deltaTime_s() const { return t_end_s_ - t_start_s_; }
  const ImuBias& linearizationBias() const { return bias_; }
  const ImuNoiseParams& noise() const { return noise_; }
  /// The samples the integration steps through: the first at t_start_s and the last at t_end_s (interpolated
  /// or held), the original ones in between.
  const std::vector<ImuSample>& knots() const { return knots_; }

  /// Deltas at the linearisation bias.
  const Eigen::Matrix3d& deltaR() const { return dR_; }
  const Eigen::Vector3d& deltaV_mps() const { return dv_; }
  const Eigen::Vector3d& deltaP_m() const { return dp_; }
  /// Bias Jacobians at the linearisation bias (rotation: of the right-perturbation rotation vector).
  const Eigen::Matrix3d& dR_dbg() const { return dR_dbg_; }
  const Eigen::Matrix3d& dV_dbg() const { return dv_dbg_; }
  const Eigen::Matrix3d& dV_dba() const { return dv_dba_; }
  const Eigen::Matrix3d& dP_dbg() const { return dp_dbg_; }
  const Eigen::Matrix3d& dP_dba() const { return dp_dba_; }

  /// First-order bias correction of the deltas to `bias` (no re-integration).
  Deltas correctedDeltas(const ImuBias& bias) const;

  /// Covariance of [dphi, dv, dp, dbg, dba] at t_end (SI units, order of Block). The first 9x9 block is the
  /// preintegration noise (including the effect of the bias drifting inside the interval); the last 6x6
  /// block is the bias random walk over the interval, diag(sigma_bg^2, sigma_ba^2) * dt_ij.
  const Matrix15d& covariance() const { return covariance_; }
  Matrix9d preintegrationCovariance() const { return covariance_.topLeftCorner<9, 9>(); }
  Eigen::Matrix<double, 6, 6> biasRandomWalkCovariance() const {
    return covariance_.bottomRightCorner<6, 6>();
  }

  /// State at t_end_s from `state_i` (at t_start_s): pose, velocity from the deltas bias-corrected to
  /// state_i's biases, biases carried over unchanged. gravity_world_mps2: e.g. kLunarGravityWorldMps2.
  NavState predict(const NavState& state_i, const Eigen::Vector3d& gravity_world_mps2) const;

  /// Unwhitened residual [r_R, r_v, r_p] of the inertial factor between state_i (its biases are used for the
  /// correction) and state_j: r_R = Log(dR(b_i)^T R_i^T R_j), r_v = R_i^T (v_j - v_i - g dt) - dv(b_i),
  /// r_p = R_i^T (p_j - p_i - v_i dt - g dt^2 / 2) - dp(b_i). Zero when state_j = predict(state_i).
  Vector9d residual(const NavState& state_i, const NavState& state_j,
                    const Eigen::Vector3d& gravity_world_mps2) const;

 private:
  void integrate();

  double t_start_s_ = 0.0, t_end_s_ = 0.0;
  ImuBias bias_;
  ImuNoiseParams noise_;
  std::vector<ImuSample> knots_;
  Eigen::Matrix3d dR_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d dv_ = Eigen::Vector3d::Zero(), dp_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d dR_dbg_, dv_dbg_, dv_dba_, dp_dbg_, dp_dba_;
  Matrix15d covariance_ = Matrix15d::Zero();
};

/// IMU-rate propagation for the low-latency output between images: the state at t_end_s from `state` (at
/// state.timestamp_s) through `samples`, with the same scheme and interval-end handling as ImuPreintegration
/// and state's biases (carried over unchanged); no covariance is computed. t_end_s == state.timestamp_s
/// returns the state. Throws std::invalid_argument like ImuPreintegration (t_end_s < state.timestamp_s, a
/// non-finite state, samples not covering the span within max_hold_s, ...).
NavState propagateNavState(const NavState& state, const std::vector<ImuSample>& samples, double t_end_s,
                           const Eigen::Vector3d& gravity_world_mps2, double max_hold_s = 0.0);

}  // namespace planetary_vo
