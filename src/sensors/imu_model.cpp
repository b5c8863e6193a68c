/// @file imu_model.cpp
/// IMU error model: named grades, YAML, the bias processes and the measurement equation.

#include "planetary_vo/sensors/imu_model.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <Eigen/Geometry>

namespace planetary_vo::sensors {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;    // rad per degree
constexpr double kHour = 3600.0;        // s per hour
constexpr double kSqrtHour = 60.0;      // sqrt(s) per sqrt(hour)
constexpr double kG0 = 9.80665;         // m/s^2 per g (standard gravity, the datasheets' g)
constexpr double kMaxSmallError = 0.1;  // scale factor and angles: the model is linear in them

// ---------------------------------------------------------------------------------------------------------
// Bias-instability process: kInstabilityProcesses Gauss-Markov processes of equal variance with correlation
// times T * 10^(k - 2), k = 0..4 (equal power per decade = flicker noise over about three decades).
// ---------------------------------------------------------------------------------------------------------
constexpr int kProcesses = ImuErrorModel::kInstabilityProcesses;

double correlationTime(double centre_s, int k) { return centre_s * std::pow(10.0, k - (kProcesses - 1) / 2); }

/// Allan variance of a unit-variance first-order Gauss-Markov process (continuous) at tau = x * T:
/// 2 [1/x - (3 - 4 e^-x + e^-2x) / (2 x^2)] (IEEE Std 952-1997, Annex C, exponentially correlated noise).
double markovAllanVariance(double x) {
  if (x < 1e-4) return 2.0 * x / 3.0;  // series: the closed form cancels catastrophically for small x
  return 2.0 * (1.0 / x - (3.0 - 4.0 * std::exp(-x) + std::exp(-2.0 * x)) / (2.0 * x * x));
}

/// Allan variance of the sum of the processes, each of unit variance, at tau = ratio * T.
double unitInstabilityAllanVariance(double ratio) {
  double sum = 0.0;
  for (int k = 0; k < kProcesses; ++k)
    sum += markovAllanVariance(ratio * std::pow(10.0, (kProcesses - 1) / 2 - k));
  return sum;
}

/// Standard deviation of each process such that the Allan deviation at tau = T is 0.664 B.
double instabilityProcessSigma(double bias_instability) {
  return ieeeBiasInstabilityFactor() * bias_instability / std::sqrt(unitInstabilityAllanVariance(1.0));
}

double roundTo2Digits(double x) {
  if (!(x > 0.0)) return x;
  const double scale = std::pow(10.0, std::floor(std::log10(x)) - 1.0);
  return std::round(x / scale) * scale;
}

/// Datasheets give N and B but neither a correlation time nor a rate random walk. Labelled typical choices
/// (docs/sensors/imu.md): the plateau centre T = 3 (N / 0.664 B)^2, at least 100 s, rounded to 2 digits (the
/// plateau, within 10 % from T/60, then starts at least a decade before the white noise line meets it); K
/// such that K sqrt(tau / 3) meets the plateau at tau = 30 T (the random walk then lifts the curve before the
/// bias-instability process fades beyond 200 T).
void placeInstabilityAndWalk(ImuTriadErrors* t) {
  const double floor_value = ieeeBiasInstabilityFactor() * t->bias_instability;
  const double crossing_s = std::pow(t->white_noise_density / floor_value, 2.0);
  t->bias_instability_correlation_s = roundTo2Digits(std::max(100.0, 3.0 * crossing_s));
  t->bias_random_walk = floor_value * std::sqrt(3.0 / (30.0 * t->bias_instability_correlation_s));
}

// ---------------------------------------------------------------------------------------------------------
// Grades: the single place where the datasheet values live. [D] datasheet value, [S] datasheet value as
// quoted by a named secondary source, [T] labelled typical value (not in the sources read); see
// docs/sensors/imu.md for the documents. Datasheets quote the bias (in)stability as the minimum of the
// measured Allan deviation (Sensonor and Analog Devices say so explicitly), so B = figure / 0.664.
// ---------------------------------------------------------------------------------------------------------

/// IEEE bias instability B of a datasheet figure that is the minimum of the Allan deviation.
double fromAllanMinimum(double allan_minimum) { return allan_minimum / ieeeBiasInstabilityFactor(); }

ImuErrorParams navigationGrade() {  // Honeywell HG9900 (ring laser gyro IMU)
  ImuErrorParams p;
  p.enabled = true;
  p.grade = "navigation";
  p.gyro.white_noise_density = 0.002 * kDeg / kSqrtHour;             // [S] ARW 0.002 deg/sqrt(h)
  p.gyro.bias_instability = fromAllanMinimum(0.003 * kDeg / kHour);  // [S] bias stability 0.003 deg/h
  p.gyro.turn_on_bias = 0.003 * kDeg / kHour;                // [T] = bias stability (no run-to-run figure)
  p.gyro.scale_factor = 5e-6;                                // [S] 5 ppm
  p.gyro.misalignment_rad = 10e-6;                           // [T] 10 urad
  p.accel.white_noise_density = 5e-6 * kG0;                  // [T] 5 ug/sqrt(Hz) (no VRW listed)
  p.accel.bias_instability = fromAllanMinimum(25e-6 * kG0);  // [S] bias 25 ug (the one bias figure)
  p.accel.turn_on_bias = 25e-6 * kG0;                        // [S] bias 25 ug
  p.accel.scale_factor = 100e-6;                             // [S] 100 ppm
  p.accel.misalignment_rad = 10e-6;                          // [T] 10 urad
  p.mounting_misalignment_rad = 0.5e-3;                      // [T] camera-IMU extrinsic residual
  placeInstabilityAndWalk(&p.gyro);
  placeInstabilityAndWalk(&p.accel);
  return p;
}

ImuErrorParams tacticalGrade() {  // Safran Sensonor STIM300 (MEMS, tactical grade), 10 g accelerometers
  ImuErrorParams p;
  p.enabled = true;
  p.grade = "tactical";
  p.gyro.white_noise_density = 0.15 * kDeg / kSqrtHour;            // [S] ARW 0.15 deg/sqrt(h)
  p.gyro.bias_instability = fromAllanMinimum(0.5 * kDeg / kHour);  // [S] bias instability 0.5 deg/h
  p.gyro.turn_on_bias = 4.0 * kDeg / kHour;                        // [S] bias run-run 4 deg/h
  p.gyro.scale_factor = 500e-6;                                    // [S] scale factor accuracy 500 ppm
  p.gyro.misalignment_rad = 1e-3;                                  // [S] axis misalignment 1 mrad
  p.gyro.quantization = std::ldexp(1.0, -14) * kDeg;           // [T] 2^-14 deg/s (= 0.22 deg/h) output LSB
  p.gyro.range = 400.0 * kDeg;                                 // [S] +-400 deg/s
  p.accel.white_noise_density = 0.06 / kSqrtHour;              // [S] VRW 0.06 m/s/sqrt(h)
  p.accel.bias_instability = fromAllanMinimum(0.05e-3 * kG0);  // [S] bias instability 0.05 mg
  p.accel.turn_on_bias = 0.75e-3 * kG0;                        // [S] bias run-run 0.75 mg
  p.accel.scale_factor = 300e-6;                               // [S] 300 ppm
  p.accel.misalignment_rad = 1e-3;                             // [S] 1 mrad
  p.accel.quantization = std::ldexp(1.0, -19) * kG0;           // [T] 2^-19 g (= 1.9 ug) output LSB
  p.accel.range = 10.0 * kG0;                                  // [S] +-10 g variant
  p.mounting_misalignment_rad = 0.5e-3;                        // [T]
  placeInstabilityAndWalk(&p.gyro);
  placeInstabilityAndWalk(&p.accel);
  return p;
}

ImuErrorParams memsGrade() {  // Analog Devices ADIS16448 (the EuRoC MAV IMU)
  ImuErrorParams p;
  p.enabled = true;
  p.grade = "mems";
  p.gyro.white_noise_density = 0.66 * kDeg / kSqrtHour;             // [D] ARW 0.66 deg/sqrt(h)
  p.gyro.bias_instability = fromAllanMinimum(14.5 * kDeg / kHour);  // [D] in-run bias stability 14.5 deg/h
  p.gyro.turn_on_bias = 0.5 * kDeg;                                 // [D] bias repeatability 0.5 deg/s
  p.gyro.scale_factor = 1e-3;                                       // [T] 0.1 %
  p.gyro.misalignment_rad = 0.05 * kDeg;                            // [T] 0.05 deg (ADIS1644x axis-to-axis)
  p.gyro.quantization = 0.04 * kDeg;                                // [D] 25 LSB/(deg/s)
  p.gyro.range = 1000.0 * kDeg;                                     // [D] +-1000 deg/s
  p.accel.white_noise_density = 0.11 / kSqrtHour;                   // [D] VRW 0.11 m/s/sqrt(h)
  p.accel.bias_instability = fromAllanMinimum(0.25e-3 * kG0);       // [T] 0.25 mg
  p.accel.turn_on_bias = 20e-3 * kG0;                               // [S] 20 mg
  p.accel.scale_factor = 1e-3;                                      // [T] 0.1 %
  p.accel.misalignment_rad = 0.05 * kDeg;                           // [T] 0.05 deg
  p.accel.quantization = kG0 / 1200.0;                              // [D] 1200 LSB/g
  p.accel.range = 18.0 * kG0;                                       // [T] +-18 g
  p.mounting_misalignment_rad = 0.5e-3;                             // [T]
  placeInstabilityAndWalk(&p.gyro);
  placeInstabilityAndWalk(&p.accel);
  return p;
}

ImuErrorParams idealGrade() {
  ImuErrorParams p;
  p.grade = "ideal";
  return p;
}

// ---------------------------------------------------------------------------------------------------------
// YAML
// ---------------------------------------------------------------------------------------------------------
struct TriadField {
  const char* name;
  double ImuTriadErrors::*member;
};
constexpr TriadField kTriadFields[] = {
    {"white_noise_density", &ImuTriadErrors::white_noise_density},
    {"bias_instability", &ImuTriadErrors::bias_instability},
    {"bias_instability_correlation_s", &ImuTriadErrors::bias_instability_correlation_s},
    {"bias_random_walk", &ImuTriadErrors::bias_random_walk},
    {"turn_on_bias", &ImuTriadErrors::turn_on_bias},
    {"scale_factor", &ImuTriadErrors::scale_factor},
    {"misalignment_rad", &ImuTriadErrors::misalignment_rad},
    {"quantization", &ImuTriadErrors::quantization},
    {"range", &ImuTriadErrors::range},
};

std::string scalarText(const YAML::Node& value, const std::string& key) {
  if (!value.IsScalar()) throw std::invalid_argument("imu." + key + ": expected a scalar value");
  return value.Scalar();
}

double readDouble(const YAML::Node& value, const std::string& key) {
  const std::string text = scalarText(value, key);
  try {
    return value.as<double>();
  } catch (const YAML::Exception&) {
    throw std::invalid_argument("imu." + key + ": not a number: '" + text + "'");
  }
}

bool readBool(const YAML::Node& value, const std::string& key) {
  const std::string text = scalarText(value, key);
  try {
    return value.as<bool>();
  } catch (const YAML::Exception&) {
    throw std::invalid_argument("imu." + key + ": not a boolean: '" + text + "'");
  }
}

void readTriad(const YAML::Node& node, const std::string& section, ImuTriadErrors* triad) {
  if (node.IsNull()) return;
  if (!node.IsMap()) throw std::invalid_argument("imu." + section + ": expected a map");
  for (const auto& entry : node) {
    const std::string key = scalarText(entry.first, section + " key");
    const TriadField* field = nullptr;
    for (const TriadField& f : kTriadFields)
      if (key == f.name) field = &f;
    if (!field) {
      std::string valid;
      for (const TriadField& f : kTriadFields) valid += std::string(valid.empty() ? "" : ", ") + f.name;
      throw std::invalid_argument("imu." + section + "." + key + ": unknown key (valid: " + valid + ")");
    }
    triad->*(field->member) = readDouble(entry.second, section + "." + key);
  }
}

YAML::Node triadYaml(const ImuTriadErrors& triad) {
  YAML::Node node(YAML::NodeType::Map);
  for (const TriadField& f : kTriadFields) node[f.name] = triad.*(f.member);
  return node;
}

void checkTriad(const ImuTriadErrors& t, const std::string& section) {
  for (const TriadField& f : kTriadFields) {
    const double v = t.*(f.member);
    if (!std::isfinite(v) || v < 0.0) {
      std::ostringstream message;
      message << "imu." << section << "." << f.name << " must be finite and >= 0 (got " << v << ")";
      throw std::invalid_argument(message.str());
    }
  }
  if (!(t.bias_instability_correlation_s > 0.0))
    throw std::invalid_argument("imu." + section + ".bias_instability_correlation_s must be > 0");
  if (t.scale_factor > kMaxSmallError)
    throw std::invalid_argument("imu." + section + ".scale_factor must be <= 0.1 (small-error model)");
  if (t.misalignment_rad > kMaxSmallError)
    throw std::invalid_argument("imu." + section + ".misalignment_rad must be <= 0.1 (small-error model)");
  if (t.range > 0.0 && t.range < t.quantization)
    throw std::invalid_argument("imu." + section + ".range must be >= quantization");
}

// Stream ids of the random generators: constants, then 3 per triad (white, Gauss-Markov, random walk).
constexpr uint64_t kConstantsStream = 0;
constexpr uint64_t kGyroStream = 1;
constexpr uint64_t kAccelStream = 2;

std::mt19937_64 makeRng(uint64_t seed, uint64_t stream) {
  std::seed_seq sequence{static_cast<uint32_t>(seed), static_cast<uint32_t>(seed >> 32),
                         static_cast<uint32_t>(stream), 0x494D55u /* "IMU" */};
  return std::mt19937_64(sequence);
}

}  // namespace

