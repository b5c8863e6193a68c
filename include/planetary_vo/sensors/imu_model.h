#pragma once
/// @file imu_model.h
/// IMU error model of the flight-like benchmark: turns the true angular velocity and specific force of the
/// vehicle body into what a real gyro and accelerometer triad would output, so that visual-inertial methods
/// are scored on realistic inertial data. See docs/sensors/imu.md for the equations, the datasheets behind
/// the named grades and the Allan deviation checks.
///
/// Per triad (gyro, accelerometer), in the IMU frame:
///   measured = sat(quant( M * (R_imu_body * truth) + b(t) + n ))
///   M    = I + diag(scale errors) + off-diagonal misalignments      (drawn once per run from the seed)
///   b(t) = turn-on bias (constant per run) + bias-instability process + rate random walk
///   n    = white noise, sigma = white_noise_density * sqrt(rate_hz) per sample
/// The bias-instability process is a sum of first-order Gauss-Markov processes with correlation times one
/// decade apart around bias_instability_correlation_s (an approximation of flicker noise): its Allan
/// deviation is 0.664 B within +-2 % over [T/10, 10 T] and within 10 % over [T/64, 205 T] (IEEE Std 952
/// convention). The true total bias b(t) of every sample is available through trueErrors() for the
/// ground-truth file that only the evaluator reads.
///
/// Randomness: every run constant and every noise stream comes from its own std::mt19937_64 seeded from
/// (seed, stream id); the samples are drawn in the fixed order of the measure() calls, so the same seed,
/// parameters and rate give bit-identical output, and switching one error term off leaves the others
/// unchanged.

#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>
#include <Eigen/Core>

#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo::sensors {

/// sqrt(2 ln 2 / pi) = 0.6643: Allan deviation of flicker (bias-instability) noise of coefficient B (IEEE
/// Std 952-1997, Annex C).
double ieeeBiasInstabilityFactor();

/// Errors of one triad (gyro or accelerometer). All 1-sigma, SI units, the same for each of the 3 axes.
struct ImuTriadErrors {
  /// White noise density: gyro rad/s/sqrt(Hz) (= angle random walk in rad/sqrt(s)); accelerometer
  /// m/s^2/sqrt(Hz) (= velocity random walk in m/s/sqrt(s)). Allan deviation N / sqrt(tau).
  double white_noise_density = 0.0;
  /// IEEE bias instability B (rad/s or m/s^2): the Allan deviation plateau is 0.664 B.
  double bias_instability = 0.0;
  /// Centre T (s) of the bias-instability process: the plateau is within 2 % over [T/10, 10 T].
  double bias_instability_correlation_s = 100.0;
  /// Rate random walk K: gyro rad/s^2/sqrt(Hz), accelerometer m/s^3/sqrt(Hz). Allan deviation K sqrt(tau/3).
  double bias_random_walk = 0.0;
  /// Turn-on bias (rad/s or m/s^2): constant for a run, drawn N(0, value^2) per axis.
  double turn_on_bias = 0.0;
  /// Relative scale factor error, drawn N(0, value^2) per axis (100 ppm = 1e-4).
  double scale_factor = 0.0;
  /// Axis misalignment / non-orthogonality (rad), drawn N(0, value^2) per off-diagonal element of M.
  double misalignment_rad = 0.0;
  /// Output resolution (LSB, rad/s or m/s^2): the output is rounded to a multiple of it. 0 = none.
  double quantization = 0.0;
  /// Saturation |value| per axis (rad/s or m/s^2). 0 = none.
  double range = 0.0;
};

struct ImuErrorParams {
  bool enabled = false;  ///< false: measure() returns the truth bit for bit (the "ideal" grade)
  std::string grade;     ///< grade the values started from (imuGrade), "" when set by hand
  ImuTriadErrors gyro;   ///< angular velocity errors (rad/s based units)
  ImuTriadErrors accel;  ///< specific force errors (m/s^2 based units)
  /// 1-sigma per axis of the small rotation of the IMU frame against the body frame (rad), drawn per run.
  double mounting_misalignment_rad = 0.0;
};

/// Throws std::invalid_argument naming the first field out of range: every value finite and >= 0,
/// correlation time > 0, scale factor and angles <= 0.1 (small-error model), range >= quantization.
void validate(const ImuErrorParams& params);

