#pragma once
/// @file shading_relief.h
/// Relief smaller than the map's plane fit, read from the shading of the keyframe images (issue 11: the
/// rocks and small craters that a high Sun leaves without shadow).
///
/// The terrain model fits a plane to the points within 4 m of a cell (terrain_map.h), so a crater 1-2 m
/// across or a rock 0.3 m high is smoothed away; at a low Sun their shadows mark them (shadow_map.h), but
/// not all of them, and at a Sun above about 15 deg they cast almost none (session 11's campaign: every
/// unsafe site was there). Their facets still shade: with the Sun at elevation e over level ground, a
/// facet tilted by a small angle s toward or away from the Sun changes the brightness by a fraction of
/// about s / tan(e) (Lambert; the Lunar-Lambert law of the Moon's regolith behaves alike at the phase
/// angles of a descent), while the albedo of the regolith varies over tens of metres, not over one. So the
/// relative brightness between two scales of relief, times tan(e), measures the slopes of that relief in
/// radians.
///
/// Per keyframe (addKeyframe): the image is reduced so that band_min_m spans at least 2 pixels, blurred at
/// band_min_m and band_max_m (Gaussian sigmas, in metres of ground at the image centre), and the squared
/// relative difference (G_min - G_max)^2 / G_max^2 is kept (16-bit float) with the pose. Per query
/// (slopeRms): every cell of known elevation is projected into the kept views whose pixel covers at most
/// max_pixel_footprint_m there; the cell's energy is the mean over them; the result is the root mean square
/// over the lander's footprint disc of those energies times tan(sun elevation), in degrees: the RMS slope
/// of the relief between band_min_m and band_max_m under the footprint. The hazard map marks a cell whose
/// value exceeds thresholds.max_shading_slope_deg a hazard (hazard.h).
///
/// Needs the Sun's elevation over the landing area (the mission's ephemeris at the landing time; the
/// dataset's sequence.yaml gives the one it was rendered with): sun_elevation_deg = 0 means not given, and
/// no shading relief is computed; nor below min_sun_elevation_deg, where the shadows take over. The measure
/// is the magnitude of the shading, not its sign. What matters is the Sun's elevation over the ground the
/// relief sits on, not over level ground: on ground tilted toward the Sun by t the same relief shades as
/// under a Sun t higher (less), away from it as under one t lower (more). With the Sun's azimuth given
/// (sun_azimuth_deg, also from the ephemeris), each cell's value is normalised by the tangent of the Sun's
/// elevation over the map's own ground there (its elevation's gradient over the footprint's radius), held
/// at min_sun_elevation_deg where it is lower (ground turned away from the Sun). On the 40 maps of six
/// campaigns with a Sun of 5-15 deg, this brought the ratio of the reading to the true relief in the band
/// (per map, of the medians over its cells; scripts/shading_calibration.py) from 0.42-0.99 (interquartile
/// over the maps) to 0.60-0.69; on the 60 with a higher Sun from 0.71-0.91 to 0.67-0.83
/// (docs/terrain/README.md, session 25). Without the azimuth the ground is taken as level. Frames: the world
/// of the poses (gravity-aligned, z up, metres), as the shadow map.

#include <deque>

#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/terrain/grid.h"
#include "planetary_vo/terrain/keyframe_view.h"

