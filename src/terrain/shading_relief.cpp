#include "planetary_vo/terrain/shading_relief.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace planetary_vo::terrain {

ShadingRelief::ShadingRelief(const PinholeCamera& camera, const ShadingReliefConfig& config)
    : camera_(camera), config_(config) {
  std::string why;
  if (!camera_.isValid(&why)) throw std::invalid_argument("ShadingRelief: invalid camera: " + why);
  if (!(config_.sun_elevation_deg >= 0.0 && config_.sun_elevation_deg <= 89.0) ||
      !(config_.sun_azimuth_deg < 0.0 || config_.sun_azimuth_deg <= 360.0) ||
      !(config_.min_sun_elevation_deg >= 0.0 && config_.min_sun_elevation_deg <= 89.0) ||
      !(config_.band_min_m > 0.0 && config_.band_max_m > config_.band_min_m &&
        std::isfinite(config_.band_max_m)) ||
      !(config_.max_pixel_footprint_m > 0.0 && std::isfinite(config_.max_pixel_footprint_m)) ||
      config_.max_keyframes < 1)
    throw std::invalid_argument(
        "ShadingRelief: invalid configuration (sun_elevation_deg and min_sun_elevation_deg in [0, 89], "
        "sun_azimuth_deg negative or at most 360, 0 < "
        "band_min_m < band_max_m, "
        "max_pixel_footprint_m > 0, max_keyframes >= 1)");
}

cv::Mat ShadingRelief::bandEnergy(const cv::Mat& gray, double pixel_footprint_m, int* scale_out) const {
  checkKeyframeImage(camera_, gray, "ShadingRelief");
  // Reduce while band_min_m still spans at least 2 pixels.
  int scale = 1;
  const cv::Mat image = reducedForSigma(gray, config_.band_min_m, pixel_footprint_m, &scale);
  const double footprint = pixel_footprint_m * scale;
  cv::Mat fine, coarse;
  cv::GaussianBlur(image, fine, cv::Size(), config_.band_min_m / footprint, 0.0, cv::BORDER_REFLECT);
  cv::GaussianBlur(image, coarse, cv::Size(), config_.band_max_m / footprint, 0.0, cv::BORDER_REFLECT);
  cv::Mat energy(image.size(), CV_32F);
  for (int r = 0; r < image.rows; ++r) {
    const float* f = fine.ptr<float>(r);
    const float* c = coarse.ptr<float>(r);
    float* e = energy.ptr<float>(r);
    for (int col = 0; col < image.cols; ++col) {
      // The black level: below 1 DN of the coarse mean the ratio means nothing (a shadow, which the shadow
      // map handles), so the denominator is held at 1.
      const float relative = (f[col] - c[col]) / std::max(c[col], 1.0f);
      e[col] = relative * relative;
    }
  }
  if (scale_out) *scale_out = scale;
  return energy;
}

bool ShadingRelief::addKeyframe(const Pose& T_world_cam, const cv::Mat& gray, double ground_elevation_m) {
  if (!active()) return false;
  return keepReducedImage(
      camera_, T_world_cam, ground_elevation_m, config_.max_pixel_footprint_m, config_.max_keyframes,
      [&](double footprint_m, int* scale) { return bandEnergy(gray, footprint_m, scale); }, &views_);
}

