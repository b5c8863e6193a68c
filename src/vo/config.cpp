/// @file config.cpp
/// Range validation, equality and enum names of VoConfig, all driven by the key table in config_fields.h.

#include "planetary_vo/vo/config.h"

#include <cmath>
#include <sstream>
#include <type_traits>

#include "config_fields.h"

namespace planetary_vo {
namespace {

std::string joinProblems(const std::vector<std::string>& problems) {
  std::string message = "invalid VO configuration (" + std::to_string(problems.size()) + " problem" +
                        (problems.size() == 1 ? "" : "s") + "):";
  for (const std::string& p : problems) message += "\n  " + p;
  return message;
}

/// Collects one message per value outside its [lo, hi] range (NaN and infinities included).
class RangeChecker {
 public:
  explicit RangeChecker(std::vector<std::string>* errors) : errors_(errors) {}
  void beginSection(const char* name) { section_ = name; }
  template <class T, class L>
  void operator()(const char* key, const T& value, L lo, L hi) {
    const double v = static_cast<double>(value);
    if (std::isfinite(v) && v >= static_cast<double>(lo) && v <= static_cast<double>(hi)) return;
    std::ostringstream msg;
    msg << section_ << "." << key << ": " << value << " is out of range [" << lo << ", " << hi << "]";
    errors_->push_back(msg.str());
  }
  void operator()(const char*, const bool&) {}
  template <class E>
  void enumeration(const char*, const E&) {}

