/// @file camera_sensor.cpp
/// Camera parameters (validation, YAML), radiometry, true and calibrated camera, and the sensor itself
/// (photon transfer, defects, auto exposure). Optics kernels are in camera_optics.cpp, motion blur in
/// camera_motion_blur.cpp.

#include "planetary_vo/sensors/camera_sensor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include <opencv2/imgproc.hpp>

#include "camera_internal.h"

namespace planetary_vo::sensors {
namespace {

/// Calls f(name, field) for every field of the params, in declaration order (the YAML key table).
template <class P, class F>
void forEachField(P& p, F&& f) {
  f("enabled", p.enabled);
  f("solar_band_irradiance_w_m2", p.solar_band_irradiance_w_m2);
  f("heliocentric_distance_au", p.heliocentric_distance_au);
  f("f_number", p.f_number);
  f("pixel_pitch_m", p.pixel_pitch_m);
  f("quantum_efficiency", p.quantum_efficiency);
  f("optics_transmission", p.optics_transmission);
  f("mean_photon_energy_j", p.mean_photon_energy_j);
  f("full_well_e", p.full_well_e);
  f("read_noise_e", p.read_noise_e);
  f("dark_current_e_per_s", p.dark_current_e_per_s);
  f("prnu", p.prnu);
  f("bit_depth", p.bit_depth);
  f("gain_e_per_dn", p.gain_e_per_dn);
  f("black_level_dn", p.black_level_dn);
  f("psf", p.psf);
  f("psf_sigma_px", p.psf_sigma_px);
  f("vignetting_corner", p.vignetting_corner);
  f("exposure_min_s", p.exposure_min_s);
  f("exposure_max_s", p.exposure_max_s);
  f("exposure_step_s", p.exposure_step_s);
  f("ae_percentile", p.ae_percentile);
  f("ae_target_fraction", p.ae_target_fraction);
  f("ae_gain", p.ae_gain);
  f("ae_max_step_ratio", p.ae_max_step_ratio);
  f("hot_pixel_fraction", p.hot_pixel_fraction);
  f("hot_pixel_dark_current_e_per_s", p.hot_pixel_dark_current_e_per_s);
  f("dead_pixel_fraction", p.dead_pixel_fraction);
  f("motion_blur", p.motion_blur);
  f("max_blur_samples", p.max_blur_samples);
  f("distortion_model", p.distortion_model);
  f("distortion", p.distortion);
  f("calibration_focal_sigma", p.calibration_focal_sigma);
  f("calibration_principal_point_sigma_px", p.calibration_principal_point_sigma_px);
  f("calibration_distortion_sigma", p.calibration_distortion_sigma);
}

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw std::invalid_argument("camera." + field + ": " + why);
}

void requireFinite(const std::string& field, double v) {
  if (!std::isfinite(v)) fail(field, "must be finite");
}
void requirePositive(const std::string& field, double v) {
  requireFinite(field, v);
  if (!(v > 0.0)) fail(field, "must be > 0 (is " + std::to_string(v) + ")");
}
void requireRange(const std::string& field, double v, double lo, double hi) {
  requireFinite(field, v);
  if (v < lo || v > hi)
    fail(field, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "] (is " +
                    std::to_string(v) + ")");
}

size_t distortionCount(const std::string& model) {
  if (model == "plumb_bob") return 5;
  if (model == "rational_polynomial") return 8;
  if (model == "equidistant") return 4;
  return 0;
}

constexpr uint64_t kStreamDefects = 0xD3FEC7ull;
constexpr uint64_t kStreamHotCurrent = 0x407C0221ull;
constexpr uint64_t kStreamPrnu = 0x9A7E1ull;
constexpr uint64_t kStreamFrame = 0xF4A3Eull;
constexpr uint64_t kStreamCalibration = 0xCA1Bull;
/// Below this mean (e-) the shot noise is drawn from the Poisson law itself; above it from the Gaussian of
/// the same mean and variance (skewness 1/sqrt(mean) < 0.16, well under one DN of shape difference).
constexpr double kPoissonLimitE = 40.0;

}  // namespace