/// Named grades: "ideal" (disabled), "navigation" (Honeywell HG9900), "tactical" (Safran Sensonor STIM300),
/// "mems" (Analog Devices ADIS16448). The values and their datasheet sources are listed in
/// docs/sensors/imu.md; this function is the single place where they live. Throws std::invalid_argument
/// listing the valid names.
ImuErrorParams imuGrade(const std::string& name);
std::vector<std::string> imuGradeNames();

/// Overrides the parameters present in `node` (a map): `grade: NAME` first replaces all values with the
/// grade's, then enabled, mounting_misalignment_rad and the nested maps gyro: and accel: (keys = the field
/// names of ImuTriadErrors) override single values. Throws std::invalid_argument naming the key for an
/// unknown key, a non-scalar where a scalar is expected, an unparsable value, or a value that fails
/// validate(). A null node changes nothing.
void readYaml(const YAML::Node& node, ImuErrorParams* params);
/// Every field (readYaml(toYaml(p)) reproduces p exactly).
YAML::Node toYaml(const ImuErrorParams& params);

/// Analytic Allan deviation of the stochastic errors of one triad (white noise, bias instability, rate
/// random walk; not quantisation) at averaging time tau_s: the curve the simulated output must follow.
double modelAllanDeviation(const ImuTriadErrors& triad, double tau_s);

/// IMU error model of one run. Call measure() once per IMU sample at the fixed rate, in time order.
class ImuErrorModel {
 public:
  /// Number of Gauss-Markov processes of the bias-instability process (correlation times T * 10^(k-2)).
  static constexpr int kInstabilityProcesses = 5;

  /// Draws the run constants (mounting rotation, M, turn-on biases) and the initial state of the
  /// bias-instability processes from `seed`. Throws std::invalid_argument for invalid params or rate_hz <= 0.
  ImuErrorModel(const ImuErrorParams& params, double rate_hz, uint64_t seed);

  /// Measured sample (IMU frame) for the true one (body frame, same timestamp), then advances the bias
  /// processes by one period 1/rate_hz.
  ImuSample measure(const ImuSample& truth);

  /// Total bias (turn-on + instability + random walk, IMU frame) that was added to the last measured sample
  /// (before white noise, quantisation and saturation); zero before the first sample and when disabled.
  struct TrueErrors {
    Eigen::Vector3d gyro_bias_radps = Eigen::Vector3d::Zero();
    Eigen::Vector3d accel_bias_mps2 = Eigen::Vector3d::Zero();
  };
  const TrueErrors& trueErrors() const { return true_errors_; }

  const Eigen::Matrix3d& R_imu_body() const { return R_imu_body_; }  ///< mounting rotation of this run
  /// M_g: measured gyro = M_g * R_imu_body * w + b + n (before quantisation and saturation).
  const Eigen::Matrix3d& gyroScaleMisalignment() const { return gyro_.M; }
  const Eigen::Matrix3d& accelScaleMisalignment() const { return accel_.M; }
  const ImuErrorParams& params() const { return params_; }
  double rateHz() const { return rate_hz_; }

 private:
  struct Triad {
    ImuTriadErrors errors;
    Eigen::Matrix3d M = Eigen::Matrix3d::Identity();
    Eigen::Vector3d turn_on = Eigen::Vector3d::Zero();
    std::array<Eigen::Vector3d, kInstabilityProcesses> markov;  ///< Gauss-Markov states
    std::array<double, kInstabilityProcesses> markov_phi{};     ///< exp(-dt / T_k)
    std::array<double, kInstabilityProcesses> markov_drive{};   ///< sigma_k sqrt(1 - phi_k^2)
    Eigen::Vector3d random_walk = Eigen::Vector3d::Zero();
    double white_sigma = 0.0;       ///< per-sample white noise sigma
    double random_walk_step = 0.0;  ///< K sqrt(dt)
    std::mt19937_64 white_rng, markov_rng, walk_rng;
    std::normal_distribution<double> white_normal, markov_normal, walk_normal;
  };
  void initTriad(const ImuTriadErrors& errors, uint64_t seed, uint64_t stream, std::mt19937_64* constants_rng,
                 std::normal_distribution<double>* constants_normal, Triad* triad) const;
  static Eigen::Vector3d bias(const Triad& triad);
  static Eigen::Vector3d output(Triad* triad, const Eigen::Vector3d& in_imu, const Eigen::Vector3d& bias);
  static void advance(Triad* triad);

  ImuErrorParams params_;
  double rate_hz_;
  Eigen::Matrix3d R_imu_body_ = Eigen::Matrix3d::Identity();
  Triad gyro_, accel_;
  TrueErrors true_errors_;
};

}  // namespace planetary_vo::sensors