cv::Mat ShadingRelief::slopeRms(const GridGeometry& geometry, const cv::Mat& elevation_m,
                                double footprint_diameter_m, ShadingStats* stats, double above_deg) const {
  if (elevation_m.type() != CV_32FC1 || elevation_m.rows != geometry.rows ||
      elevation_m.cols != geometry.cols)
    throw std::invalid_argument("ShadingRelief::slopeRms: the elevation is not a CV_32F layer of the grid");
  if (!(footprint_diameter_m > 0.0)) throw std::invalid_argument("ShadingRelief::slopeRms: footprint <= 0");
  cv::Mat result = geometry.newLayer();
  ShadingStats s;
  if (!active() || views_.empty()) {
    if (stats) *stats = s;
    return result;
  }
  // The mean energy of each cell over the views that resolve it.
  const cv::Mat cell_energy =
      meanOverKeptImages(camera_, views_, geometry, elevation_m, config_.max_pixel_footprint_m);
  // RMS over the footprint disc, in degrees of slope.
  const double radius_cells = 0.5 * footprint_diameter_m / geometry.cell_size_m;
  const int reach = static_cast<int>(std::floor(radius_cells));
  std::vector<cv::Point> disc;
  for (int dr = -reach; dr <= reach; ++dr)
    for (int dc = -reach; dc <= reach; ++dc)
      if (dr * dr + dc * dc <= radius_cells * radius_cells) disc.emplace_back(dc, dr);
  // The slope a relative brightness means: tan of the Sun's elevation over the ground the relief sits on.
  const cv::Mat sun_deg = localSunElevationDeg(geometry, elevation_m, 0.5 * footprint_diameter_m);
  for (int row = 0; row < geometry.rows; ++row) {
    float* out = result.ptr<float>(row);
    const float* z = elevation_m.ptr<float>(row);
    for (int col = 0; col < geometry.cols; ++col) {
      if (!std::isfinite(z[col])) continue;
      double sum = 0.0;
      int n = 0;
      for (const cv::Point& d : disc) {
        const int c = col + d.x, r = row + d.y;
        if (!geometry.contains(c, r)) continue;
        const float e = cell_energy.at<float>(r, c);
        if (!std::isfinite(e)) continue;
        sum += e;
        ++n;
      }
      if (2 * n < static_cast<int>(disc.size())) continue;
      double sun = sun_deg.at<float>(row, col);
      if (!config_.normalise_turned_away) sun = std::max(sun, config_.sun_elevation_deg);
      sun = std::max(sun, config_.min_sun_elevation_deg);
      out[col] = static_cast<float>(std::sqrt(sum / n) * std::tan(sun * M_PI / 180.0) * 180.0 / M_PI);
      ++s.cells_measured;
      if (out[col] > above_deg) ++s.cells_above;
    }
  }
  if (stats) *stats = s;
  return result;
}

cv::Mat ShadingRelief::localSunElevationDeg(const GridGeometry& geometry, const cv::Mat& elevation_m,
                                            double radius_m) const {
  if (elevation_m.type() != CV_32FC1 || elevation_m.rows != geometry.rows ||
      elevation_m.cols != geometry.cols)
    throw std::invalid_argument(
        "ShadingRelief::localSunElevationDeg: the elevation is not a CV_32F layer of the grid");
  cv::Mat out = geometry.newLayer();
  const double e = config_.sun_elevation_deg * M_PI / 180.0;
  const bool level = config_.sun_azimuth_deg < 0.0;
  const double a = level ? 0.0 : config_.sun_azimuth_deg * M_PI / 180.0;
  const Eigen::Vector3d sun(std::cos(e) * std::sin(a), std::cos(e) * std::cos(a), std::sin(e));
  const int k = std::max(1, static_cast<int>(std::lround(radius_m / geometry.cell_size_m)));
  const double step_m = k * geometry.cell_size_m;
  // dz per metre along one axis from z at -k, 0 and +k cells (NaN = unknown or outside).
  const auto gradient = [step_m](double minus, double centre, double plus) {
    if (std::isfinite(minus) && std::isfinite(plus)) return (plus - minus) / (2.0 * step_m);
    if (std::isfinite(plus)) return (plus - centre) / step_m;
    if (std::isfinite(minus)) return (centre - minus) / step_m;
    return 0.0;
  };
  const auto z = [&](int c, int r) {
    return geometry.contains(c, r) ? double(elevation_m.at<float>(r, c)) : std::nan("");
  };
  for (int row = 0; row < geometry.rows; ++row)
    for (int col = 0; col < geometry.cols; ++col) {
      const double centre = z(col, row);
      if (!std::isfinite(centre)) continue;
      if (level) {
        out.at<float>(row, col) = static_cast<float>(config_.sun_elevation_deg);
        continue;
      }
      const double dz_dx = gradient(z(col - k, row), centre, z(col + k, row));
      const double dz_dy = gradient(z(col, row - k), centre, z(col, row + k));
      const Eigen::Vector3d normal = Eigen::Vector3d(-dz_dx, -dz_dy, 1.0).normalized();
      const double sine = std::clamp(normal.dot(sun), -1.0, 1.0);
      out.at<float>(row, col) = static_cast<float>(std::asin(sine) * 180.0 / M_PI);
    }
  return out;
}

}  // namespace planetary_vo::terrain