void validate(const CameraSensorParams& p) {
  requirePositive("solar_band_irradiance_w_m2", p.solar_band_irradiance_w_m2);
  requirePositive("heliocentric_distance_au", p.heliocentric_distance_au);
  requirePositive("f_number", p.f_number);
  requirePositive("pixel_pitch_m", p.pixel_pitch_m);
  requirePositive("quantum_efficiency", p.quantum_efficiency);
  requireRange("quantum_efficiency", p.quantum_efficiency, 0.0, 1.0);
  requirePositive("optics_transmission", p.optics_transmission);
  requireRange("optics_transmission", p.optics_transmission, 0.0, 1.0);
  requirePositive("mean_photon_energy_j", p.mean_photon_energy_j);
  requirePositive("full_well_e", p.full_well_e);
  requireRange("read_noise_e", p.read_noise_e, 0.0, 1e6);
  requireRange("dark_current_e_per_s", p.dark_current_e_per_s, 0.0, 1e12);
  requireRange("prnu", p.prnu, 0.0, 0.5);
  if (p.bit_depth < 8 || p.bit_depth > 16)
    fail("bit_depth", "must be in [8, 16] (is " + std::to_string(p.bit_depth) + ")");
  const double max_dn = std::ldexp(1.0, p.bit_depth) - 1.0;
  requireRange("gain_e_per_dn", p.gain_e_per_dn, 0.0, 1e9);
  requireRange("black_level_dn", p.black_level_dn, 0.0, max_dn - 1.0);
  if (p.psf != "gaussian" && p.psf != "airy" && p.psf != "none")
    fail("psf", "must be gaussian, airy or none (is '" + p.psf + "')");
  if (p.psf != "none") {
    requireFinite("psf_sigma_px", p.psf_sigma_px);
    if (!(p.psf_sigma_px >= 0.1) || p.psf_sigma_px > 50.0)
      fail("psf_sigma_px", "must be in [0.1, 50] px (is " + std::to_string(p.psf_sigma_px) + ")");
  }
  requirePositive("vignetting_corner", p.vignetting_corner);
  requireRange("vignetting_corner", p.vignetting_corner, 0.0, 1.0);
  requirePositive("exposure_min_s", p.exposure_min_s);
  requirePositive("exposure_max_s", p.exposure_max_s);
  if (p.exposure_max_s < p.exposure_min_s) fail("exposure_max_s", "must be >= exposure_min_s");
  requireRange("exposure_step_s", p.exposure_step_s, 0.0, p.exposure_max_s);
  requirePositive("ae_percentile", p.ae_percentile);
  requireRange("ae_percentile", p.ae_percentile, 0.0, 100.0);
  requirePositive("ae_target_fraction", p.ae_target_fraction);
  requireRange("ae_target_fraction", p.ae_target_fraction, 0.0, 1.0);
  requireRange("ae_gain", p.ae_gain, 0.0, 1.0);
  requireRange("ae_max_step_ratio", p.ae_max_step_ratio, 1.0, 1e6);
  requireRange("hot_pixel_fraction", p.hot_pixel_fraction, 0.0, 1.0);
  requireRange("hot_pixel_dark_current_e_per_s", p.hot_pixel_dark_current_e_per_s, 0.0, 1e12);
  requireRange("dead_pixel_fraction", p.dead_pixel_fraction, 0.0, 1.0);
  if (p.hot_pixel_fraction + p.dead_pixel_fraction > 1.0)
    fail("dead_pixel_fraction", "hot_pixel_fraction + dead_pixel_fraction must be <= 1");
  if (p.max_blur_samples < 1 || p.max_blur_samples > 10000)
    fail("max_blur_samples", "must be in [1, 10000] (is " + std::to_string(p.max_blur_samples) + ")");
  if (p.distortion_model != "none" && distortionCount(p.distortion_model) == 0)
    fail("distortion_model",
         "must be none, plumb_bob, rational_polynomial or equidistant (is '" + p.distortion_model + "')");
  if (p.distortion_model != "none" && p.distortion.size() != distortionCount(p.distortion_model))
    fail("distortion", p.distortion_model + " needs " + std::to_string(distortionCount(p.distortion_model)) +
                           " coefficients (has " + std::to_string(p.distortion.size()) + ")");
  for (double d : p.distortion) requireFinite("distortion", d);
  requireRange("calibration_focal_sigma", p.calibration_focal_sigma, 0.0, 0.5);
  requireRange("calibration_principal_point_sigma_px", p.calibration_principal_point_sigma_px, 0.0, 1e4);
  requireRange("calibration_distortion_sigma", p.calibration_distortion_sigma, 0.0, 10.0);
}

