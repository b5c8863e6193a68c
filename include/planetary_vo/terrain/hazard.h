#pragma once
/// @file hazard.h
/// Hazards of a landing area: a cell is hazardous when the slope of the plane the lander would settle on
/// exceeds max_slope_deg or the roughness under its footprint exceeds max_roughness_m
/// (terrain/surface_analysis.h); unknown where either is unknown. The thresholds of issue 11 (10 deg,
/// 0.3 m) are the defaults, in this one place.

#include <cstdint>

#include <opencv2/core.hpp>

namespace planetary_vo::terrain {

struct HazardThresholds {
  double max_slope_deg = 10.0;
  double max_roughness_m = 0.3;
  /// A cell seen dark in more than this fraction of the views that resolve it (terrain/shadow_map.h) is
  /// unknown, whatever its slope and roughness: its relief is unseen (a cast shadow marks a rock, a rim or a
  /// slope turned from the Sun, smaller than the map's plane fit may resolve), so it is never certified safe.
  /// Used only where a shadow layer is given; 1 = shadows are ignored.
  double max_shadow_fraction = 0.5;
  /// A cell whose shading relief (terrain/shading_relief.h: the RMS slope of the relief between 0.5 and 2 m
  /// under the footprint, from the keyframes' shading) exceeds this is a hazard: craters of a metre or two
  /// and rocks that the plane fit smooths away. Used only where a shading layer is given.
  double max_shading_slope_deg = 3.0;
};

/// Cell values of hazardMask().
enum HazardCell : uint8_t { kSafe = 0, kHazard = 1, kUnknown = 255 };

/// CV_8U of the size of the layers (CV_32F, NaN = unknown): kSafe, kHazard or kUnknown per cell. Throws
/// std::invalid_argument on layers of different sizes or types.
cv::Mat hazardMask(const cv::Mat& slope_deg, const cv::Mat& roughness_m, const HazardThresholds& thresholds);
/// The same with the layers from the keyframe images (CV_32F of the same size, NaN = not measured; an
/// empty Mat = no such layer): a cell whose `shadow_fraction` exceeds thresholds.max_shadow_fraction is
/// unknown (its relief unseen), whatever its other layers say; otherwise a known cell whose
/// `shading_slope_deg` exceeds thresholds.max_shading_slope_deg is a hazard.
cv::Mat hazardMask(const cv::Mat& slope_deg, const cv::Mat& roughness_m, const cv::Mat& shadow_fraction,
                   const cv::Mat& shading_slope_deg, const HazardThresholds& thresholds);

}  // namespace planetary_vo::terrain
