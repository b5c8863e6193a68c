#include "planetary_vo/terrain/shading_tilt.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace planetary_vo::terrain {
namespace {

constexpr double kDeg = M_PI / 180.0;

/// Gaussian of `values` over the pixels where `mask` is 1, normalised by the mask's Gaussian: NaN where less
/// than half of the weight is known. Sigma in pixels; BORDER_REFLECT as the shading relief.
cv::Mat maskedBlur(const cv::Mat& values, const cv::Mat& mask, double sigma_px) {
  cv::Mat num, den;
  cv::GaussianBlur(values.mul(mask), num, cv::Size(), sigma_px, 0.0, cv::BORDER_REFLECT);
  cv::GaussianBlur(mask, den, cv::Size(), sigma_px, 0.0, cv::BORDER_REFLECT);
  cv::Mat out(values.size(), CV_32F);
  for (int r = 0; r < out.rows; ++r)
    for (int c = 0; c < out.cols; ++c) {
      const float d = den.at<float>(r, c);
      out.at<float>(r, c) = d > 0.5f ? num.at<float>(r, c) / d : std::numeric_limits<float>::quiet_NaN();
    }
  return out;
}

}  // namespace

ShadingTilt::ShadingTilt(const PinholeCamera& camera, const ShadingTiltConfig& config,
                         double sun_elevation_deg, double sun_azimuth_deg, double min_sun_elevation_deg)
    : camera_(camera),
      config_(config),
      sun_elevation_deg_(sun_elevation_deg),
      sun_azimuth_deg_(sun_azimuth_deg) {
  std::string why;
  if (!camera_.isValid(&why)) throw std::invalid_argument("ShadingTilt: invalid camera: " + why);
  if (!(config_.weight >= 0.0 && config_.weight <= 1.0) ||
      !(config_.footprint_sigma_m > 0.0 && config_.surround_sigma_m > config_.footprint_sigma_m &&
        std::isfinite(config_.surround_sigma_m)) ||
      !(config_.max_pixel_footprint_m > 0.0 && std::isfinite(config_.max_pixel_footprint_m)) ||
      !(config_.min_brightness >= 0.0 && config_.min_brightness < 255.0) || config_.max_keyframes < 1)
    throw std::invalid_argument(
        "ShadingTilt: invalid configuration (weight in [0, 1], 0 < footprint_sigma_m < surround_sigma_m, "
        "max_pixel_footprint_m > 0, min_brightness in [0, 255), max_keyframes >= 1)");
  active_ = config_.weight > 0.0 && sun_elevation_deg_ > 0.0 && sun_elevation_deg_ < 90.0 &&
            sun_elevation_deg_ >= min_sun_elevation_deg && sun_azimuth_deg_ >= 0.0;
}

cv::Mat ShadingTilt::relativeBrightness(const cv::Mat& gray, double pixel_footprint_m, int* scale_out) const {
  checkKeyframeImage(camera_, gray, "ShadingTilt");
  // Reduce while the patch's sigma still spans at least 2 pixels.
  int scale = 1;
  const cv::Mat image = reducedForSigma(gray, config_.footprint_sigma_m, pixel_footprint_m, &scale);
  const double pixel_m = pixel_footprint_m * scale;
  cv::Mat mask;
  cv::threshold(image, mask, config_.min_brightness - 1e-3, 1.0, cv::THRESH_BINARY);
  const cv::Mat fine = maskedBlur(image, mask, config_.footprint_sigma_m / pixel_m);
  const cv::Mat coarse = maskedBlur(image, mask, config_.surround_sigma_m / pixel_m);
  cv::Mat rel = fine / coarse - 1.0;  // NaN propagates
  if (scale_out) *scale_out = scale;
  return rel;
}

bool ShadingTilt::addKeyframe(const Pose& T_world_cam, const cv::Mat& gray, double ground_elevation_m) {
  if (!active_) return false;
  return keepReducedImage(
      camera_, T_world_cam, ground_elevation_m, config_.max_pixel_footprint_m, config_.max_keyframes,
      [&](double footprint_m, int* scale) { return relativeBrightness(gray, footprint_m, scale); }, &views_);
}