void readYaml(const YAML::Node& node, CameraSensorParams* params) {
  if (!node || node.IsNull()) return;
  if (!node.IsMap()) throw std::invalid_argument("camera: expected a map of parameters");
  CameraSensorParams p = *params;
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    const YAML::Node& value = kv.second;
    bool known = false;
    forEachField(p, [&](const char* name, auto& field) {
      if (key != name) return;
      known = true;
      using T = std::decay_t<decltype(field)>;
      try {
        if constexpr (std::is_same_v<T, std::vector<double>>) {
          if (!value.IsSequence()) fail(key, "expected a list of numbers");
          std::vector<double> v;
          for (const auto& e : value) {
            if (!e.IsScalar()) fail(key, "expected a list of numbers");
            v.push_back(e.as<double>());
          }
          field = v;
        } else {
          if (!value.IsScalar()) fail(key, "expected a single value");
          field = value.as<T>();
        }
      } catch (const YAML::Exception&) {
        fail(key, "cannot read '" + (value.IsScalar() ? value.Scalar() : std::string("...")) + "' as a " +
                      (std::is_same_v<T, bool>          ? "boolean"
                       : std::is_same_v<T, int>         ? "integer"
                       : std::is_same_v<T, std::string> ? "string"
                                                        : "number"));
      }
    });
    if (!known) {
      std::string names;
      forEachField(p,
                   [&](const char* name, auto&) { names += std::string(names.empty() ? "" : ", ") + name; });
      throw std::invalid_argument("camera: unknown key '" + key + "' (valid: " + names + ")");
    }
  }
  validate(p);
  *params = p;
}

YAML::Node toYaml(const CameraSensorParams& params) {
  YAML::Node n;
  forEachField(params, [&](const char* name, const auto& field) { n[name] = field; });
  return n;
}

double electronRatePerUnitReflectance(const CameraSensorParams& p) {
  // Radiance of I/F = 1: L = E / (pi d^2); focal-plane irradiance on axis: pi L T / (4 N^2); per pixel times
  // pitch^2; photons / E_photon; electrons times QE.
  const double radiance =
      p.solar_band_irradiance_w_m2 / (M_PI * p.heliocentric_distance_au * p.heliocentric_distance_au);
  const double irradiance = M_PI * radiance * p.optics_transmission / (4.0 * p.f_number * p.f_number);
  return irradiance * p.pixel_pitch_m * p.pixel_pitch_m * p.quantum_efficiency / p.mean_photon_energy_j;
}

double conversionGainEPerDn(const CameraSensorParams& p) {
  if (p.gain_e_per_dn > 0.0) return p.gain_e_per_dn;
  return p.full_well_e / (std::ldexp(1.0, p.bit_depth) - 1.0 - p.black_level_dn);
}

PinholeCamera trueCamera(const PinholeCamera& nominal, const CameraSensorParams& params) {
  validate(params);
  if (params.distortion_model == "none")
    return PinholeCamera(nominal.width(), nominal.height(), nominal.fx(), nominal.fy(), nominal.cx(),
                         nominal.cy());
  return PinholeCamera(nominal.width(), nominal.height(), nominal.fx(), nominal.fy(), nominal.cx(),
                       nominal.cy(), params.distortion_model, params.distortion);
}

