/// @file camera_optics.cpp
/// PSF kernels (pixel-integrated Gaussian and Airy) and the vignetting law of the camera model.

#include <algorithm>
#include <cmath>

#include "camera_internal.h"
#include "planetary_vo/sensors/camera_sensor.h"

namespace planetary_vo::sensors {
namespace {

constexpr double kAiryCoreSigma = 0.42;          // Gaussian-equivalent core sigma / (lambda N)
constexpr double kAiryThirdZero = 10.173468135;  // third zero of J1: the kernel reaches the 3rd dark ring
constexpr int kAirySubsamples = 8;               // per axis per pixel: pixel integration of the Airy disc

/// Airy intensity [2 J1(x) / x]^2, x = pi r / (lambda N) (r and lambda N in pixels), 1 at the centre.
double airy(double r_px, double lambda_n_px) {
  const double x = M_PI * r_px / lambda_n_px;
  if (x < 1e-8) return 1.0;
  const double a = 2.0 * std::cyl_bessel_j(1.0, x) / x;
  return a * a;
}

}  // namespace

namespace camera_detail {

namespace {

/// Pixel-integrated Gaussian of optics sigma `sigma_optics` (column, radius 4 sigma + 1, normalised).
cv::Mat1d integratedGaussian(double sigma_optics, int radius) {
  cv::Mat1d k(2 * radius + 1, 1);
  const double s = 1.0 / (std::sqrt(2.0) * sigma_optics);
  double sum = 0.0;
  for (int i = -radius; i <= radius; ++i) {
    k(i + radius) = 0.5 * (std::erf((i + 0.5) * s) - std::erf((i - 0.5) * s));
    sum += k(i + radius);
  }
  return k / sum;
}

double secondMoment(const cv::Mat1d& k) {
  const int radius = k.rows / 2;
  double m = 0.0;
  for (int i = -radius; i <= radius; ++i) m += i * i * k(i + radius);
  return m;
}

}  // namespace

double gaussianOpticsSigma(double sigma_total_px) {
  // The kernel's second moment grows monotonically with the optics sigma, from 0 (all light in the centre
  // pixel) to sigma^2 + 1/12 for a wide PSF: bisection.
  const int radius = std::max(1, static_cast<int>(std::ceil(4.0 * sigma_total_px)) + 1);
  const double target = sigma_total_px * sigma_total_px;
  double lo = 0.0, hi = sigma_total_px + 1.0;
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    (secondMoment(integratedGaussian(mid, radius)) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

cv::Mat1d gaussianPsf1d(double sigma_total_px) {
  const int radius = std::max(1, static_cast<int>(std::ceil(4.0 * sigma_total_px)) + 1);
  return integratedGaussian(gaussianOpticsSigma(sigma_total_px), radius);
}

}  // namespace camera_detail

cv::Mat1d psfKernel(const CameraSensorParams& params) {
  validate(params);
  if (params.psf == "none") return cv::Mat1d(1, 1, 1.0);
  if (params.psf == "gaussian") {
    const cv::Mat1d k = camera_detail::gaussianPsf1d(params.psf_sigma_px);
    return k * k.t();
  }
  // Airy: the optics' Gaussian-equivalent core sigma 0.42 lambda N is that of the gaussian kernel of the same
  // psf_sigma_px; integrated over each pixel by kAirySubsamples^2 point samples; truncated at the third dark
  // ring and normalised.
  const double core = camera_detail::gaussianOpticsSigma(params.psf_sigma_px);
  const double lambda_n = core / kAiryCoreSigma;
  const int radius = static_cast<int>(std::ceil(kAiryThirdZero / M_PI * lambda_n + 0.5));
  const double r_max = kAiryThirdZero / M_PI * lambda_n;
  cv::Mat1d k(2 * radius + 1, 2 * radius + 1, 0.0);
  double sum = 0.0;
  for (int i = -radius; i <= radius; ++i) {
    for (int j = -radius; j <= radius; ++j) {
      double acc = 0.0;
      for (int a = 0; a < kAirySubsamples; ++a) {
        for (int b = 0; b < kAirySubsamples; ++b) {
          const double y = i - 0.5 + (a + 0.5) / kAirySubsamples, x = j - 0.5 + (b + 0.5) / kAirySubsamples;
          const double r = std::hypot(x, y);
          if (r <= r_max) acc += airy(r, lambda_n);
        }
      }
      k(i + radius, j + radius) = acc;
      sum += acc;
    }
  }
  return k / sum;
}

cv::Mat1f vignettingMap(const CameraSensorParams& params, int width, int height) {
  cv::Mat1f v(height, width);
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1);
  const double corner2 = cx * cx + cy * cy;
  const double falloff = corner2 > 0.0 ? (1.0 - params.vignetting_corner) / corner2 : 0.0;
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c)
      v(r, c) = static_cast<float>(1.0 - falloff * ((c - cx) * (c - cx) + (r - cy) * (r - cy)));
  return v;
}

}  // namespace planetary_vo::sensors
