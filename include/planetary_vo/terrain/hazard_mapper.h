#pragma once
/// @file hazard_mapper.h
/// Hazard detection over the navigation's map (issue 11, thesis Phase 4): the one object both the offline
/// runner (`vo_run --output-terrain`) and the ROS hazard nodelet drive. Its inputs are explicit: the VO's map
/// events of each frame (vo/map_events.h) with the frame's metric flag and, at keyframes, the keyframe's
/// 8-bit image; the camera model once known. It feeds the persistent terrain model (terrain_map.h) and, once
/// the navigation is metric, densifies the landing area at each keyframe (densifier.h). On request it gives
/// the products hazard detection and avoidance hands on: the rasters, the hazard mask (hazard.h) and the
/// ranked safe landing sites near the target (landing_sites.h).
///
/// Densification needs metric poses (its parallax, plane prediction and support radii are in metres) and
/// a gravity-aligned world (the fused modes with a handed-over initial state, or the visual-inertial
/// alignment): without them the sparse map is used alone and products().metric says the map is not metric.
///
/// Configuration: HazardMapperConfig, a plain struct whose sections are the structs of the stages; the
/// landing area is given once (`area`) and copied into the terrain model and the densifier. YAML keys:
/// config/hazard.yaml, which is the default (a test checks it parses to a default-constructed config).

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/terrain/densifier.h"
#include "planetary_vo/terrain/hazard.h"
#include "planetary_vo/terrain/landing_area.h"
#include "planetary_vo/terrain/landing_sites.h"
#include "planetary_vo/terrain/shading_relief.h"
#include "planetary_vo/terrain/shading_tilt.h"
#include "planetary_vo/terrain/shadow_map.h"
#include "planetary_vo/terrain/terrain_map.h"
#include "planetary_vo/vo/map_events.h"

namespace planetary_vo::terrain {

struct HazardMapperConfig {
  LandingAreaParams area;  ///< the grid and the footprint (overrides map.area and densifier.area)
  TerrainMapConfig map;
  bool densify = true;  ///< densify the landing area at keyframes once metric
  DensifierConfig densifier;
  /// The shadows of the keyframes once metric (shadow_map.h): a cell seen in shadow is unknown in the
  /// hazard mask, never a site (thresholds.max_shadow_fraction).
  ShadowMapConfig shadows;
  /// The relief under the plane fit from the keyframes' shading once metric (shading_relief.h): a cell whose
  /// RMS slope between 0.5 and 2 m exceeds thresholds.max_shading_slope_deg is a hazard. Needs the Sun's
  /// elevation (shading.sun_elevation_deg; 0 = not given, then off).
  ShadingReliefConfig shading;
  /// The plane fit's slope corrected along the Sun's azimuth by the keyframes' brightness once metric
  /// (shading_tilt.h; the Sun from `shading`): the layer slope_deg then carries the correction and
  /// shading_tilt_delta_deg the change. Off with weight 0.
  ShadingTiltConfig shading_tilt;
  HazardThresholds thresholds;
  LandingSiteParams sites;
};

/// Thrown by parseHazardMapperConfig / loadHazardMapperConfig: one entry per bad or unknown key
/// (`section.key: what is wrong`).
class HazardConfigError : public std::runtime_error {
 public:
  explicit HazardConfigError(std::vector<std::string> problems);
  const std::vector<std::string>& problems() const { return problems_; }

 private:
  std::vector<std::string> problems_;
};

/// YAML text (sections area, map, densify, densifier, thresholds, sites; absent keys keep their defaults) ->
/// a validated config. Throws HazardConfigError naming every unknown section or key, wrong type and
/// out-of-range value, and YAML syntax errors.
HazardMapperConfig parseHazardMapperConfig(const std::string& yaml_text);
/// As parseHazardMapperConfig, from a file (the path prefixed to the errors).
HazardMapperConfig loadHazardMapperConfig(const std::string& yaml_path);
/// Every key with its value, as YAML that parseHazardMapperConfig reads back to the same config.
std::string dumpHazardMapperConfig(const HazardMapperConfig& config);
/// The YAML sections parseHazardMapperConfig knows, in order (area, map, densifier, ...).
std::vector<std::string> hazardMapperConfigSections();

/// What one apply() did.
struct HazardMapperUpdate {
  bool keyframe = false;            ///< the events added a keyframe
  bool densified = false;           ///< ... and the densifier ran on it
  DensifierStats densifier;         ///< its counts when it ran
  bool shadow_view_added = false;   ///< the keyframe's shadows were kept (metric, shadows enabled)
  bool shading_view_added = false;  ///< the keyframe's shading was kept (metric, Sun given, fine enough)
  bool tilt_view_added = false;     ///< ... and its relative brightness (shading_tilt on)
};

struct HazardProducts {
  /// Layers elevation_m, elevation_sigma_m, support_points, slope_deg, roughness_m (terrain_map.h) and
  /// hazard (0 safe, 1 hazard, NaN unknown: hazardMask as float, so that it is written with the rest);
  /// once metric with shadows enabled, shadow_fraction (shadow_map.h), which the hazard mask and the sites
  /// take into account.
  TerrainProducts terrain;
  ShadowStats shadows;  ///< cells seen at the resolution, and in shadow
  /// Cells whose shading relief was measured, and above thresholds.max_shading_slope_deg (layer
  /// shading_slope_deg when the Sun is given; the hazard mask and the sites take it into account).
  ShadingStats shading;
  cv::Mat hazard;  ///< CV_8U hazardMask() of the layers (kSafe, kHazard, kUnknown)
  /// Sites near config.sites' target, best first. Searched only on a metric map (distances, clearance and
  /// roughness in metres); otherwise empty with the reason.
  LandingSiteResult sites;
};

class HazardMapper {
 public:
  /// Throws std::invalid_argument when a stage rejects its config.
  explicit HazardMapper(const HazardMapperConfig& config = HazardMapperConfig());

  /// The camera the keyframe images come from (needed by the densifier; it may change, e.g. a new
  /// camera_info). Throws std::invalid_argument on an invalid camera.
  void setCamera(const PinholeCamera& camera);
  bool hasCamera() const { return densifier_ != nullptr; }

  /// One frame's events. keyframe_gray: the 8-bit image of the last keyframe the events add (CV_8UC1, as the
  /// VO was given it), or empty. A map restart keeps the terrain model (its retired points are estimates of
  /// the same ground) but starts the densifier's keyframe history again, as does a change of the metric
  /// flag (the older keyframes' poses are in the other unit). Throws std::invalid_argument on a keyframe
  /// image that is not CV_8UC1 of the camera's size.
  HazardMapperUpdate apply(const MapEvents& events, bool metric_scale,
                           const cv::Mat& keyframe_gray = cv::Mat());

  /// Everything back to the state after construction (the camera is kept).
  void reset();

  /// The products now (cost: the terrain model's rasterisation, the shadows of the known cells and the site
  /// search; vo_run prints it: docs/agnc.md gives a measurement).
  HazardProducts products() const;

  const HazardMapperConfig& config() const { return config_; }
  size_t numPoints() const { return map_.numPoints(); }
  bool metric() const { return metric_; }

 private:
  HazardMapperConfig config_;
  TerrainMap map_;
  std::unique_ptr<PinholeCamera> camera_;
  std::unique_ptr<Densifier> densifier_;
  std::unique_ptr<ShadowMap> shadows_;
  std::unique_ptr<ShadingRelief> shading_;
  std::unique_ptr<ShadingTilt> tilt_;
  bool metric_ = false;
};

}  // namespace planetary_vo::terrain