PinholeCamera calibratedCamera(const PinholeCamera& true_camera, const CameraSensorParams& params,
                               uint64_t seed) {
  validate(params);
  // Independent standard normals, one per quantity, from a hash of (seed, index): stable whatever the model.
  auto normal = [&](int index) {
    return camera_detail::normalFromHash(camera_detail::hash4(seed, kStreamCalibration, index, 0));
  };
  const double fx = true_camera.fx() * (1.0 + params.calibration_focal_sigma * normal(0));
  const double fy = true_camera.fy() * (1.0 + params.calibration_focal_sigma * normal(1));
  const double cx = true_camera.cx() + params.calibration_principal_point_sigma_px * normal(2);
  const double cy = true_camera.cy() + params.calibration_principal_point_sigma_px * normal(3);
  std::vector<double> d = true_camera.distortion();
  if (true_camera.hasDistortion() && !d.empty()) {
    const double c0 = d[0];
    for (size_t i = 0; i < d.size(); ++i) {
      double sigma = 0.0;
      if (i == 0)
        sigma = params.calibration_distortion_sigma;
      else if (c0 != 0.0)
        sigma = params.calibration_distortion_sigma * std::abs(d[i] / c0);
      if (sigma > 0.0) d[i] += sigma * normal(10 + static_cast<int>(i));
    }
  }
  return PinholeCamera(true_camera.width(), true_camera.height(), fx, fy, cx, cy,
                       true_camera.distortionModel(), d);
}

// ------------------------------------------------------------------------------------------------------------
// CameraSensor

CameraSensor::CameraSensor(const CameraSensorParams& params, int width, int height, uint64_t seed)
    : params_(params), width_(width), height_(height), seed_(seed) {
  validate(params_);
  if (width <= 0 || height <= 0) throw std::invalid_argument("camera sensor: image size must be positive");
  gain_e_per_dn_ = conversionGainEPerDn(params_);
  max_dn_ = (1 << params_.bit_depth) - 1;
  psf_ = psfKernel(params_);
  if (params_.psf == "gaussian") psf_1d_ = camera_detail::gaussianPsf1d(params_.psf_sigma_px);

  // Fixed pattern from hashes of (seed, row, col): defects, dark current, response (rate x vignetting x
  // PRNU).
  const cv::Mat1f vignetting = vignettingMap(params_, width, height);
  const double rate = electronRatePerUnitReflectance(params_);
  defects_.create(height, width);
  dark_e_per_s_.create(height, width);
  response_e_per_s_.create(height, width);
  const double hot = params_.hot_pixel_fraction, dead = params_.dead_pixel_fraction;
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const double u = camera_detail::toUnit(camera_detail::hash4(seed_, kStreamDefects, r, c));
      uint8_t defect = kNormal;
      if (u < hot)
        defect = kHot;
      else if (u >= 1.0 - dead)
        defect = kDead;
      defects_(r, c) = defect;
      double dark = params_.dark_current_e_per_s;
      if (defect == kHot) {
        const double v = camera_detail::toUnitOpen(camera_detail::hash4(seed_, kStreamHotCurrent, r, c));
        dark = -params_.hot_pixel_dark_current_e_per_s * std::log(v);  // exponential, mean = the parameter
      }
      dark_e_per_s_(r, c) = static_cast<float>(dark);
      const double gain = std::max(
          0.0,
          1.0 + params_.prnu * camera_detail::normalFromHash(camera_detail::hash4(seed_, kStreamPrnu, r, c)));
      response_e_per_s_(r, c) = defect == kDead ? 0.0f : static_cast<float>(rate * vignetting(r, c) * gain);
    }
  }
  exposure_s_ = quantiseExposure(std::sqrt(params_.exposure_min_s * params_.exposure_max_s));
}

double CameraSensor::quantiseExposure(double exposure_s) const {
  double t = std::clamp(exposure_s, params_.exposure_min_s, params_.exposure_max_s);
  if (params_.exposure_step_s > 0.0) t = std::round(t / params_.exposure_step_s) * params_.exposure_step_s;
  return std::clamp(t, params_.exposure_min_s, params_.exposure_max_s);
}