double ieeeBiasInstabilityFactor() { return std::sqrt(2.0 * std::log(2.0) / kPi); }

void validate(const ImuErrorParams& params) {
  checkTriad(params.gyro, "gyro");
  checkTriad(params.accel, "accel");
  const double m = params.mounting_misalignment_rad;
  if (!std::isfinite(m) || m < 0.0 || m > kMaxSmallError)
    throw std::invalid_argument("imu.mounting_misalignment_rad must be in [0, 0.1] (got " +
                                std::to_string(m) + ")");
}

std::vector<std::string> imuGradeNames() { return {"ideal", "navigation", "tactical", "mems"}; }

ImuErrorParams imuGrade(const std::string& name) {
  if (name == "ideal") return idealGrade();
  if (name == "navigation") return navigationGrade();
  if (name == "tactical") return tacticalGrade();
  if (name == "mems") return memsGrade();
  std::string valid;
  for (const std::string& n : imuGradeNames()) valid += (valid.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown IMU grade '" + name + "' (valid: " + valid + ")");
}

void readYaml(const YAML::Node& node, ImuErrorParams* params) {
  if (!node || node.IsNull()) return;
  if (!node.IsMap()) throw std::invalid_argument("imu: expected a map");
  ImuErrorParams p = *params;
  if (const YAML::Node grade = node["grade"]) {
    const std::string name = scalarText(grade, "grade");
    try {
      p = imuGrade(name);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("imu.grade: ") + e.what());
    }
  }
  for (const auto& entry : node) {
    const std::string key = scalarText(entry.first, "key");
    if (key == "grade") continue;
    if (key == "enabled") {
      p.enabled = readBool(entry.second, key);
    } else if (key == "mounting_misalignment_rad") {
      p.mounting_misalignment_rad = readDouble(entry.second, key);
    } else if (key == "gyro") {
      readTriad(entry.second, "gyro", &p.gyro);
    } else if (key == "accel") {
      readTriad(entry.second, "accel", &p.accel);
    } else {
      throw std::invalid_argument(
          "imu." + key + ": unknown key (valid: enabled, grade, gyro, accel, mounting_misalignment_rad)");
    }
  }
  validate(p);
  *params = p;
}

