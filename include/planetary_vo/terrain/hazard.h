#pragma once
/// @file hazard.h
/// Hazards of a landing area: a cell is hazardous when the slope of the plane the lander would settle on
/// exceeds max_slope_deg or the roughness under its footprint exceeds max_roughness_m
/// (terrain/surface_analysis.h); unknown where either is unknown. The thresholds of issue 11 (10 deg,
/// 0.3 m) are the defaults, in this one place.

#include <cstdint>

#include <opencv2/core.hpp>

#include "planetary_vo/terrain/grid.h"

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
  /// and rocks that the plane fit smooths away. Used only where a shading layer is given. 2.7 since session
  /// 25 (3 before): the reading normalised by the Sun over the map's own ground is about a tenth lower at a
  /// high Sun (median ratio to the true relief 0.81 -> 0.73 on seeds 5-10), and 3 x 0.73 / 0.81 keeps the
  /// relief the threshold stands for there. Adopted on a criterion fixed before held-out seed 13 (Sun 15-45
  /// deg, 16 runs) finished: certified cells next to a true hazard 1.20 % -> 0.86 %, the same 35 sites chosen,
  /// 1 unsafe either way (docs/terrain/README.md).
  double max_shading_slope_deg = 2.7;
  /// ... and so is every cell within this distance (m, centre to centre) of such a cell: the shading relief
  /// is an RMS over the footprint, which dilutes a rock or a pit at the footprint's edge, while the footprint
  /// of every cell within its radius of that relief has it underneath (the truth's roughness is the largest
  /// relief over the footprint). The footprint's radius (2 m). 0 = the cell's own shading alone (before
  /// session 24). Measured on four campaigns' maps (seeds 5-8, session 24): of the cells the site search
  /// would certify at a Sun of 15 deg or more, those with a truly hazardous cell within 3 m fell from 2.0 %
  /// to 0.26 %, keeping 54 % of them; held out (seed 9, 16 runs at 15-45 deg), from 2.3 % to none, keeping
  /// 48 %. At a lower Sun less on seeds 5-8 (8.7 % -> 7.6 %); held out (seed 10, 16 runs at 5-15 deg) 2.2 % ->
  /// 0.6 %, keeping 65 %. Chosen sites over seeds 5-8: 6 of 173 unsafe against 14 of 195
  /// (docs/terrain/README.md).
  double shading_margin_m = 2.0;
  /// The slope compared with max_slope_deg is the plane's slope plus this times the shading relief, where a
  /// shading layer is given: relief under the plane fit tilts the footprint by about its own RMS slope, which
  /// the plane fit flattens (a crater wall narrower than the 4 m support). 0 = the plane's slope alone.
  /// 0.5, chosen on a 12-run development campaign (seed 5): of the map cells that would qualify as sites, the
  /// share with a true slope above 10 deg within 3 m fell from 1.6 % to 0.4 % (1: 0.2 %), keeping 56 % of
  /// them (1: 22 %); both unsafe sites on slopes that were chosen (7 of 43 trials) were no longer chosen, 31
  /// sites chosen, none unsafe. Held out (seed 6, 24 runs): 3 of 81 chosen sites unsafe against 6 of 90 at 0;
  /// seed 7 (20 runs): 10 of 40 against 9 of 60, its unsafe sites rocks at a low Sun
  /// (docs/terrain/README.md, session 23).
  double shading_slope_weight = 0.5;
};

/// The shading layer hazardMask() compares with max_shading_slope_deg for a grid set: per cell, the largest
/// finite `shading_slope_deg` of the cells within thresholds.shading_margin_m of it (itself included), NaN
/// where there is none. An empty Mat when the grid set has no `shading_slope_deg` layer. Throws
/// std::invalid_argument on a layer that is not CV_32F of the grid's size, a non-positive cell size, or a
/// negative or non-finite margin.
cv::Mat shadingWithinMargin(const GridSet& grids, const HazardThresholds& thresholds);

/// Cell values of hazardMask().
enum HazardCell : uint8_t { kSafe = 0, kHazard = 1, kUnknown = 255 };

/// CV_8U of the size of the layers (CV_32F, NaN = unknown): kSafe, kHazard or kUnknown per cell. Throws
/// std::invalid_argument on layers of different sizes or types.
cv::Mat hazardMask(const cv::Mat& slope_deg, const cv::Mat& roughness_m, const HazardThresholds& thresholds);
/// The same with the layers from the keyframe images (CV_32F of the same size, NaN = not measured; an
/// empty Mat = no such layer): a cell whose `shadow_fraction` exceeds thresholds.max_shadow_fraction is
/// unknown (its relief unseen), whatever its other layers say; otherwise a known cell whose
/// `shading_slope_deg` exceeds thresholds.max_shading_slope_deg, or whose slope plus
/// thresholds.shading_slope_weight times it exceeds thresholds.max_slope_deg, is a hazard.
cv::Mat hazardMask(const cv::Mat& slope_deg, const cv::Mat& roughness_m, const cv::Mat& shadow_fraction,
                   const cv::Mat& shading_slope_deg, const HazardThresholds& thresholds);
/// The same with the layer the shading threshold is applied to given apart (shadingWithinMargin() of a grid
/// set, CV_32F of the same size, or empty when shading_slope_deg is): `shading_slope_deg` raises the slope
/// by the weight, `shading_near_deg` is compared with max_shading_slope_deg.
cv::Mat hazardMask(const cv::Mat& slope_deg, const cv::Mat& roughness_m, const cv::Mat& shadow_fraction,
                   const cv::Mat& shading_slope_deg, const cv::Mat& shading_near_deg,
                   const HazardThresholds& thresholds);

/// slope_deg + weight * shading_slope_deg where the shading is measured (finite), slope_deg elsewhere (a
/// copy when the layer is empty or the weight 0): the slope hazardMask compares with max_slope_deg. Throws
/// std::invalid_argument on layers of different sizes or types or a negative weight.
cv::Mat slopeWithShading(const cv::Mat& slope_deg, const cv::Mat& shading_slope_deg, double weight);

}  // namespace planetary_vo::terrain