void CameraSensor::setExposure(double exposure_s) {
  if (!std::isfinite(exposure_s)) throw std::invalid_argument("camera sensor: exposure is not finite");
  exposure_s_ = quantiseExposure(exposure_s);
}

cv::Mat1f CameraSensor::applyPsf(const cv::Mat1f& reflectance) const {
  cv::Mat1f out;
  if (!psf_1d_.empty()) {
    cv::sepFilter2D(reflectance, out, CV_32F, psf_1d_, psf_1d_, cv::Point(-1, -1), 0.0, cv::BORDER_REPLICATE);
  } else if (psf_.rows > 1) {
    cv::filter2D(reflectance, out, CV_32F, psf_, cv::Point(-1, -1), 0.0, cv::BORDER_REPLICATE);
  } else {
    out = reflectance.clone();
  }
  return out;
}

void CameraSensor::settleExposure(const cv::Mat1f& reflectance) {
  if (reflectance.rows != height_ || reflectance.cols != width_)
    throw std::invalid_argument("camera sensor: reflectance image has the wrong size");
  const cv::Mat1f blurred = applyPsf(reflectance);
  std::vector<float> rate;
  rate.reserve(static_cast<size_t>(width_) * height_);
  for (int r = 0; r < height_; ++r)
    for (int c = 0; c < width_; ++c) {
      const float v = blurred(r, c);
      rate.push_back((v > 0.0f ? v : 0.0f) * response_e_per_s_(r, c));  // NaN -> 0
    }
  const size_t k = static_cast<size_t>(
      std::clamp(std::ceil(params_.ae_percentile / 100.0 * static_cast<double>(rate.size())) - 1.0, 0.0,
                 static_cast<double>(rate.size() - 1)));
  std::nth_element(rate.begin(), rate.begin() + static_cast<std::ptrdiff_t>(k), rate.end());
  const double target_e = params_.ae_target_fraction * (max_dn_ - params_.black_level_dn) * gain_e_per_dn_;
  const double total_rate = static_cast<double>(rate[k]) + params_.dark_current_e_per_s;
  exposure_s_ = quantiseExposure(total_rate > 0.0 ? target_e / total_rate : params_.exposure_max_s);
}

