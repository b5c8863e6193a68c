#include "planetary_vo/terrain/hazard_mapper.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <variant>

#include <yaml-cpp/yaml.h>

namespace planetary_vo::terrain {
namespace {

std::string joined(const std::vector<std::string>& problems) {
  std::string s = "hazard configuration:";
  for (const std::string& p : problems) s += "\n  " + p;
  return s;
}

using FieldPtr = std::variant<double*, int*, bool*>;
using Fields = std::vector<std::pair<const char*, FieldPtr>>;

/// The YAML keys of each section, pointing into one config: the single list of names.
std::vector<std::pair<const char*, Fields>> sectionsOf(HazardMapperConfig* c) {
  return {
      {"area",
       {{"half_extent_m", &c->area.half_extent_m},
        {"cell_size_m", &c->area.cell_size_m},
        {"footprint_diameter_m", &c->area.footprint_diameter_m}}},
      {"map",
       {{"max_point_sigma_z_m", &c->map.max_point_sigma_z_m},
        {"point_sigma_floor_m", &c->map.point_sigma_floor_m},
        {"support_radius_m", &c->map.support_radius_m},
        {"min_points_per_fit", &c->map.min_points_per_fit},
        {"max_support_offset", &c->map.max_support_offset}}},
      {"densifier",
       {{"enabled", &c->densify},
        {"area_margin_m", &c->densifier.area_margin_m},
        {"grid_step_px", &c->densifier.grid_step_px},
        {"max_corners", &c->densifier.max_corners},
        {"min_corner_quality", &c->densifier.min_corner_quality},
        {"max_keyframe_gap", &c->densifier.max_keyframe_gap},
        {"target_parallax_deg", &c->densifier.target_parallax_deg},
        {"partners_per_keyframe", &c->densifier.partners_per_keyframe},
        {"warp_partner", &c->densifier.warp_partner},
        {"min_seeds", &c->densifier.min_seeds},
        {"min_parallax_deg", &c->densifier.min_parallax_deg},
        {"max_forward_backward_px", &c->densifier.max_forward_backward_px},
        {"pixel_sigma_px", &c->densifier.pixel_sigma_px},
        {"klt_window_px", &c->densifier.klt_window_px},
        {"klt_levels", &c->densifier.klt_levels},
        {"max_window_footprint_m", &c->densifier.max_window_footprint_m}}},
      {"shadows",
       {{"enabled", &c->shadows.enabled},
        {"dark_fraction_of_bright", &c->shadows.dark_fraction_of_bright},
        {"max_pixel_footprint_m", &c->shadows.max_pixel_footprint_m},
        {"max_keyframes", &c->shadows.max_keyframes}}},
      {"shading",
       {{"enabled", &c->shading.enabled},
        {"sun_elevation_deg", &c->shading.sun_elevation_deg},
        {"sun_azimuth_deg", &c->shading.sun_azimuth_deg},
        {"normalise_turned_away", &c->shading.normalise_turned_away},
        {"min_sun_elevation_deg", &c->shading.min_sun_elevation_deg},
        {"band_min_m", &c->shading.band_min_m},
        {"band_max_m", &c->shading.band_max_m},
        {"max_pixel_footprint_m", &c->shading.max_pixel_footprint_m},
        {"max_keyframes", &c->shading.max_keyframes}}},
      {"shading_tilt",
       {{"weight", &c->shading_tilt.weight},
        {"footprint_sigma_m", &c->shading_tilt.footprint_sigma_m},
        {"surround_sigma_m", &c->shading_tilt.surround_sigma_m},
        {"max_pixel_footprint_m", &c->shading_tilt.max_pixel_footprint_m},
        {"min_brightness", &c->shading_tilt.min_brightness},
        {"max_keyframes", &c->shading_tilt.max_keyframes}}},
      {"thresholds",
       {{"max_slope_deg", &c->thresholds.max_slope_deg},
        {"max_roughness_m", &c->thresholds.max_roughness_m},
        {"max_shadow_fraction", &c->thresholds.max_shadow_fraction},
        {"max_shading_slope_deg", &c->thresholds.max_shading_slope_deg},
        {"shading_margin_m", &c->thresholds.shading_margin_m},
        {"shading_slope_weight", &c->thresholds.shading_slope_weight}}},
      {"sites",
       {{"target_x_m", &c->sites.target_x_m},
        {"target_y_m", &c->sites.target_y_m},
        {"max_distance_from_target_m", &c->sites.max_distance_from_target_m},
        {"max_sites", &c->sites.max_sites},
        {"min_separation_m", &c->sites.min_separation_m},
        {"confidence_k", &c->sites.confidence_k},
        {"min_clearance_m", &c->sites.min_clearance_m},
        {"distance_weight", &c->sites.distance_weight}}},
  };
}

/// Reads one scalar into the field; false (with `why`) on a wrong type or a non-finite number.
bool readField(const YAML::Node& node, const FieldPtr& field, std::string* why) {
  if (!node.IsScalar()) {
    *why = "expected a scalar";
    return false;
  }
  try {
    if (auto* d = std::get_if<double*>(&field)) {
      const double v = node.as<double>();
      if (!std::isfinite(v)) {
        *why = "not a finite number";
        return false;
      }
      **d = v;
    } else if (auto* i = std::get_if<int*>(&field)) {
      **i = node.as<int>();
    } else {
      **std::get_if<bool*>(&field) = node.as<bool>();
    }
  } catch (const YAML::Exception&) {
    *why = std::holds_alternative<double*>(field) ? "expected a number"
           : std::holds_alternative<int*>(field)  ? "expected an integer"
                                                  : "expected true or false";
    return false;
  }
  return true;
}

/// The landing area is given once (`area`) and copied into the stages that use it.
HazardMapperConfig withArea(HazardMapperConfig c) {
  c.map.area = c.area;
  c.densifier.area = c.area;
  return c;
}

/// Range checks by the stages themselves (their constructors and the site search on a tiny grid), so that
/// the limits live in one place each.
std::vector<std::string> validationErrors(const HazardMapperConfig& c) {
  std::vector<std::string> problems;
  const HazardMapperConfig effective = withArea(c);
  try {
    (void)c.area.geometry();
  } catch (const std::invalid_argument& e) {
    problems.push_back(std::string("area: ") + e.what());
    return problems;
  }
  try {
    TerrainMap check(effective.map);
  } catch (const std::invalid_argument& e) {
    problems.push_back(std::string("map/area: ") + e.what());
  }
  try {
    Densifier check(PinholeCamera(64, 64, 50.0, 50.0, 32.0, 32.0), effective.densifier);
  } catch (const std::invalid_argument& e) {
    problems.push_back(std::string("densifier: ") + e.what());
  }
  try {
    ShadowMap check(PinholeCamera(64, 64, 50.0, 50.0, 32.0, 32.0), effective.shadows);
  } catch (const std::invalid_argument& e) {
    problems.push_back(std::string("shadows: ") + e.what());
  }
  try {
    ShadingRelief check(PinholeCamera(64, 64, 50.0, 50.0, 32.0, 32.0), effective.shading);
  } catch (const std::invalid_argument& e) {
    problems.push_back(std::string("shading: ") + e.what());
  }
  try {
    ShadingTilt check(PinholeCamera(64, 64, 50.0, 50.0, 32.0, 32.0), effective.shading_tilt,
                      effective.shading.sun_elevation_deg, effective.shading.sun_azimuth_deg,
                      effective.shading.min_sun_elevation_deg);
  } catch (const std::invalid_argument& e) {
    problems.push_back(std::string("shading_tilt: ") + e.what());
  }
  try {
    GridSet tiny;
    tiny.geometry = GridGeometry::centeredOnOrigin(1.0, 1.0);
    tiny.layers["slope_deg"] = tiny.geometry.newLayer(0.0f);
    tiny.layers["roughness_m"] = tiny.geometry.newLayer(0.0f);
    (void)findLandingSites(tiny, c.thresholds, c.sites);
  } catch (const std::invalid_argument& e) {
    problems.push_back(std::string("thresholds/sites: ") + e.what());
  }
  return problems;
}

}  // namespace

HazardConfigError::HazardConfigError(std::vector<std::string> problems)
    : std::runtime_error(joined(problems)), problems_(std::move(problems)) {}

HazardMapperConfig parseHazardMapperConfig(const std::string& yaml_text) {
  HazardMapperConfig config;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw HazardConfigError({std::string("YAML syntax: ") + e.what()});
  }
  std::vector<std::string> problems;
  if (root && !root.IsNull()) {
    if (!root.IsMap()) throw HazardConfigError({"the document must be a map of sections"});
    auto sections = sectionsOf(&config);
    std::set<std::string> seen_sections;
    for (const auto& entry : root) {
      const std::string section = entry.first.IsScalar() ? entry.first.as<std::string>() : "<non-scalar>";
      if (!seen_sections.insert(section).second) {
        problems.push_back(section + ": duplicate section");
        continue;
      }
      auto s = std::find_if(sections.begin(), sections.end(),
                            [&](const auto& known) { return section == known.first; });
      if (s == sections.end()) {
        std::string known;
        for (const auto& k : sections) known += std::string(known.empty() ? "" : ", ") + k.first;
        problems.push_back(section + ": unknown section (known: " + known + ")");
        continue;
      }
      if (!entry.second.IsMap()) {
        if (!entry.second.IsNull()) problems.push_back(section + ": expected a map of keys");
        continue;
      }
      std::set<std::string> seen_keys;
      for (const auto& kv : entry.second) {
        const std::string key = kv.first.IsScalar() ? kv.first.as<std::string>() : "<non-scalar>";
        if (!seen_keys.insert(key).second) {
          problems.push_back(section + "." + key + ": duplicate key");
          continue;
        }
        auto f = std::find_if(s->second.begin(), s->second.end(),
                              [&](const auto& known) { return key == known.first; });
        if (f == s->second.end()) {
          problems.push_back(section + "." + key + ": unknown key");
          continue;
        }
        std::string why;
        if (!readField(kv.second, f->second, &why)) problems.push_back(section + "." + key + ": " + why);
      }
    }
  }
  if (problems.empty()) problems = validationErrors(config);
  if (!problems.empty()) throw HazardConfigError(problems);
  return withArea(config);
}