YAML::Node toYaml(const ImuErrorParams& params) {
  YAML::Node node(YAML::NodeType::Map);
  node["enabled"] = params.enabled;
  node["grade"] = params.grade;
  node["mounting_misalignment_rad"] = params.mounting_misalignment_rad;
  node["gyro"] = triadYaml(params.gyro);
  node["accel"] = triadYaml(params.accel);
  return node;
}

double modelAllanDeviation(const ImuTriadErrors& triad, double tau_s) {
  const double n = triad.white_noise_density, k = triad.bias_random_walk;
  double variance = n * n / tau_s + k * k * tau_s / 3.0;
  if (triad.bias_instability > 0.0) {
    const double sigma = instabilityProcessSigma(triad.bias_instability);
    variance += sigma * sigma * unitInstabilityAllanVariance(tau_s / triad.bias_instability_correlation_s);
  }
  return std::sqrt(variance);
}

// ---------------------------------------------------------------------------------------------------------
// ImuErrorModel
// ---------------------------------------------------------------------------------------------------------
ImuErrorModel::ImuErrorModel(const ImuErrorParams& params, double rate_hz, uint64_t seed)
    : params_(params), rate_hz_(rate_hz) {
  validate(params_);
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz))
    throw std::invalid_argument("ImuErrorModel: rate_hz must be > 0 (got " + std::to_string(rate_hz) + ")");
  if (!params_.enabled) return;
  // Run constants, always drawn in this order (a zero sigma scales its draw to zero, so switching one term
  // off does not change the others): mounting rotation, then per triad scale, misalignment, turn-on bias.
  std::mt19937_64 constants_rng = makeRng(seed, kConstantsStream);
  std::normal_distribution<double> constants_normal;
  Eigen::Vector3d rotation_vector;
  for (int i = 0; i < 3; ++i)
    rotation_vector[i] = params_.mounting_misalignment_rad * constants_normal(constants_rng);
  const double angle = rotation_vector.norm();
  R_imu_body_ = angle > 0.0 ? Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix()
                            : Eigen::Matrix3d::Identity();
  initTriad(params_.gyro, seed, kGyroStream, &constants_rng, &constants_normal, &gyro_);
  initTriad(params_.accel, seed, kAccelStream, &constants_rng, &constants_normal, &accel_);
}

