#pragma once
/// @file landing_sites.h
/// The ranked list of safe landing sites near a target, from a hazard map's slope and roughness (and, when
/// there, the elevation's uncertainty): what hazard detection and avoidance hands to guidance (issue 11).
///
/// A site is a cell of the grid (its centre, world frame of terrain/grid.h). A cell qualifies when
///  1. it is safe with confidence: slope + k sigma_slope <= max_slope_deg and roughness + k sigma_roughness
///     <= max_roughness_m (terrain/hazard.h applied to the raised values; an unknown cell is never safe),
///     and, when the grid set has the layer `shadow_fraction` (terrain/shadow_map.h), it was not seen in
///     shadow in more than max_shadow_fraction of its views (such a cell is unknown: its relief is unseen);
///     when it has the layer `shading_slope_deg` (terrain/shading_relief.h), that is at most
///     max_shading_slope_deg (above, the shading shows relief the plane fit smooths away: a hazard);
///  2. its clearance, the distance from its centre to the centre of the nearest cell that is not safe with
///     confidence (hazardous, unknown, or outside the grid, which counts as unknown), is >= min_clearance_m;
///  3. its centre lies within max_distance_from_target_m of the target.
///
/// Uncertainty (layer `elevation_sigma_m`, the elevation's 1-sigma; without it sigma_slope = sigma_roughness
/// = 0; with the terrain model's own `slope_sigma_deg` layer, that replaces the slope bound below: see
/// surfaceSigmas). sigma_z of a cell = the largest elevation sigma over its footprint disc (the disc its
/// slope and roughness were computed over, terrain/surface_analysis.h, diameter from the grid set's parameter
/// `footprint_diameter_m`). The slope is the gradient of a least-squares plane over the disc's cells, g_x =
/// sum(dx_i z_i) / sum(dx_i^2), so an elevation error e_i moves it by sum(dx_i e_i) / sum(dx_i^2). Whatever
/// the correlation of the cells' errors, the standard deviation of that sum is at most sum(|dx_i|) sigma_z
/// (the standard deviation of a sum is at most the sum of the standard deviations), reached when the errors
/// are fully correlated with opposite signs on either side of the centre, a tilt of the disc: the error to
/// expect from the terrain map, whose cells are plane fits to shared points within a support radius about
/// the footprint's size (terrain/terrain_map.h). So, along any direction,
///   sigma_gradient = c sigma_z,  c = sum(|dx_i|) / sum(dx_i^2)  (1/m; 3.33 / footprint diameter for the
///                                                              4 m disc of 0.5 m cells),
///   sigma_slope_deg = atan(sigma_gradient) in degrees (a gradient error of s along the slope changes the
///                     slope angle by at most atan(s)),
/// against sigma_z / sqrt(sum(dx_i^2)) (5.8x less on that disc) if the errors were independent. The roughness
/// is the largest |z_i - plane(dx_i, dy_i)| over the disc: the error of one cell's residual is its elevation
/// error less the plane's there, sigma_z sqrt(1 - 1/N - d_i^2 / sum(dx^2)) for independent errors and less
/// when they are positively correlated, so sigma_roughness = sigma_z bounds it. Test
/// LandingSites.SlopeSigmaIsTheTiltOfTheWorstCorrelatedElevationError checks c and the 5.8 against the plane
/// fit of surface_analysis.
///
/// Ranking. Each qualifying cell has three margins as fractions of their limits:
///   slope     (max_slope_deg - slope - k sigma_slope) / max_slope_deg,
///   roughness (max_roughness_m - roughness - k sigma_roughness) / max_roughness_m,
///   clearance (clearance - min_clearance_m) / min_clearance_m,
/// and score = min(the three) - distance_weight * distance_to_target / max_distance_from_target_m: the
/// tightest margin, less a divert cost (with the default weight 1, a site 10 % of the search radius farther
/// must have 10 % more of its tightest margin). The best cell is taken first; then, repeatedly, the best
/// cell at least min_separation_m from every site already taken, up to max_sites (ties: the nearer to the
/// target, then the lower row, then the lower column). Sites are returned best first.
///
/// Cost: a dilation for sigma_z, a distance transform (cv::distanceTransform, exact Euclidean) for the
/// clearance, one pass over the cells, and max_sites passes over the qualifying cells.

#include <string>
#include <vector>

#include "planetary_vo/terrain/grid.h"
#include "planetary_vo/terrain/hazard.h"

