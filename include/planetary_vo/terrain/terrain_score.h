#pragma once
/// @file terrain_score.h
/// Scores an estimated terrain map of the landing area against the true one the renderer wrote
/// (render/terrain_truth.h): on the cells known in both, the elevation error (RMSE and mean, metres, world
/// z), the slope and roughness errors, and the hazard map's precision and recall (terrain/hazard.h: a
/// hazard found where there is one / every true hazard found; an estimate with the layer shadow_fraction
/// has its cells seen in shadow unknown there, and one with shading_slope_deg its cells above
/// max_shading_slope_deg hazards, as it publishes them), plus how much of the area the
/// estimate covers at all. Both grid sets must share one geometry (the landing area of
/// terrain/landing_area.h).

#include <string>

#include "planetary_vo/terrain/grid.h"
#include "planetary_vo/terrain/hazard.h"
#include "planetary_vo/terrain/landing_sites.h"

namespace planetary_vo::terrain {

struct TerrainScore {
  int cells = 0;                                            ///< cells of the area
  int cells_elevation = 0;                                  ///< cells with a true and an estimated elevation
  double elevation_coverage = 0;                            ///< cells_elevation / cells with a true elevation
  double elevation_rmse_m = 0, elevation_mean_error_m = 0;  ///< estimate - truth
  int cells_surface = 0;        ///< cells with true and estimated slope and roughness
  double surface_coverage = 0;  ///< cells_surface / cells with a true slope and roughness
  double slope_rmse_deg = 0, roughness_rmse_m = 0;
  double slope_error_median_deg = 0, slope_error_p90_deg = 0;   ///< of |estimate - truth|
  double slope_mean_error_deg = 0, roughness_mean_error_m = 0;  ///< estimate - truth (a bias)
  /// Hazard cells over cells_surface: true positives (hazard in both), false positives (estimated only),
  /// false negatives (true only), true negatives.
  int hazard_tp = 0, hazard_fp = 0, hazard_fn = 0, hazard_tn = 0;
  double hazard_precision = 0, hazard_recall = 0;  ///< NaN when undefined (no hazard estimated / true)
  /// Calibration of the estimate's own uncertainty (surfaceSigmas of landing_sites.h, what the site search
  /// raises slope and roughness by), over the cells_surface cells with a known sigma: the fraction whose
  /// |error| is within 1 and 2 sigma (0.68 and 0.95 for a calibrated Gaussian). NaN without sigmas.
  int cells_sigma = 0;
  double slope_within_1sigma = 0, slope_within_2sigma = 0;
  double roughness_within_1sigma = 0, roughness_within_2sigma = 0;
};

/// Throws std::invalid_argument when the geometries differ or a layer (elevation_m, slope_deg,
/// roughness_m) is missing.
TerrainScore scoreTerrain(const GridSet& truth, const GridSet& estimate, const HazardThresholds& thresholds);

/// A chosen landing site against the truth: safe when every true cell within the clearance the site was
/// chosen with (LandingSiteParams::min_clearance_m, centre to centre, as findLandingSites counts it) is known
/// and safe.
struct SiteCheck {
  bool truly_safe = false;
  double true_slope_deg = 0, true_roughness_m = 0;             ///< at the site's cell (NaN when unknown)
  int cells_checked = 0, cells_hazard = 0, cells_unknown = 0;  ///< within the clearance
  /// Distance from the site to the nearest true hazard or unknown cell found within 3 clearances (NaN:
  /// none there).
  double nearest_unsafe_m = 0;
};

/// Throws std::invalid_argument when the truth lacks slope_deg or roughness_m.
SiteCheck checkSite(const GridSet& truth, const LandingSite& site, const HazardThresholds& thresholds,
                    const LandingSiteParams& params);

/// The truth as a map built in the navigation's frame sees it, and as a lander guided by that navigation
/// meets it. The navigation places everything it sees displaced by its own error e = estimate - truth
/// (world, m): the map's cell (x, y) shows the true ground at (x - e_x, y - e_y), e_z higher, and a lander
/// that flies to a site at (x, y) by that navigation touches down on that same ground (with the error it
/// had while mapping: what drifts after that is the site search's clearance). Every layer is moved by
/// (e_x, e_y) rounded to whole cells (at most half a cell off per axis); `elevation_m` is raised by e_z;
/// cells the move brings in from outside the grid are unknown (NaN). Scoring a map and checking its sites
/// against this truth measures the map, not the navigation's absolute error at the time (which vision
/// alone cannot remove without a map of the site). Throws std::invalid_argument on a non-finite error.
GridSet truthInNavigationFrame(const GridSet& truth, double error_x_m, double error_y_m, double error_z_m);

/// The score as one JSON object (NaN as null).
std::string toJson(const TerrainScore& score);

}  // namespace planetary_vo::terrain