void ImuErrorModel::initTriad(const ImuTriadErrors& errors, uint64_t seed, uint64_t stream,
                              std::mt19937_64* constants_rng,
                              std::normal_distribution<double>* constants_normal, Triad* triad) const {
  Triad& t = *triad;
  t.errors = errors;
  auto constant = [&](double sigma) { return sigma * (*constants_normal)(*constants_rng); };
  t.M = Eigen::Matrix3d::Identity();
  for (int i = 0; i < 3; ++i) t.M(i, i) += constant(errors.scale_factor);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (r != c) t.M(r, c) = constant(errors.misalignment_rad);
  for (int i = 0; i < 3; ++i) t.turn_on[i] = constant(errors.turn_on_bias);

  const double dt = 1.0 / rate_hz_;
  t.white_sigma = errors.white_noise_density * std::sqrt(rate_hz_);
  t.random_walk_step = errors.bias_random_walk * std::sqrt(dt);
  t.white_rng = makeRng(seed, 3 * stream + 0);
  t.markov_rng = makeRng(seed, 3 * stream + 1);
  t.walk_rng = makeRng(seed, 3 * stream + 2);
  const double sigma = errors.bias_instability > 0.0 ? instabilityProcessSigma(errors.bias_instability) : 0.0;
  for (int k = 0; k < kInstabilityProcesses; ++k) {
    const double phi = std::exp(-dt / correlationTime(errors.bias_instability_correlation_s, k));
    t.markov_phi[k] = phi;
    t.markov_drive[k] = sigma * std::sqrt(1.0 - phi * phi);
    // Stationary start: the process has its full variance from the first sample on.
    for (int i = 0; i < 3; ++i) t.markov[k][i] = sigma > 0.0 ? sigma * t.markov_normal(t.markov_rng) : 0.0;
  }
  t.random_walk.setZero();  // the turn-on bias is the value at the start
}