 private:
  std::vector<std::string>* errors_;
  std::string section_;
};

/// Flattens a struct into doubles (exact for every int, bool and enum value), so that two configs compare by
/// walking the same table once each.
class Flattener {
 public:
  void beginSection(const char*) {}
  template <class T, class L>
  void operator()(const char*, const T& value, L, L) {
    values.push_back(static_cast<double>(value));
  }
  void operator()(const char*, const bool& value) { values.push_back(value ? 1.0 : 0.0); }
  template <class E>
  void enumeration(const char*, const E& value) {
    values.push_back(static_cast<double>(static_cast<std::underlying_type_t<E>>(value)));
  }
  std::vector<double> values;
};

template <class S, class Walk>
bool equalBy(const S& a, const S& b, Walk walk) {
  Flattener fa, fb;
  walk(a, fa);
  walk(b, fb);
  return fa.values == fb.values;
}

}  // namespace

ConfigError::ConfigError(std::vector<std::string> problems)
    : std::runtime_error(joinProblems(problems)), problems_(std::move(problems)) {}

std::vector<std::string> VoConfig::validationErrors() const {
  std::vector<std::string> errors;
  RangeChecker checker(&errors);
  config_detail::forEachField(*this, checker);

  // Combinations the per-key ranges cannot express.
  if (detector.fast_threshold_fallback > detector.fast_threshold)
    errors.push_back("detector.fast_threshold_fallback: " + std::to_string(detector.fast_threshold_fallback) +
                     " exceeds detector.fast_threshold (" + std::to_string(detector.fast_threshold) +
                     "); the fallback must be the lower threshold");
  if (tracker.window_size_px % 2 == 0)
    errors.push_back("tracker.window_size_px: " + std::to_string(tracker.window_size_px) +
                     " must be odd (the window is centred on the feature)");
  if (tracker.method != TrackingMethod::kKlt && tracker.replenish_strategy != ReplenishStrategy::kEmptyCells)
    errors.push_back(
        "tracker.method: anchor_alignment and auto need tracker.replenish_strategy: empty_cells "
        "(restart_below_min "
        "tracks fresh features from the previous image with LK)");
  if (tracker.anchor_patch_px % 2 == 0)
    errors.push_back("tracker.anchor_patch_px: " + std::to_string(tracker.anchor_patch_px) +
                     " must be odd (the patch is centred on the feature)");
  if (bundle_adjustment.enabled && pipeline.trajectory_mode == TrajectoryMode::kUnitStepConcatenation)
    errors.push_back(
        "bundle_adjustment.enabled: true needs a map, but pipeline.trajectory_mode is "
        "unit_step_concatenation");
  if (bundle_adjustment.window_keyframes > map.window_keyframes)
    errors.push_back(
        "bundle_adjustment.window_keyframes: " + std::to_string(bundle_adjustment.window_keyframes) +
        " exceeds map.window_keyframes (" + std::to_string(map.window_keyframes) +
        "); BA can only adjust keyframes of the local map");
  if (pipeline.exposure_step_ratio != 0.0 && pipeline.exposure_step_ratio <= 1.0)
    errors.push_back("pipeline.exposure_step_ratio: " + std::to_string(pipeline.exposure_step_ratio) +
                     " must be above 1 (a brightness factor), or 0 to switch the compensation off");
  if (altimeter.noise.min_range_m >= altimeter.noise.max_range_m)
    errors.push_back("altimeter.min_range_m: " + std::to_string(altimeter.noise.min_range_m) +
                     " must be below altimeter.max_range_m (" + std::to_string(altimeter.noise.max_range_m) +
                     ")");
  if (std::abs(altimeter.mounting.boresight_body.norm() - 1.0) > 1e-3)
    errors.push_back("altimeter.boresight_x/y/z: (" + std::to_string(altimeter.mounting.boresight_body.x()) +
                     ", " + std::to_string(altimeter.mounting.boresight_body.y()) + ", " +
                     std::to_string(altimeter.mounting.boresight_body.z()) + ") must be a unit vector");
  return errors;
}

void VoConfig::validate() const {
  std::vector<std::string> errors = validationErrors();
  if (!errors.empty()) throw ConfigError(std::move(errors));
}

#define PLANETARY_VO_CONFIG_EQ(Type, walker)                                                \
  bool operator==(const Type& a, const Type& b) {                                           \
    return equalBy(a, b, [](const Type& c, Flattener& f) { config_detail::walker(c, f); }); \
  }
PLANETARY_VO_CONFIG_EQ(DetectorConfig, detectorFields)
PLANETARY_VO_CONFIG_EQ(TrackerConfig, trackerFields)
PLANETARY_VO_CONFIG_EQ(MotionConfig, motionFields)
PLANETARY_VO_CONFIG_EQ(KeyframeConfig, keyframeFields)
PLANETARY_VO_CONFIG_EQ(MapConfig, mapFields)
PLANETARY_VO_CONFIG_EQ(PnpConfig, pnpFields)
PLANETARY_VO_CONFIG_EQ(MotionFilterConfig, motionFilterFields)
PLANETARY_VO_CONFIG_EQ(BundleAdjustmentConfig, bundleAdjustmentFields)
PLANETARY_VO_CONFIG_EQ(PipelineConfig, pipelineFields)
PLANETARY_VO_CONFIG_EQ(AltimeterAidingConfig, altimeterFields)
PLANETARY_VO_CONFIG_EQ(ImuAidingConfig, imuFields)
PLANETARY_VO_CONFIG_EQ(CpuBudgetConfig, cpuBudgetFields)
PLANETARY_VO_CONFIG_EQ(VoConfig, forEachField)
#undef PLANETARY_VO_CONFIG_EQ

namespace {
/// Finds one key's range while walking the table.
struct RangeFinder {
  std::string section, key, current;
  bool found = false;
  double lo = 0.0, hi = 0.0;
  void beginSection(const char* name) { current = name; }
  template <class T, class L>
  void operator()(const char* k, const T&, L l, L h) {
    if (current != section || key != k) return;
    found = true;
    lo = static_cast<double>(l);
    hi = static_cast<double>(h);
  }
  void operator()(const char*, const bool&) {}
  template <class E>
  void enumeration(const char*, const E&) {}
};
}  // namespace

bool configRange(const std::string& section, const std::string& key, double* lo, double* hi) {
  RangeFinder finder;
  finder.section = section;
  finder.key = key;
  const VoConfig defaults;
  config_detail::forEachField(defaults, finder);
  if (!finder.found) return false;
  *lo = finder.lo;
  *hi = finder.hi;
  return true;
}

const char* toString(MotionModel v) { return config_detail::enumName(v); }
const char* toString(PlaneNormalPrior v) { return config_detail::enumName(v); }

Eigen::Vector3d planeNormalPriorVector(PlaneNormalPrior prior) {
  switch (prior) {
    case PlaneNormalPrior::kOpticalAxis:
      return Eigen::Vector3d::UnitZ();
    case PlaneNormalPrior::kImageDown:
      return Eigen::Vector3d::UnitY();
    case PlaneNormalPrior::kNone:
      break;
  }
  return Eigen::Vector3d::Zero();
}
const char* toString(KeyframeMode v) { return config_detail::enumName(v); }
const char* toString(RobustLoss v) { return config_detail::enumName(v); }
const char* toString(TrajectoryMode v) { return config_detail::enumName(v); }
const char* toString(ReplenishStrategy v) { return config_detail::enumName(v); }
const char* toString(TrackingMethod v) { return config_detail::enumName(v); }

}  // namespace planetary_vo