namespace planetary_vo::terrain {

struct ShadingReliefConfig {
  bool enabled = true;
  /// [deg] The Sun's elevation over the landing area at the time of the landing (ephemeris). 0 = not given:
  /// no shading relief. Must be in [0, 89].
  double sun_elevation_deg = 0.0;
  /// [deg] The Sun's azimuth at the landing (ephemeris), measured in the world frame from +y (downrange)
  /// toward +x (crossrange), as the renderer's sequence.yaml: the Sun's direction is (cos e sin a,
  /// cos e cos a, sin e). Negative = not given: the ground under each cell is taken as level. Else in
  /// [0, 360].
  double sun_azimuth_deg = -1.0;
  /// With the azimuth given: where the map's ground is turned away from the Sun (the Sun over it lower than
  /// over level ground), normalise by that lower elevation too (true), or by the Sun over level ground there
  /// (false). False takes, per cell, the larger of the level-ground and the map's-ground readings: on ground
  /// turned toward the Sun the normalisation raises the reading, and away from it the level-ground reading
  /// is kept. Not the default: on held-out seed 14 it certified 1211 cells with 1 next to a true hazard,
  /// against 1681 with 1, and chose 27 sites against 30, 1 unsafe either way (session 26,
  /// docs/terrain/README.md).
  bool normalise_turned_away = true;
  /// [deg] Below this Sun the shading relief is not computed: facets of the slopes it measures turn into
  /// shadow (the linear law above needs the Sun well above them) and the shadow map alone marks the relief.
  /// Where the Sun over the map's ground is lower than this (ground turned away from it), a cell's value is
  /// normalised by this elevation.
  /// 5 deg, the lowest Sun of the campaigns: on the 12 maps of the seed-2 campaign with a Sun of 5-15 deg
  /// the shading flagged 4-31 % of the truly safe cells (10-77 % of the hazardous ones), as many sites were
  /// chosen as without it (43) and 2 of them were unsafe against 4; on two held-out low-Sun campaigns (seeds
  /// 3 and 4, 21 runs) 3 of 61 against 9 of 63 (session 14, docs/terrain/README.md). The cost is precision.
  /// Until then it was 15 deg, set when the three benchmark renders at 12 deg had 29-33 % of their truly
  /// safe cells flagged (17-20 % at 42 deg, session 12).
  double min_sun_elevation_deg = 5.0;
  /// [m] The band of relief measured: Gaussian sigmas on the ground. Of six bands between 0.1 and 2 m,
  /// 0.5-2 m separated best the cells the true terrain calls rough (run_015, Sun 42 deg: ROC AUC 0.956), and
  /// lined up with the Sun on two more renders at 12 and 43 deg (docs/terrain/README.md).
  double band_min_m = 0.5;
  double band_max_m = 2.0;
  /// [m] A view counts for a cell only when one of its pixels covers at most this much ground there, and a
  /// keyframe is kept only when its image centre does.
  double max_pixel_footprint_m = 0.25;
  /// The last N keyframes that qualify are kept (16-bit per pixel of the reduced image).
  int max_keyframes = 30;
};

struct ShadingStats {
  int cells_measured = 0;  ///< cells with a value (views at the resolution under enough of the footprint)
  int cells_above = 0;     ///< ... of which above `above_deg`
};

class ShadingRelief {
 public:
  /// Throws std::invalid_argument on an invalid camera or config.
  ShadingRelief(const PinholeCamera& camera, const ShadingReliefConfig& config = ShadingReliefConfig());

  /// Keeps the relative band energy of a keyframe's image (CV_8UC1 of the camera's size, else
  /// std::invalid_argument) with its pose. ground_elevation_m: the ground's height (world z) under the
  /// camera, for the scale of the band. Returns false (nothing kept) when the Sun is not given, the
  /// optical axis does not point down, or the pixel at the image centre is coarser than
  /// max_pixel_footprint_m.
  bool addKeyframe(const Pose& T_world_cam, const cv::Mat& gray, double ground_elevation_m);
  void clear() { views_.clear(); }
  size_t numKeyframes() const { return views_.size(); }
  /// Enabled, the Sun given and at least min_sun_elevation_deg high.
  bool active() const {
    return config_.enabled && config_.sun_elevation_deg > 0.0 &&
           config_.sun_elevation_deg >= config_.min_sun_elevation_deg;
  }

  /// Per cell of `elevation_m` (CV_32F on `geometry`, NaN = unknown): the RMS slope (deg) of the relief in
  /// the band over the disc of `footprint_diameter_m` around the cell; NaN where the cell's elevation is
  /// unknown or fewer than half of the disc's cells are seen by a view at the resolution. `stats` counts
  /// the cells above `above_deg`. With the Sun's azimuth, normalised by the Sun's elevation over the ground
  /// of `elevation_m` around the cell (localSunElevationDeg()).
  cv::Mat slopeRms(const GridGeometry& geometry, const cv::Mat& elevation_m, double footprint_diameter_m,
                   ShadingStats* stats = nullptr, double above_deg = 0.0) const;

  /// Per cell of `elevation_m`: the Sun's elevation (deg) over the ground there, the plane whose gradient
  /// is the elevation's central difference over +-`radius_m` in x and y (one-sided where one end is
  /// unknown, 0 where both are). NaN where the cell's elevation is unknown; the Sun's elevation everywhere
  /// else when its azimuth is not given.
  cv::Mat localSunElevationDeg(const GridGeometry& geometry, const cv::Mat& elevation_m,
                               double radius_m) const;

  /// The relative band energy of one image whose centre pixel covers `pixel_footprint_m` of ground
  /// (CV_32F, of the reduced size; `scale_out`: full-resolution pixels per reduced pixel): what addKeyframe
  /// keeps.
  cv::Mat bandEnergy(const cv::Mat& gray, double pixel_footprint_m, int* scale_out) const;

 private:
  PinholeCamera camera_;
  ShadingReliefConfig config_;
  std::deque<KeptImage> views_;  ///< values: the relative band energy
};

}  // namespace planetary_vo::terrain