Eigen::Vector3d ImuErrorModel::bias(const Triad& t) {
  Eigen::Vector3d b = t.turn_on;
  for (int k = 0; k < kInstabilityProcesses; ++k) b += t.markov[k];
  return b + t.random_walk;
}

Eigen::Vector3d ImuErrorModel::output(Triad* t, const Eigen::Vector3d& in_imu, const Eigen::Vector3d& b) {
  Eigen::Vector3d y = t->M * in_imu + b;
  if (t->white_sigma > 0.0)
    for (int i = 0; i < 3; ++i) y[i] += t->white_sigma * t->white_normal(t->white_rng);
  const double q = t->errors.quantization, range = t->errors.range;
  if (q > 0.0)
    for (int i = 0; i < 3; ++i) y[i] = q * std::round(y[i] / q);
  if (range > 0.0) {
    // Full scale is a whole number of LSBs, so saturated outputs stay on the quantisation grid.
    const double limit = q > 0.0 ? q * std::floor(range / q + 1e-9) : range;
    for (int i = 0; i < 3; ++i) y[i] = std::clamp(y[i], -limit, limit);
  }
  return y;
}

void ImuErrorModel::advance(Triad* t) {
  if (t->errors.bias_instability > 0.0)
    for (int k = 0; k < kInstabilityProcesses; ++k)
      for (int i = 0; i < 3; ++i)
        t->markov[k][i] =
            t->markov_phi[k] * t->markov[k][i] + t->markov_drive[k] * t->markov_normal(t->markov_rng);
  if (t->random_walk_step > 0.0)
    for (int i = 0; i < 3; ++i) t->random_walk[i] += t->random_walk_step * t->walk_normal(t->walk_rng);
}

ImuSample ImuErrorModel::measure(const ImuSample& truth) {
  if (!params_.enabled) return truth;
  ImuSample measured;
  measured.timestamp_s = truth.timestamp_s;
  true_errors_.gyro_bias_radps = bias(gyro_);
  true_errors_.accel_bias_mps2 = bias(accel_);
  measured.angular_velocity_radps =
      output(&gyro_, R_imu_body_ * truth.angular_velocity_radps, true_errors_.gyro_bias_radps);
  measured.specific_force_mps2 =
      output(&accel_, R_imu_body_ * truth.specific_force_mps2, true_errors_.accel_bias_mps2);
  advance(&gyro_);
  advance(&accel_);
  return measured;
}

}  // namespace planetary_vo::sensors
