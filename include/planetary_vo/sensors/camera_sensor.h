#pragma once
/// @file camera_sensor.h
/// Camera error model of the flight-like benchmark: turns the renderer's noiseless reflectance image (I/F)
/// into the raw frame a real space navigation camera would deliver, so that VO is scored on realistic images
/// (noise that grows with brightness, blur, exposure changes, bad pixels, lens distortion) instead of perfect
/// ones. See docs/sensors/camera.md for the equations, the datasheet values and the measured checks.
///
/// The chain, in order (what the renderer does, then expose()):
///  1. lens distortion: the renderer casts each pixel's ray through trueCamera() (distortedPixelToBearing),
///  so
///     the image is distorted like a real lens's; camera.yaml gets calibratedCamera() (with calibration
///     error);
///  2. motion blur: imageMotionFromDepth() + motionBlur() average the scene along each pixel's path during
///  the
///     exposure (the image is rendered at mid-exposure);
///  3. optics: PSF (pixel-integrated Gaussian or Airy), vignetting (relative illumination);
///  4. photon transfer: electrons = I/F * rate * exposure * (1 + PRNU) + dark current * exposure (hot
///  pixels),
///     Poisson shot noise, full-well clip, read noise, gain, black level, ADC rounding and clip, dead pixels;
///  5. auto exposure: the exposure of the next frame follows the metered percentile with a lag.
///
/// Randomness: fixed-pattern maps (PRNU, hot and dead pixels) come from a hash of (seed, row, col) and frame
/// noise from a hash of (seed, frame_index, row, col): the output depends only on the seed, the parameters,
/// the input image and the frame index, never on the call order or on threads.

#include <cstdint>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"

namespace planetary_vo::sensors {

/// Every parameter of the camera model. The defaults (with enabled = true) are the `flight` camera: an
/// ams/CMOSIS CMV4000-class global-shutter CMOS behind an f/5.6 lens with a 400-700 nm filter (sources in
/// docs/sensors/camera.md). Values in pixels (psf_sigma_px, calibration_principal_point_sigma_px) are for the
/// rendered image size; everything else is physical and does not depend on it.
struct CameraSensorParams {
  /// false: the ideal camera (the renderer's old noiseless 8-bit path through a perfect pinhole; this model
  /// and the lens distortion are not used).
  bool enabled = false;

  // --- Radiometry: electrons per second of a pixel seeing I/F = 1 (electronRatePerUnitReflectance()):
  //   rate = (E_band / d^2 / pi) * pi / (4 N^2) * pitch^2 * QE * transmission / E_photon
  /// Solar irradiance in the camera's pass band at 1 AU (W/m^2): ASTM E-490 AM0 integrated over 400-700 nm.
  double solar_band_irradiance_w_m2 = 530.0;
  double heliocentric_distance_au = 1.0;  ///< Sun distance of the scene (AU)
  double f_number = 5.6;                  ///< focal ratio N of the lens
  double pixel_pitch_m = 5.5e-6;          ///< pixel pitch (m); CMV4000: 5.5 um
  double quantum_efficiency = 0.5;        ///< band-average QE x fill factor (CMV4000 peak 0.60 at 550 nm)
  double optics_transmission = 0.85;      ///< lens + filter transmission
  /// Mean photon energy in the band (J): h c / 543.8 nm, the photon-weighted mean wavelength of E-490 in
  /// 400-700 nm.
  double mean_photon_energy_j = 3.653e-19;

  // --- Photon transfer (sensor)
  double full_well_e = 13500.0;         ///< full-well capacity (e-); CMV4000: 13.5 ke-
  double read_noise_e = 13.0;           ///< temporal read noise (e- rms); CMV4000: 13 e-
  double dark_current_e_per_s = 125.0;  ///< mean dark current (e-/s); CMV4000: 125 e-/s at 25 C
  double prnu = 0.01;                   ///< photo-response non-uniformity (rms, relative); CMV4000: < 1 %
  int bit_depth = 12;  ///< ADC resolution (bits), 8 ... 16; output DN in [0, 2^bit_depth - 1]
  /// Conversion gain (e- per DN). 0: full well maps to ADC full scale, gain = full_well / (2^bits - 1 -
  /// black).
  double gain_e_per_dn = 0.0;
  double black_level_dn = 64.0;  ///< offset added before the ADC (DN of the configured bit depth)

