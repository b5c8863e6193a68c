#pragma once
/// @file dem.h
/// A real lunar elevation grid (16-bit PNG + YAML sidecar, see ../shared/data/lunar_dem/) with bicubic
/// interpolation, and its placement in the landing-site world frame of the descent sequences.

#include <memory>
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace planetary_vo::render {

/// Elevation grid in metres. Local metric coordinates (east_m, north_m) have their origin at the grid centre.
class LunarDem {
 public:
  /// Loads the YAML sidecar and its PNG (elevation_m = value - 10000). Throws std::runtime_error naming the
  /// file.
  static std::shared_ptr<const LunarDem> load(const std::string& yaml_path);
  /// Builds a DEM from an elevation image (CV_32F, metres; row 0 = north) for tests and synthetic terrains.
  LunarDem(cv::Mat1f elevation_m, double pixel_east_m, double pixel_north_m, std::string name);

  /// Bicubic (Catmull-Rom) interpolated elevation; the grid is clamped at its edges.
  double height(double east_m, double north_m) const;
  double halfWidthEastM() const { return 0.5 * elevation_.cols * pixel_east_m_; }
  double halfHeightNorthM() const { return 0.5 * elevation_.rows * pixel_north_m_; }
  double pixelEastM() const { return pixel_east_m_; }
  double pixelNorthM() const { return pixel_north_m_; }
  const std::string& name() const { return name_; }
  const std::string& path() const { return path_; }
  const cv::Mat1f& elevation() const { return elevation_; }

 private:
  cv::Mat1f elevation_;
  double pixel_east_m_ = 1.0, pixel_north_m_ = 1.0;
  std::string name_, path_;
};

/// Rigid placement of the DEM under the world frame (x crossrange, y downrange, z up; origin at the landing
/// site). World +y maps to the DEM direction of azimuth `heading_rad` (clockwise from north); z = elevation -
/// datum.
struct DemPlacement {
  double origin_east_m = 0.0;  ///< DEM coordinates of the world origin
  double origin_north_m = 0.0;
  double heading_rad = 0.0;
  double datum_m = 0.0;  ///< DEM elevation that becomes world z = 0 (the landing site's terrain)

  Eigen::Vector2d worldToDem(double x, double y) const;
};

}  // namespace planetary_vo::render
