#include "planetary_vo/terrain/resolution.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "planetary_vo/terrain/surface_analysis.h"

namespace planetary_vo::terrain {

cv::Mat elevationAtSupport(const GridGeometry& geometry, const cv::Mat& elevation_m,
                           double support_radius_m) {
  if (elevation_m.type() != CV_32FC1 || elevation_m.rows != geometry.rows ||
      elevation_m.cols != geometry.cols)
    throw std::invalid_argument("elevationAtSupport: elevation layer of the wrong size or type");
  if (!(support_radius_m >= geometry.cell_size_m))
    throw std::invalid_argument("elevationAtSupport: the support radius must be at least one cell");
  // The support disc's offsets, weights and the (constant) normal matrix of the plane fit.
  struct Tap {
    int dc, dr;
    double dx, dy, w;
  };
  std::vector<Tap> taps;
  const int reach = static_cast<int>(std::floor(support_radius_m / geometry.cell_size_m));
  const double inv_2s2 = 1.0 / (2.0 * std::pow(0.5 * support_radius_m, 2));
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  for (int dr = -reach; dr <= reach; ++dr) {
    for (int dc = -reach; dc <= reach; ++dc) {
      const double dx = dc * geometry.cell_size_m, dy = dr * geometry.cell_size_m;
      const double d2 = dx * dx + dy * dy;
      if (d2 > support_radius_m * support_radius_m) continue;
      const double w = std::exp(-d2 * inv_2s2);
      taps.push_back({dc, dr, dx, dy, w});
      const Eigen::Vector3d a(1.0, dx, dy);
      A += w * a * a.transpose();
    }
  }
  // The fitted plane's value at the centre is a fixed linear combination of the samples: row 0 of A^-1
  // times the taps' design vectors.
  const Eigen::Vector3d e0 = A.ldlt().solve(Eigen::Vector3d::UnitX());
  std::vector<double> coefficient(taps.size());
  for (size_t k = 0; k < taps.size(); ++k)
    coefficient[k] = taps[k].w * (e0(0) + e0(1) * taps[k].dx + e0(2) * taps[k].dy);
  cv::Mat out = geometry.newLayer();
  for (int row = reach; row < geometry.rows - reach; ++row) {
    for (int col = reach; col < geometry.cols - reach; ++col) {
      double z = 0.0;
      bool known = true;
      for (size_t k = 0; k < taps.size() && known; ++k) {
        const float v = elevation_m.at<float>(row + taps[k].dr, col + taps[k].dc);
        known = std::isfinite(v);
        z += coefficient[k] * v;
      }
      if (known) out.at<float>(row, col) = static_cast<float>(z);
    }
  }
  return out;
}

GridSet truthAtSupport(const GridSet& truth, double support_radius_m, double footprint_diameter_m) {
  const auto it = truth.layers.find("elevation_m");
  if (it == truth.layers.end()) throw std::invalid_argument("truthAtSupport: no elevation_m layer");
  GridSet out;
  out.geometry = truth.geometry;
  out.description = "the truth seen at a support radius (terrain/resolution.h)";
  out.parameters = {{"support_radius_m", support_radius_m}, {"footprint_diameter_m", footprint_diameter_m}};
  const cv::Mat elevation = elevationAtSupport(truth.geometry, it->second, support_radius_m);
  const SurfaceMaps surface = analyzeSurface(truth.geometry, elevation, footprint_diameter_m);
  out.layers = {
      {"elevation_m", elevation}, {"slope_deg", surface.slope_deg}, {"roughness_m", surface.roughness_m}};
  return out;
}

}  // namespace planetary_vo::terrain