  // --- Optics
  /// "gaussian" | "airy" | "none". Both kernels are integrated over the pixel area (the pixel aperture).
  std::string psf = "gaussian";
  /// PSF width (px): the second moment per axis of the kernel, i.e. of the image of a point source at a pixel
  /// centre, pixel aperture included. gaussian: the optics sigma is solved for (about sqrt(sigma^2 - 1/12)
  /// when wide); airy: the optics' Gaussian-equivalent core sigma 0.42 lambda N / pitch is that same optics
  /// sigma, first dark ring at 1.22 lambda N / pitch. Depends on the image size (a coarser image of the same
  /// lens has a narrower PSF in pixels).
  double psf_sigma_px = 0.6;
  /// Relative illumination at the image corner (1 = no vignetting); law 1 - (1 - corner) (r / r_corner)^2
  /// around the image centre.
  double vignetting_corner = 0.95;

  // --- Auto exposure (the exposure of the next frame is set from this frame: the VO sees the change)
  double exposure_min_s = 26e-6;  ///< shortest exposure (s); CMV4000: 25.8 us
  double exposure_max_s = 0.02;   ///< longest exposure (s), below the frame period
  double exposure_step_s = 1e-5;  ///< exposure granularity (s); exposures are multiples of it, 0 = continuous
  double ae_percentile = 99.0;    ///< metered statistic: this percentile (%) of the frame's DN above black
  double ae_target_fraction =
      0.8;  ///< the metered percentile's target, as a fraction of the DN range above black
  /// Fraction of the log exposure error corrected per frame (1 = immediate, 0 = fixed exposure).
  double ae_gain = 0.5;
  double ae_max_step_ratio = 2.0;  ///< largest exposure change per frame (factor, >= 1)

  // --- Pixel defects (fixed per sensor, drawn from the seed)
  double hot_pixel_fraction = 1e-4;  ///< fraction of pixels with a high dark current
  double hot_pixel_dark_current_e_per_s =
      2e5;                            ///< mean dark current of a hot pixel (exponentially distributed)
  double dead_pixel_fraction = 1e-5;  ///< fraction of pixels that output the black level

  // --- Motion blur (used by the caller: imageMotionFromDepth() + motionBlur())
  bool motion_blur = true;
  int max_blur_samples = 32;  ///< most samples along one pixel's path

  // --- Lens distortion of the real camera and calibration error of what camera.yaml says
  /// "none" | "plumb_bob" (k1 k2 p1 p2 k3) | "rational_polynomial" (k1 k2 p1 p2 k3 k4 k5 k6) | "equidistant"
  /// (k1 k2 k3 k4), in normalised image coordinates (so they do not depend on the image size).
  std::string distortion_model = "plumb_bob";
  std::vector<double> distortion = {-0.04, 0.01, 0.0, 0.0, 0.0};
  double calibration_focal_sigma = 5e-4;              ///< relative 1-sigma error of fx and fy (independent)
  double calibration_principal_point_sigma_px = 0.4;  ///< 1-sigma error of cx and cy (px)
  /// 1-sigma error of the first distortion coefficient; every other non-zero coefficient c_i gets
  /// sigma * |c_i / c_0| (the same relative error); zero coefficients stay zero.
  double calibration_distortion_sigma = 1e-4;
};

/// Throws std::invalid_argument naming the first field out of range.
void validate(const CameraSensorParams& params);
/// Overrides the keys present (key = field name); throws std::invalid_argument naming an unknown key, a
/// non-scalar where a scalar is expected, a value of the wrong type or out of range.
void readYaml(const YAML::Node& node, CameraSensorParams* params);
/// Every field.
YAML::Node toYaml(const CameraSensorParams& params);

/// Electrons per second collected by a pixel at the image centre seeing I/F = 1 (see the struct's formula).
double electronRatePerUnitReflectance(const CameraSensorParams& params);
/// Conversion gain in e-/DN (gain_e_per_dn, or the full-well-to-full-scale gain when it is 0).
double conversionGainEPerDn(const CameraSensorParams& params);

/// The true camera: `nominal` (pinhole from the FOV) with the params' lens distortion.
PinholeCamera trueCamera(const PinholeCamera& nominal, const CameraSensorParams& params);
/// What calibration says (written to camera.yaml): the true camera with the calibration error drawn from
/// `seed`.
PinholeCamera calibratedCamera(const PinholeCamera& true_camera, const CameraSensorParams& params,
                               uint64_t seed);

/// The PSF kernel (CV_64F, odd square, sums to 1) for the params' psf and psf_sigma_px; 1x1 for "none".
cv::Mat1d psfKernel(const CameraSensorParams& params);
/// Relative illumination per pixel (1 at the centre, vignetting_corner at the corner pixels).
cv::Mat1f vignettingMap(const CameraSensorParams& params, int width, int height);

/// Per-pixel image motion of a static scene during the exposure: for each pixel (distorted coordinates) of
/// the mid-exposure image with z-depth (m, 0 = nothing: treated as infinitely far, so only rotation moves
/// it), where its scene point appears at exposure start and end, as a displacement from the pixel (px,
/// distorted). T_mid_start maps exposure-start camera coordinates into mid-exposure ones (p_mid = T_mid_start
/// * p_start). A point behind the camera at start or end gets zero displacement. The camera's undistorted
/// bearings are computed once per camera and cached.
void imageMotionFromDepth(const cv::Mat1f& depth_m, const PinholeCamera& camera, const Pose& T_mid_start,
                          const Pose& T_mid_end, cv::Mat2f* disp_start_px, cv::Mat2f* disp_end_px);
/// Average of `sharp` along each pixel's path during the exposure: the quadratic through disp_start (start),
/// 0 (mid-exposure) and disp_end (end), sampled at n equally spaced times (midpoint rule), n =
/// ceil(|disp_start| + |disp_end|) + 1 capped at max_samples (1 for a path shorter than 1e-6 px: the sharp
/// value itself). Bilinear interpolation; samples outside the image take the nearest border pixel.
cv::Mat1f motionBlur(const cv::Mat1f& sharp, const cv::Mat2f& disp_start_px, const cv::Mat2f& disp_end_px,
                     int max_samples);

/// What happened in one expose() call.
struct FrameExposure {
  double exposure_s = 0.0;          ///< exposure of this frame (s)
  double metered_dn = 0.0;          ///< the ae_percentile of the frame's DN above the black level
  double saturated_fraction = 0.0;  ///< fraction of pixels clipped at the full well or the ADC full scale
  double mean_dn = 0.0;             ///< mean raw DN (black level included)
};

/// One camera: fixed-pattern maps drawn from the seed, the auto-exposure state, and the raw frame of each I/F
/// image. Not thread-safe (one instance per sequence).
class CameraSensor {
 public:
  /// Validates the params (std::invalid_argument). The initial exposure is the geometric mean of the limits
  /// (quantised); call settleExposure() before the first frame.
  CameraSensor(const CameraSensorParams& params, int width, int height, uint64_t seed);