cv::Mat ShadingTilt::cellRelativeBrightness(const GridGeometry& geometry, const cv::Mat& elevation_m) const {
  if (elevation_m.type() != CV_32FC1 || elevation_m.rows != geometry.rows ||
      elevation_m.cols != geometry.cols)
    throw std::invalid_argument("ShadingTilt: the elevation is not a CV_32F layer of the grid");
  return meanOverKeptImages(camera_, views_, geometry, elevation_m, config_.max_pixel_footprint_m);
}

cv::Mat ShadingTilt::correctedSlope(const GridGeometry& geometry, const cv::Mat& elevation_m,
                                    const cv::Mat& slope_deg, cv::Mat* delta_deg_out) const {
  if (slope_deg.type() != CV_32FC1 || slope_deg.rows != geometry.rows || slope_deg.cols != geometry.cols)
    throw std::invalid_argument("ShadingTilt: the slope is not a CV_32F layer of the grid");
  cv::Mat slope = slope_deg.clone();
  cv::Mat delta = geometry.newLayer(0.0f);
  if (active_ && !views_.empty()) {
    const cv::Mat rel = cellRelativeBrightness(geometry, elevation_m);
    // The map's elevation smoothed at both sigmas over its known cells, and its gradients (central
    // differences; NaN next to an unknown cell).
    cv::Mat known, values;
    cv::compare(elevation_m, elevation_m, known, cv::CMP_EQ);  // false at NaN
    known.convertTo(known, CV_32F, 1.0 / 255.0);
    values = elevation_m.clone();
    values.setTo(0.0f, known == 0);
    const cv::Mat z_fine = maskedBlur(values, known, config_.footprint_sigma_m / geometry.cell_size_m);
    const cv::Mat z_coarse = maskedBlur(values, known, config_.surround_sigma_m / geometry.cell_size_m);
    const double e = sun_elevation_deg_ * kDeg, a = sun_azimuth_deg_ * kDeg;
    const double ux = std::sin(a), uy = std::cos(a);  // toward the Sun on the ground (world x, y)
    const auto gradient = [&](const cv::Mat& z, int c, int r, double* gx, double* gy) {
      if (c < 1 || r < 1 || c + 1 >= geometry.cols || r + 1 >= geometry.rows) return false;
      *gx = (z.at<float>(r, c + 1) - z.at<float>(r, c - 1)) / (2.0 * geometry.cell_size_m);
      *gy = (z.at<float>(r + 1, c) - z.at<float>(r - 1, c)) / (2.0 * geometry.cell_size_m);
      return std::isfinite(*gx) && std::isfinite(*gy);
    };
    for (int r = 0; r < geometry.rows; ++r)
      for (int c = 0; c < geometry.cols; ++c) {
        const float s = slope.at<float>(r, c), b = rel.at<float>(r, c);
        double fx, fy, cx, cy;
        if (!std::isfinite(s) || !std::isfinite(b) || !gradient(z_fine, c, r, &fx, &fy) ||
            !gradient(z_coarse, c, r, &cx, &cy))
          continue;
        const double along = fx * ux + fy * uy, across = -fx * uy + fy * ux;
        const double along_surround = cx * ux + cy * uy;
        const double along_shading = -b * std::tan(e);
        const double along_new =
            (1.0 - config_.weight) * along + config_.weight * (along_surround + along_shading);
        const double d =
            (std::atan(std::hypot(along_new, across)) - std::atan(std::hypot(along, across))) / kDeg;
        delta.at<float>(r, c) = static_cast<float>(d);
        slope.at<float>(r, c) = static_cast<float>(std::max(0.0, s + d));
      }
  }
  if (delta_deg_out) *delta_deg_out = delta;
  return slope;
}

}  // namespace planetary_vo::terrain
