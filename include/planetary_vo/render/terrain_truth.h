#pragma once
/// @file terrain_truth.h
/// The true terrain of the landing area, as the renderer writes it into every dataset (ground truth, for the
/// evaluator only): elevation, slope and roughness grids (terrain/grid.h, terrain/surface_analysis.h) of the
/// same LunarTerrain the images are rendered from.
///
/// Level of detail: the elevation of cell (col, row) is LunarTerrain::height at the cell centre with
/// lod_m = the cell size. The LOD is the terrain's band limit: relief of wavelength >= 2 lod (fBm octaves,
/// craters >= 4 lod across, boulders >= lod across) is there at full amplitude, finer relief fades out. With
/// lod = cell size the grid holds everything it can resolve (2 cells = its Nyquist wavelength) and nothing
/// that would alias between its samples; the same rule the renderer applies to a pixel's ground footprint, so
/// the images seen from low altitude (finer than a cell) show this relief plus finer detail.

#include <memory>
#include <string>

#include "planetary_vo/render/terrain.h"
#include "planetary_vo/terrain/grid.h"
#include "planetary_vo/terrain/landing_area.h"

namespace planetary_vo::render {

/// Name of the grid set in a dataset folder: groundtruth_terrain.yaml + groundtruth_terrain_<layer>.tiff.
constexpr const char* kGroundTruthTerrainName = "groundtruth_terrain";

/// Layers `elevation_m` (world z), `slope_deg`, `roughness_m` over area.geometry(), parameters
/// half_extent_m, cell_size_m, footprint_diameter_m and lod_m (the level of detail of the elevation).
terrain::GridSet groundTruthTerrain(const LunarTerrain& terrain, const terrain::LandingAreaParams& area);

}  // namespace planetary_vo::render