namespace planetary_vo::terrain {

struct LandingSiteParams {
  /// The target (world frame): the planned landing site, the origin of the landing-site frame.
  double target_x_m = 0.0;
  double target_y_m = 0.0;
  /// How far from the target a site may be: the divert the lander can still fly at the low gate (100 m up,
  /// 100 m short of the site in the Lunar approach). The default, the low gate's altitude, is an assumption
  /// (no vehicle is specified here); a vehicle sets its own. With 50 m, the oblique approaches found no site
  /// the map could certify near the target (docs/terrain/README.md, the campaign).
  double max_distance_from_target_m = 100.0;
  int max_sites = 5;
  /// Distinct alternatives rather than neighbouring cells of one patch: the footprint (4 m) plus the
  /// dispersion (min_clearance_m) on either side.
  double min_separation_m = 10.0;
  /// k: a cell is safe with confidence when its slope and roughness raised by k sigma stay within the
  /// thresholds. 2.5: against the truth as sampled (not smoothed to the map's resolution) the terrain
  /// model's slope sigma covers 0.85-0.96 of the errors at 2 sigma, not 0.95 (steep ground is flattened by
  /// the plane fit's 4 m support), and with k = 2 five of 18 sites chosen on the three flight approach
  /// renders were unsafe at true slopes of 10.0-10.8 deg; with 2.5 none of 16 (docs/terrain/README.md).
  double confidence_k = 2.5;
  /// The touchdown dispersion about the aim point: every cell within this distance of a site must be safe
  /// (each cell's slope and roughness already cover the footprint centred on it, so the footprint is not
  /// added again). A touchdown point is judged by the cell it falls in, whose centre may be half a cell
  /// diagonal (0.35 m for 0.5 m cells) farther than the point: include that in the value. Must be > 0. The
  /// default is an assumption (no lander dispersion is specified in this project); a vehicle sets its own.
  double min_clearance_m = 3.0;
  /// Weight of the distance to the target against the tightest margin in the score (see the file comment).
  double distance_weight = 1.0;
};

struct LandingSite {
  int col = 0, row = 0;
  double x_m = 0.0, y_m = 0.0;  ///< world x, y of the cell centre
  double elevation_m = 0.0;     ///< NaN when the grid set has no `elevation_m` layer
  double slope_deg = 0.0, roughness_m = 0.0;
  double slope_sigma_deg = 0.0, roughness_sigma_m = 0.0;  ///< 0 without `elevation_sigma_m`
  /// max_slope_deg - (slope + k sigma_slope) and max_roughness_m - (roughness + k sigma_roughness): >= 0.
  double slope_margin_deg = 0.0, roughness_margin_m = 0.0;
  double clearance_m = 0.0;           ///< to the nearest cell not safe with confidence (centre to centre)
  double distance_to_target_m = 0.0;  ///< from the cell centre
  double score = 0.0;
};

struct LandingSiteResult {
  std::vector<LandingSite> sites;    ///< best first; empty when no cell qualifies
  std::string reason;                ///< why `sites` is empty (empty otherwise)
  bool uncertainty_applied = false;  ///< the grid set had `elevation_sigma_m`
  /// Cells whose centre is within max_distance_from_target_m of the target, and of those: with a known
  /// slope and roughness, safe with confidence, and qualifying (clearance too).
  int cells_in_reach = 0, cells_known = 0, cells_safe = 0, cells_qualifying = 0;
};

/// c of the file comment: the bound on the plane's gradient error per metre of elevation sigma over a
/// footprint disc (1/m). Throws std::invalid_argument as footprintOffsets does.
double slopeSigmaPerElevationSigma(double cell_size_m, double footprint_diameter_m);

/// The 1-sigma of slope and roughness findLandingSites raises them by: roughness_m = sigma_z, the largest
/// `elevation_sigma_m` over the footprint disc; slope_deg = the largest `slope_sigma_deg` over the disc when
/// the grid set has that layer (the gradient uncertainty of the terrain model's plane fits,
/// terrain_map.h), else the correlated-error bound atan(c sigma_z) of the file comment. NaN where a sigma
/// over the disc is unknown. `available` is false (layers empty) without `elevation_sigma_m`.
/// unresolved_relief_m: the largest `residual_rms_m` over the disc when the grid set has it (the terrain
/// model's points' RMS distance from their fitted plane: noise plus relief smaller than the fit's support);
/// findLandingSites raises the roughness to at least this, so a site where it exceeds the roughness limit is
/// never certified. Empty without the layer.
struct SurfaceSigmas {
  bool available = false;
  bool slope_from_fit = false;  ///< slope_deg from `slope_sigma_deg`, not from the bound
  cv::Mat slope_deg, roughness_m;
  cv::Mat unresolved_relief_m;
};
/// Throws std::invalid_argument when `elevation_sigma_m` is there without the `footprint_diameter_m`
/// parameter.
SurfaceSigmas surfaceSigmas(const GridSet& grids);

/// The sites of `grids` (layers `slope_deg`, `roughness_m`; optional `elevation_m`, `elevation_sigma_m`,
/// the latter requiring the parameter `footprint_diameter_m`). Throws std::invalid_argument on a missing or
/// malformed layer, non-positive thresholds, or parameters out of range (max_sites < 1, negative k,
/// separation or weight, non-positive or non-finite clearance or distance).
LandingSiteResult findLandingSites(const GridSet& grids, const HazardThresholds& thresholds,
                                   const LandingSiteParams& params = LandingSiteParams());

/// The sites a run chose and the parameters they were chosen with, as a YAML file (`landing_sites.yaml`
/// beside a run's terrain.yaml: vo_run --output-terrain, hazard_recorder), what terrain_eval checks against
/// the truth. Throws std::runtime_error when the file cannot be written.
void writeLandingSites(const std::string& path, const LandingSiteResult& result,
                       const LandingSiteParams& params);
/// Reads what writeLandingSites wrote (result.sites, reason, cell counts; params). Throws std::runtime_error
/// on a missing or malformed file.
LandingSiteResult readLandingSites(const std::string& path, LandingSiteParams* params);

}  // namespace planetary_vo::terrain
