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
};

/// Cell values of hazardMask().
enum HazardCell : uint8_t { kSafe = 0, kHazard = 1, kUnknown = 255 };

/// CV_8U of the size of the layers (CV_32F, NaN = unknown): kSafe, kHazard or kUnknown per cell. Throws
/// std::invalid_argument on layers of different sizes or types.
cv::Mat hazardMask(const cv::Mat& slope_deg, const cv::Mat& roughness_m, const HazardThresholds& thresholds);

}  // namespace planetary_vo::terrain