std::string dumpHazardMapperConfig(const HazardMapperConfig& config) {
  HazardMapperConfig copy = config;
  std::ostringstream os;
  os << std::setprecision(17);
  for (const auto& [section, fields] : sectionsOf(&copy)) {
    os << section << ":\n";
    for (const auto& [key, field] : fields) {
      os << "  " << key << ": ";
      if (auto* d = std::get_if<double*>(&field))
        os << **d;
      else if (auto* i = std::get_if<int*>(&field))
        os << **i;
      else
        os << (**std::get_if<bool*>(&field) ? "true" : "false");
      os << "\n";
    }
  }
  return os.str();
}

std::vector<std::string> hazardMapperConfigSections() {
  HazardMapperConfig config;
  std::vector<std::string> names;
  for (const auto& section : sectionsOf(&config)) names.emplace_back(section.first);
  return names;
}

HazardMapperConfig loadHazardMapperConfig(const std::string& yaml_path) {
  std::error_code ec;
  if (std::filesystem::is_directory(yaml_path, ec))
    throw HazardConfigError({yaml_path + ": is a folder, not a YAML file"});
  std::ifstream in(yaml_path);
  if (!in) throw HazardConfigError({yaml_path + ": cannot be read"});
  std::stringstream text;
  text << in.rdbuf();
  try {
    return parseHazardMapperConfig(text.str());
  } catch (const HazardConfigError& e) {
    std::vector<std::string> problems;
    for (const std::string& p : e.problems()) problems.push_back(yaml_path + ": " + p);
    throw HazardConfigError(problems);
  }
}

