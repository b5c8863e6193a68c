#include "planetary_vo/terrain/terrain_map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "planetary_vo/terrain/surface_analysis.h"

namespace planetary_vo::terrain {
namespace {

uint64_t bucketKey(int64_t bx, int64_t by) {
  return (static_cast<uint64_t>(bx) << 32) ^ (static_cast<uint64_t>(by) & 0xffffffffULL);
}

}  // namespace

TerrainMap::TerrainMap(const TerrainMapConfig& config) : config_(config) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(config_.support_radius_m) || !positive(config_.max_point_sigma_z_m) ||
      !(std::isfinite(config_.point_sigma_floor_m) && config_.point_sigma_floor_m >= 0.0) ||
      !positive(config_.area.cell_size_m) || !positive(config_.area.half_extent_m) ||
      !positive(config_.area.footprint_diameter_m))
    throw std::invalid_argument(
        "TerrainMap: radii, sigmas, cell size, extent and footprint must be positive");
  if (!(config_.max_support_offset > 0.0 && config_.max_support_offset <= 1.0))
    throw std::invalid_argument("TerrainMap: max_support_offset must be in (0, 1]");
  if (config_.min_points_per_fit < 3)
    throw std::invalid_argument("TerrainMap: min_points_per_fit must be at least 3 (a plane)");
}

void TerrainMap::store(const MapPointState& state, bool retired) {
  if (!state.p_world.allFinite() || !state.covariance_world.allFinite()) return;
  StoredPoint& p = points_[state.id];
  p.p_world = state.p_world;
  p.sigma_z = std::sqrt(std::max(0.0, state.covariance_world(2, 2)));
  p.retired = retired;
}

void TerrainMap::apply(const MapEvents& events, bool metric_scale) {
  // A change between up-to-scale and metric (the altimeter or the IMU fixed the scale) rescales the VO's map,
  // and the events of that frame carry every point at its new place; points retired before keep the old
  // unit and are dropped.
  if (metric_scale != metric_) {
    for (auto it = points_.begin(); it != points_.end();) it = it->second.retired ? points_.erase(it) : ++it;
    metric_ = metric_scale;
  }
  for (const MapPointState& p : events.points_added) store(p, false);
  for (const MapPointState& p : events.points_updated) store(p, false);
  for (const MapPointState& p : events.points_retired) store(p, true);
  for (uint64_t id : events.points_removed) points_.erase(id);
}

void TerrainMap::clear() {
  points_.clear();
  metric_ = false;
}