  /// Sets the exposure as a settled auto exposure would for this scene: the noise-free metered percentile
  /// equals the target (clamped to the exposure limits, quantised). Called once before the first frame.
  void settleExposure(const cv::Mat1f& reflectance);
  /// Sets the exposure of the next frame (clamped to the limits and quantised), e.g. for a manual exposure.
  void setExposure(double exposure_s);
  /// Exposure of the next frame (s); the caller needs it for the motion blur.
  double exposureS() const { return exposure_s_; }

  /// I/F image (motion blur already applied by the caller, width x height) -> raw frame in DN (0 ..
  /// 2^bit_depth - 1): PSF, vignetting, electrons = I/F * rate * exposure * (1 + PRNU) + dark current
  /// (hot pixels), shot noise (Poisson; Gaussian above 40 e- where mean and variance are exact), full-well
  /// clip, read noise, gain, black level, rounding, ADC clip, dead pixels. Then updates the auto exposure
  /// from this frame (lagged). Non-finite or negative I/F counts as 0.
  cv::Mat1w expose(const cv::Mat1f& reflectance, uint64_t frame_index, FrameExposure* info = nullptr);

  /// The raw frame as stored in a 16-bit PNG: MSB-aligned (value << (16 - bit_depth)) so that 8-bit readers
  /// that scale 16-bit by 1/257 see the right brightness.
  cv::Mat1w toPng16(const cv::Mat1w& raw) const;

  const CameraSensorParams& params() const { return params_; }
  double gainEPerDn() const { return gain_e_per_dn_; }
  int maxDn() const { return max_dn_; }
  /// Per pixel: 0 normal, 1 hot, 2 dead (fixed for the sensor's seed).
  const cv::Mat1b& defectMap() const { return defects_; }
  /// Per pixel dark current (e-/s): dark_current_e_per_s, or the hot pixel's own value.
  const cv::Mat1f& darkCurrentMap() const { return dark_e_per_s_; }
  /// Per pixel electrons per second per unit I/F: rate x vignetting x (1 + PRNU); 0 for dead pixels.
  const cv::Mat1f& responseMap() const { return response_e_per_s_; }

  static constexpr uint8_t kNormal = 0, kHot = 1, kDead = 2;

 private:
  double quantiseExposure(double exposure_s) const;
  cv::Mat1f applyPsf(const cv::Mat1f& reflectance) const;

  CameraSensorParams params_;
  int width_, height_;
  uint64_t seed_;
  double gain_e_per_dn_;
  int max_dn_;
  double exposure_s_;
  cv::Mat1d psf_;     ///< 2D kernel (1x1 for none)
  cv::Mat1d psf_1d_;  ///< the 1D factor of a separable (gaussian) kernel, else empty
  cv::Mat1b defects_;
  cv::Mat1f dark_e_per_s_;
  cv::Mat1f response_e_per_s_;
};

}  // namespace planetary_vo::sensors