HazardMapper::HazardMapper(const HazardMapperConfig& config) : config_(withArea(config)), map_(config_.map) {
  const std::vector<std::string> problems = validationErrors(config_);
  if (!problems.empty()) throw std::invalid_argument(joined(problems));
}

void HazardMapper::setCamera(const PinholeCamera& camera) {
  auto densifier = std::make_unique<Densifier>(camera, config_.densifier);  // validates the camera
  auto shadows = std::make_unique<ShadowMap>(camera, config_.shadows);
  auto shading = std::make_unique<ShadingRelief>(camera, config_.shading);
  auto tilt =
      std::make_unique<ShadingTilt>(camera, config_.shading_tilt, config_.shading.sun_elevation_deg,
                                    config_.shading.sun_azimuth_deg, config_.shading.min_sun_elevation_deg);
  camera_ = std::make_unique<PinholeCamera>(camera);
  tilt_ = std::move(tilt);
  densifier_ = std::move(densifier);
  shadows_ = std::move(shadows);
  shading_ = std::move(shading);
}

HazardMapperUpdate HazardMapper::apply(const MapEvents& events, bool metric_scale,
                                       const cv::Mat& keyframe_gray) {
  HazardMapperUpdate update;
  update.keyframe = !events.keyframes_added.empty();
  if ((events.map_restarted || metric_scale != metric_) && camera_) {
    densifier_ = std::make_unique<Densifier>(*camera_, config_.densifier);
    shadows_->clear();
    shading_->clear();
    tilt_->clear();
  }
  metric_ = metric_scale;
  map_.apply(events, metric_scale);
  if (!update.keyframe || !metric_scale || !camera_ || keyframe_gray.empty()) return update;
  if (keyframe_gray.type() != CV_8UC1 || keyframe_gray.cols != camera_->width() ||
      keyframe_gray.rows != camera_->height())
    throw std::invalid_argument(
        "HazardMapper::apply: the keyframe image is not 8-bit gray of the camera's size (" +
        std::to_string(keyframe_gray.cols) + "x" + std::to_string(keyframe_gray.rows) + ", camera " +
        std::to_string(camera_->width()) + "x" + std::to_string(camera_->height()) + ")");
  const MapKeyframeState& kf = events.keyframes_added.back();
  if (config_.shadows.enabled) {
    shadows_->addKeyframe(kf.T_world_cam, keyframe_gray);
    update.shadow_view_added = true;
  }
  const double ground_z = map_.medianGroundHeight();
  update.shading_view_added =  // false unless the Sun is given and high enough (ShadingRelief::active)
      shading_->addKeyframe(kf.T_world_cam, keyframe_gray, std::isfinite(ground_z) ? ground_z : 0.0);
  update.tilt_view_added =  // false unless shading_tilt.weight > 0 and the Sun is given (ShadingTilt::active)
      tilt_->addKeyframe(kf.T_world_cam, keyframe_gray, std::isfinite(ground_z) ? ground_z : 0.0);
  if (!config_.densify) return update;
  MapEvents dense;
  dense.points_added = densifier_->addKeyframe(kf.timestamp_s, kf.T_world_cam, keyframe_gray,
                                               std::isfinite(ground_z) ? ground_z : 0.0, &update.densifier);
  map_.apply(dense, metric_scale);
  update.densified = true;
  return update;
}

