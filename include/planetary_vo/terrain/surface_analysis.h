#pragma once
/// @file surface_analysis.h
/// Slope and roughness of an elevation grid over a lander footprint: what hazard detection and avoidance
/// (HDA) compares with the lander's limits (issue 11: 10 deg, 0.3 m).
///
/// For every cell, the footprint is the disc of cells whose centres lie within footprint_diameter_m / 2 of
/// the cell's centre (a cell exactly on the circle is in). A plane z = a + gx dx + gy dy is fitted by least
/// squares to the elevations of the disc's cells (dx, dy: their world offsets from the centre cell), and
///  - slope_deg = atan(|(gx, gy)|): the angle between the plane's normal and the vertical;
///  - roughness_m = max |z - plane| over the disc's cells: the largest departure of the surface from
///    the plane the lander would settle on, a rock above it or a hole below it. An isolated one-cell spike
///    of height h at the disc centre gives h (1 - 1/N) over a disc of N cells (the plane is pulled up by
///    h / N); off centre, h (1 - 1/N - d^2 / sum(dx^2)) with d its distance from the centre (the plane also
///    tilts toward it).
/// A cell whose disc is not entirely inside the grid or holds an unknown elevation (NaN, or infinite) gets
/// NaN for both.
///
/// Cost: the plane fit is the disc's moments from row prefix sums (2 lookups per disc row); the roughness
/// visits every cell of the disc once. The disc being symmetric, the fit needs no matrix solve.

#include <vector>

#include <opencv2/core.hpp>

#include "planetary_vo/terrain/grid.h"

namespace planetary_vo::terrain {

struct SurfaceMaps {
  cv::Mat slope_deg;    ///< CV_32F, NaN where the footprint is not fully known
  cv::Mat roughness_m;  ///< CV_32F, NaN where the footprint is not fully known
};

/// The footprint disc as (col, row) offsets from its centre cell. Throws std::invalid_argument unless
/// footprint_diameter_m >= 2 * cell_size_m (the disc then holds at least the centre and its 4 neighbours, so
/// the plane is determined).
std::vector<cv::Point> footprintOffsets(double cell_size_m, double footprint_diameter_m);

/// Slope and roughness of `elevation_m` (geometry.rows x geometry.cols CV_32F, NaN = unknown) over a
/// footprint of `footprint_diameter_m`. Throws std::invalid_argument on a layer of the wrong size or type.
SurfaceMaps analyzeSurface(const GridGeometry& geometry, const cv::Mat& elevation_m,
                           double footprint_diameter_m);

}  // namespace planetary_vo::terrain