double TerrainMap::medianGroundHeight() const {
  const GridGeometry geometry = config_.area.geometry();
  const double R = config_.support_radius_m;
  std::vector<double> z;
  for (const auto& entry : points_) {
    const Eigen::Vector3d& p = entry.second.p_world;
    if (p.x() < geometry.x_m(0) - R || p.x() > geometry.x_m(geometry.cols - 1) + R ||
        p.y() < geometry.y_m(0) - R || p.y() > geometry.y_m(geometry.rows - 1) + R ||
        !(entry.second.sigma_z <= config_.max_point_sigma_z_m))
      continue;
    z.push_back(p.z());
  }
  if (z.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(z.begin(), z.begin() + static_cast<std::ptrdiff_t>(z.size() / 2), z.end());
  return z[z.size() / 2];
}

TerrainProducts TerrainMap::products() const {
  TerrainProducts out;
  out.metric = metric_;
  out.num_points = points_.size();
  const GridGeometry geometry = config_.area.geometry();
  out.grids.geometry = geometry;
  out.grids.description =
      std::string(
          "terrain model from the VO map events: elevation (weighted local plane fit), slope and "
          "roughness over the footprint; ") +
      (metric_ ? "metres" : "NOT METRIC: map units (slopes valid, distances not)");
  out.grids.parameters = {{"footprint_diameter_m", config_.area.footprint_diameter_m},
                          {"support_radius_m", config_.support_radius_m},
                          {"max_point_sigma_z_m", config_.max_point_sigma_z_m},
                          {"point_sigma_floor_m", config_.point_sigma_floor_m},
                          {"min_points_per_fit", config_.min_points_per_fit},
                          {"max_support_offset", config_.max_support_offset},
                          {"metric", metric_ ? 1.0 : 0.0}};
  cv::Mat elevation = geometry.newLayer(), sigma = geometry.newLayer(), support = geometry.newLayer(0.0f);
  cv::Mat slope_sigma = geometry.newLayer(), relief_sigma = geometry.newLayer();
  cv::Mat residual_rms = geometry.newLayer();

  // The usable points near the area, bucketed by the support radius.
  const double R = config_.support_radius_m;
  const double x_min = geometry.x_m(0) - R, x_max = geometry.x_m(geometry.cols - 1) + R;
  const double y_min = geometry.y_m(0) - R, y_max = geometry.y_m(geometry.rows - 1) + R;
  struct Used {
    Eigen::Vector3d p;
    double weight;
  };
  std::vector<Used> used;
  std::unordered_map<uint64_t, std::vector<size_t>> buckets;
  const double floor2 = config_.point_sigma_floor_m * config_.point_sigma_floor_m;
  for (const auto& entry : points_) {
    const StoredPoint& sp = entry.second;
    const Eigen::Vector3d& p = sp.p_world;
    if (p.x() < x_min || p.x() > x_max || p.y() < y_min || p.y() > y_max) continue;
    if (!(sp.sigma_z <= config_.max_point_sigma_z_m)) continue;
    const double variance = sp.sigma_z * sp.sigma_z + floor2;
    if (!(variance > 0.0)) continue;
    buckets[bucketKey(static_cast<int64_t>(std::floor(p.x() / R)),
                      static_cast<int64_t>(std::floor(p.y() / R)))]
        .push_back(used.size());
    used.push_back({p, 1.0 / variance});
  }
  out.num_used = used.size();

  const double kernel_sigma = 0.5 * R;
  const double inv_2ks2 = 1.0 / (2.0 * kernel_sigma * kernel_sigma);
  for (int row = 0; row < geometry.rows; ++row) {
    const double cy = geometry.y_m(row);
    for (int col = 0; col < geometry.cols; ++col) {
      const double cx = geometry.x_m(col);
      const int64_t bx = static_cast<int64_t>(std::floor(cx / R)),
                    by = static_cast<int64_t>(std::floor(cy / R));
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      double wzz = 0.0;
      int n = 0;
      for (int64_t dy = -1; dy <= 1; ++dy) {
        for (int64_t dx = -1; dx <= 1; ++dx) {
          const auto it = buckets.find(bucketKey(bx + dx, by + dy));
          if (it == buckets.end()) continue;
          for (size_t k : it->second) {
            const Used& u = used[k];
            const double ox = u.p.x() - cx, oy = u.p.y() - cy;
            const double d2 = ox * ox + oy * oy;
            if (d2 > R * R) continue;
            const double w = u.weight * std::exp(-d2 * inv_2ks2);
            const Eigen::Vector3d a(1.0, ox, oy);
            A.noalias() += w * a * a.transpose();
            b += w * u.p.z() * a;
            wzz += w * u.p.z() * u.p.z();
            ++n;
          }
        }
      }
      support.at<float>(row, col) = static_cast<float>(n);
      if (n < config_.min_points_per_fit) continue;
      // One-sided support (the edge of the seen ground): the plane would be extrapolated to the centre.
      if (std::hypot(A(0, 1), A(0, 2)) > config_.max_support_offset * R * A(0, 0)) continue;
      // Points (nearly) on a line leave the plane undetermined: refuse rather than guess. The moments are
      // compared in units of the radius so that the test does not depend on the map's unit.
      Eigen::Matrix3d A_scaled = A;
      A_scaled.row(1) *= R;
      A_scaled.row(2) *= R;
      A_scaled.col(1) *= R;
      A_scaled.col(2) *= R;
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A_scaled / A(0, 0));
      if (!(eig.eigenvalues()(0) > 1e-3)) continue;
      const Eigen::LDLT<Eigen::Matrix3d> ldlt(A);
      const Eigen::Vector3d x = ldlt.solve(b);
      Eigen::Matrix3d covariance = ldlt.solve(Eigen::Matrix3d::Identity());
      const double chi2 = std::max(0.0, wzz - 2.0 * x.dot(b) + x.dot(A * x));
      const double scatter = n > 3 ? chi2 / (n - 3) : 1.0;
      const Eigen::Matrix2d gradient_covariance = covariance.block<2, 2>(1, 1) * scatter;
      relief_sigma.at<float>(row, col) = static_cast<float>(std::sqrt(covariance(0, 0) * scatter));
      // The points' weighted RMS distance from the fitted plane (metres): their noise plus the relief the
      // plane does not follow.
      residual_rms.at<float>(row, col) = static_cast<float>(std::sqrt(chi2 / A(0, 0)));
      covariance *= std::max(1.0, scatter);
      elevation.at<float>(row, col) = static_cast<float>(x(0));
      sigma.at<float>(row, col) = static_cast<float>(std::sqrt(covariance(0, 0)));
      // The fitted plane's gradient: its 1-sigma along the worst direction, as a slope angle.
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> gradient(gradient_covariance);
      slope_sigma.at<float>(row, col) =
          static_cast<float>(std::atan(std::sqrt(std::max(0.0, gradient.eigenvalues()(1)))) * 180.0 / M_PI);
      ++out.cells_known;
    }
  }
  const SurfaceMaps surface = analyzeSurface(geometry, elevation, config_.area.footprint_diameter_m);
  out.grids.layers["elevation_m"] = elevation;
  out.grids.layers["elevation_sigma_m"] = sigma;
  out.grids.layers["slope_sigma_deg"] = slope_sigma;
  out.grids.layers["relief_sigma_m"] = relief_sigma;
  out.grids.layers["residual_rms_m"] = residual_rms;
  out.grids.layers["support_points"] = support;
  out.grids.layers["slope_deg"] = surface.slope_deg;
  out.grids.layers["roughness_m"] = surface.roughness_m;
  return out;
}

}  // namespace planetary_vo::terrain