void HazardMapper::reset() {
  map_.clear();
  metric_ = false;
  if (camera_) densifier_ = std::make_unique<Densifier>(*camera_, config_.densifier);
  if (shadows_) shadows_->clear();
  if (shading_) shading_->clear();
  if (tilt_) tilt_->clear();
}

HazardProducts HazardMapper::products() const {
  HazardProducts out;
  out.terrain = map_.products();
  if (tilt_ && tilt_->active() && out.terrain.metric) {
    // The plane fit's slope corrected along the Sun's azimuth by the keyframes' brightness (shading_tilt.h).
    GridSet& g = out.terrain.grids;
    cv::Mat delta;
    g.layers["slope_deg"] =
        tilt_->correctedSlope(g.geometry, g.layers.at("elevation_m"), g.layers.at("slope_deg"), &delta);
    g.layers["shading_tilt_delta_deg"] = delta;
    g.parameters["shading_tilt_weight"] = config_.shading_tilt.weight;
  }
  if (shadows_ && config_.shadows.enabled && out.terrain.metric) {
    out.terrain.grids.layers["shadow_fraction"] =
        shadows_->shadowFraction(out.terrain.grids.geometry, out.terrain.grids.layers.at("elevation_m"),
                                 &out.shadows, nullptr, config_.thresholds.max_shadow_fraction);
    out.terrain.grids.parameters["max_shadow_fraction"] = config_.thresholds.max_shadow_fraction;
  }
  if (shading_ && shading_->active() && out.terrain.metric) {
    out.terrain.grids.layers["shading_slope_deg"] = shading_->slopeRms(
        out.terrain.grids.geometry, out.terrain.grids.layers.at("elevation_m"),
        config_.area.footprint_diameter_m, &out.shading, config_.thresholds.max_shading_slope_deg);
    out.terrain.grids.parameters["max_shading_slope_deg"] = config_.thresholds.max_shading_slope_deg;
    out.terrain.grids.parameters["shading_margin_m"] = config_.thresholds.shading_margin_m;
    out.terrain.grids.parameters["shading_slope_weight"] = config_.thresholds.shading_slope_weight;
    out.terrain.grids.parameters["sun_elevation_deg"] = config_.shading.sun_elevation_deg;
    out.terrain.grids.parameters["sun_azimuth_deg"] = config_.shading.sun_azimuth_deg;
    out.terrain.grids.parameters["shading_normalise_turned_away"] = config_.shading.normalise_turned_away;
  }
  const GridSet& g = out.terrain.grids;
  const auto shadow = g.layers.find("shadow_fraction");
  const auto shading = g.layers.find("shading_slope_deg");
  out.hazard = hazardMask(g.layers.at("slope_deg"), g.layers.at("roughness_m"),
                          shadow == g.layers.end() ? cv::Mat() : shadow->second,
                          shading == g.layers.end() ? cv::Mat() : shading->second,
                          shadingWithinMargin(g, config_.thresholds), config_.thresholds);
  cv::Mat hazard_f(out.hazard.size(), CV_32F);
  for (int r = 0; r < out.hazard.rows; ++r)
    for (int c = 0; c < out.hazard.cols; ++c) {
      const uint8_t v = out.hazard.at<uint8_t>(r, c);
      hazard_f.at<float>(r, c) = v == kUnknown ? std::numeric_limits<float>::quiet_NaN() : float(v);
    }
  out.terrain.grids.layers["hazard"] = hazard_f;
  out.terrain.grids.parameters["max_slope_deg"] = config_.thresholds.max_slope_deg;
  out.terrain.grids.parameters["max_roughness_m"] = config_.thresholds.max_roughness_m;
  if (out.terrain.metric) {
    out.sites = findLandingSites(out.terrain.grids, config_.thresholds, config_.sites);
  } else {
    out.sites.reason =
        "the map is not metric (vision only): no landing site is chosen on a map without metres";
  }
  return out;
}

}  // namespace planetary_vo::terrain
