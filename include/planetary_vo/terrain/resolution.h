#pragma once
/// @file resolution.h
/// The terrain as a map of a given resolution sees it: every cell's elevation replaced by the weighted
/// least-squares plane through the cells within support_radius_m of it (Gaussian weights of sigma
/// support_radius_m / 2), evaluated at the cell: the estimator of terrain_map.h applied to perfect, dense
/// samples. Scoring an estimated map against the truth at the resolution it claims (issue 11: hazards "at
/// the resolution the map claims") compares it with this, not with relief it cannot resolve.

#include <opencv2/core.hpp>

#include "planetary_vo/terrain/grid.h"

namespace planetary_vo::terrain {

/// `elevation_m` (CV_32F, NaN = unknown) seen at `support_radius_m`; a cell whose support holds an unknown
/// cell is unknown. Throws std::invalid_argument on a layer of the wrong size or type or a radius below one
/// cell.
cv::Mat elevationAtSupport(const GridGeometry& geometry, const cv::Mat& elevation_m, double support_radius_m);

/// The truth's layers (elevation_m, slope_deg, roughness_m, from the elevation at that support and
/// surface_analysis over `footprint_diameter_m`), with parameter support_radius_m.
GridSet truthAtSupport(const GridSet& truth, double support_radius_m, double footprint_diameter_m);

}  // namespace planetary_vo::terrain