cv::Mat1w CameraSensor::expose(const cv::Mat1f& reflectance, uint64_t frame_index, FrameExposure* info) {
  if (reflectance.rows != height_ || reflectance.cols != width_)
    throw std::invalid_argument("camera sensor: reflectance image is " + std::to_string(reflectance.cols) +
                                "x" + std::to_string(reflectance.rows) + ", expected " +
                                std::to_string(width_) + "x" + std::to_string(height_));
  const double t = exposure_s_;
  const cv::Mat1f blurred = applyPsf(reflectance);
  cv::Mat1w raw(height_, width_);
  const double full_well = params_.full_well_e, read_noise = params_.read_noise_e;
  const double inv_gain = 1.0 / gain_e_per_dn_, black = params_.black_level_dn;
  const uint16_t black_dn = static_cast<uint16_t>(std::lround(black));
  const uint64_t frame_key = camera_detail::hash4(seed_, kStreamFrame, static_cast<int64_t>(frame_index), 0);
  std::vector<uint32_t> histogram(static_cast<size_t>(max_dn_) + 1, 0);
  size_t saturated = 0;
  double sum_dn = 0.0;
  for (int r = 0; r < height_; ++r) {
    const float* in = blurred.ptr<float>(r);
    const float* response = response_e_per_s_.ptr<float>(r);
    const float* dark = dark_e_per_s_.ptr<float>(r);
    const uint8_t* defect = defects_.ptr<uint8_t>(r);
    uint16_t* out = raw.ptr<uint16_t>(r);
    const uint64_t row_key =
        camera_detail::mix64(frame_key + static_cast<uint64_t>(r) * 0xD1B54A32D192ED03ull);
    for (int c = 0; c < width_; ++c) {
      if (defect[c] == kDead) {
        out[c] = black_dn;
        ++histogram[black_dn];
        sum_dn += black_dn;
        continue;
      }
      const float v = in[c];
      const double signal = (v > 0.0f ? static_cast<double>(v) : 0.0) * response[c];  // NaN -> 0
      const double mean_e = (signal + dark[c]) * t;
      // Two normals (shot, read) from one Box-Muller pair; a third uniform for the Poisson draw.
      const uint64_t h1 =
          camera_detail::mix64(row_key + static_cast<uint64_t>(c + 1) * 0x9E3779B97F4A7C15ull);
      const uint64_t h2 = camera_detail::mix64(h1 ^ 0x632BE59BD9B4E019ull);
      const float radius = std::sqrt(-2.0f * std::log(camera_detail::toUnitOpenF(h1)));
      const float angle = 6.2831853f * camera_detail::toUnitF(h2);
      const double shot_normal = radius * std::cos(angle), read_normal = radius * std::sin(angle);
      double electrons;
      if (mean_e < kPoissonLimitE) {
        const double u = camera_detail::toUnit(camera_detail::mix64(h2 ^ 0x2545F4914F6CDD1Dull));
        electrons = camera_detail::poissonInverse(mean_e, u);
      } else {
        electrons = std::max(0.0, mean_e + std::sqrt(mean_e) * shot_normal);
      }
      bool clipped = false;
      if (electrons >= full_well) electrons = full_well, clipped = true;
      // Rounding to the nearest DN (truncation of a positive value is its floor).
      const double dn = black + (electrons + read_noise * read_normal) * inv_gain + 0.5;
      int value;
      if (dn >= max_dn_ + 1.0)
        value = max_dn_, clipped = true;
      else
        value = dn > 0.0 ? static_cast<int>(dn) : 0;
      if (value == max_dn_) clipped = true;
      out[c] = static_cast<uint16_t>(value);
      ++histogram[static_cast<size_t>(value)];
      sum_dn += value;
      saturated += clipped;
    }
  }

  const double n = static_cast<double>(width_) * height_;
  const double count_needed = std::max(1.0, std::ceil(params_.ae_percentile / 100.0 * n));
  double cumulative = 0.0;
  int percentile_dn = max_dn_;
  for (int d = 0; d <= max_dn_; ++d) {
    cumulative += histogram[static_cast<size_t>(d)];
    if (cumulative >= count_needed) {
      percentile_dn = d;
      break;
    }
  }
  FrameExposure frame;
  frame.exposure_s = t;
  frame.metered_dn = std::max(0.0, percentile_dn - black);
  frame.saturated_fraction = static_cast<double>(saturated) / n;
  frame.mean_dn = sum_dn / n;
  if (info) *info = frame;

  // Auto exposure of the next frame: correct a fraction ae_gain of the log error, at most ae_max_step_ratio.
  if (params_.ae_gain > 0.0) {
    const double target_dn = params_.ae_target_fraction * (max_dn_ - black);
    double ratio;
    if (frame.saturated_fraction > 1.0 - params_.ae_percentile / 100.0) {
      // The metered pixel is clipped: its error is unknown (at least the clip level), step down.
      ratio = 1.0 / params_.ae_max_step_ratio;
    } else {
      const double log_error = std::log(target_dn / std::max(frame.metered_dn, 0.5));
      ratio = std::clamp(std::exp(params_.ae_gain * log_error), 1.0 / params_.ae_max_step_ratio,
                         params_.ae_max_step_ratio);
    }
    exposure_s_ = quantiseExposure(t * ratio);
  }
  return raw;
}

cv::Mat1w CameraSensor::toPng16(const cv::Mat1w& raw) const {
  const int shift = 16 - params_.bit_depth;
  cv::Mat1w out(raw.size());
  for (int r = 0; r < raw.rows; ++r) {
    const uint16_t* in = raw.ptr<uint16_t>(r);
    uint16_t* o = out.ptr<uint16_t>(r);
    for (int c = 0; c < raw.cols; ++c) o[c] = static_cast<uint16_t>(std::min<int>(in[c], max_dn_) << shift);
  }
  return out;
}

}  // namespace planetary_vo::sensors
