#pragma once
/// @file terrain_map.h
/// The terrain model of the whole descent, built from the VO's map events (vo/map_events.h) without looking
/// into the VO: every point the VO triangulated, refined or retired is kept (a retired point is a final
/// estimate of the ground, not forgotten when it leaves the VO's window), rejected points are dropped. On
/// request it rasterises the landing area (terrain/landing_area.h) into elevation, its uncertainty, slope and
/// roughness (terrain/surface_analysis.h, the definitions the ground truth uses).
///
/// Elevation of a cell: a weighted least-squares plane z = a + gx dx + gy dy through the points within
/// support_radius_m of the cell centre (weight 1 / (sigma_z^2 + sigma_floor^2) of each point, times a
/// Gaussian of its distance with sigma support_radius_m / 2), evaluated at the centre: a; its 1-sigma from
/// the fit's covariance, scaled up by the fit's residual scatter when that is larger than the points'
/// sigmas. With fewer than min_points_per_fit points, points all on a line, or points whose weighted
/// centroid is off the cell by more than max_support_offset of the radius (one-sided support: the plane
/// would be extrapolated) the cell stays unknown (NaN): a hole in the map is reported, never filled in.
///
/// Frames and units: the VO world of the events. It must be gravity-aligned (z up: the initial pose handed
/// over, or the visual-inertial alignment) for slopes to mean anything; distances are metres only when the
/// navigation was metric (apply(..., metric_scale)); in vision-only mode slopes stay valid (the map's
/// scale is isotropic) but elevations, roughness and the support radius are in the map's unit, and
/// TerrainProducts::metric says so.

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/terrain/grid.h"
#include "planetary_vo/terrain/landing_area.h"
#include "planetary_vo/vo/map_events.h"

namespace planetary_vo::terrain {

struct TerrainMapConfig {
  LandingAreaParams area;  ///< the grid and the lander's footprint
  /// Points whose vertical 1-sigma (from their triangulation covariance) exceeds this are not used, e.g.
  /// points seen from nearly parallel rays. Metres (map units when not metric).
  double max_point_sigma_z_m = 2.0;
  /// Added in quadrature to every point's vertical sigma: what the triangulation covariance leaves out
  /// (the keyframe poses' own errors).
  double point_sigma_floor_m = 0.1;
  /// Radius of the points around a cell that its elevation plane is fitted to (m).
  double support_radius_m = 4.0;
  int min_points_per_fit = 4;
  /// A cell is known only when the weighted centroid of its support points lies within this fraction of
  /// support_radius_m of its centre: the plane is interpolated there, not extrapolated from points on one
  /// side (the edge of the seen ground). 1 = no such test.
  double max_support_offset = 0.35;
};

struct TerrainProducts {
  /// Layers elevation_m, elevation_sigma_m, relief_sigma_m (the intercept's sigma from the fit's scatter),
  /// residual_rms_m (the points' weighted RMS distance from the fitted plane: noise plus unresolved relief),
  /// slope_sigma_deg (the 1-sigma of the fitted plane's gradient
  /// along its worst direction, as an angle: the slope uncertainty at the map's resolution), support_points
  /// (count within the support radius), slope_deg, roughness_m on config.area.geometry(); parameters record
  /// the config.
  GridSet grids;
  bool metric = false;    ///< distances in metres (else the VO map's unit)
  size_t num_points = 0;  ///< points in the model
  size_t num_used = 0;    ///< ... inside the area with a usable sigma
  int cells_known = 0;    ///< cells with an elevation
};

class TerrainMap {
 public:
  /// Throws std::invalid_argument on a non-positive radius, sigma or cell size, or min_points_per_fit < 3.
  explicit TerrainMap(const TerrainMapConfig& config = TerrainMapConfig());

  /// One frame's events; metric_scale = FrameResult::metric_scale of that frame.
  void apply(const MapEvents& events, bool metric_scale);
  void clear();

  size_t numPoints() const { return points_.size(); }
  /// Median height (world z) of the usable points over the landing area (plus the support radius); NaN
  /// without any. The ground height a densifier predicts with (densifier.h).
  double medianGroundHeight() const;
  const TerrainMapConfig& config() const { return config_; }
  /// The rasters of the landing area now (cost: the points near the area times the cells).
  TerrainProducts products() const;

 private:
  struct StoredPoint {
    Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
    double sigma_z = 0.0;
    bool retired = false;
  };
  void store(const MapPointState& state, bool retired);

  TerrainMapConfig config_;
  std::unordered_map<uint64_t, StoredPoint> points_;
  bool metric_ = false;
};

}  // namespace planetary_vo::terrain
