#include "planetary_vo/render/terrain_truth.h"

#include <cmath>

#include "planetary_vo/terrain/surface_analysis.h"

namespace planetary_vo::render {

terrain::GridSet groundTruthTerrain(const LunarTerrain& lunar, const terrain::LandingAreaParams& area) {
  terrain::GridSet grids;
  grids.geometry = area.geometry();
  const terrain::GridGeometry& g = grids.geometry;
  const double lod_m = g.cell_size_m;
  // The cell centres are the nodes (i0 + i, j0 + j) * spacing of LunarTerrain::sampleGrid (the grid is
  // centred on the origin, so x0 and y0 are whole multiples of the cell size); sampleGrid is bit-identical to
  // height().
  const auto i0 = static_cast<int64_t>(std::lround(g.x0_m / g.cell_size_m));
  const auto j0 = static_cast<int64_t>(std::lround(g.y0_m / g.cell_size_m));
  cv::Mat elevation = g.newLayer(0.0f), albedo = g.newLayer(0.0f);
  lunar.sampleGrid(i0, j0, g.cols, g.rows, g.cell_size_m, lod_m, elevation.ptr<float>(), albedo.ptr<float>());
  const terrain::SurfaceMaps surface = terrain::analyzeSurface(g, elevation, area.footprint_diameter_m);
  grids.layers["elevation_m"] = elevation;
  grids.layers["slope_deg"] = surface.slope_deg;
  grids.layers["roughness_m"] = surface.roughness_m;
  grids.description =
      "GROUND TRUTH (evaluator only): the true terrain of the landing area, from the rendered LunarTerrain "
      "at "
      "level of detail lod_m; slope and roughness over a footprint_diameter_m disc "
      "(terrain/surface_analysis.h)";
  grids.parameters = {{"half_extent_m", area.half_extent_m},
                      {"cell_size_m", area.cell_size_m},
                      {"footprint_diameter_m", area.footprint_diameter_m},
                      {"lod_m", lod_m}};
  return grids;
}

}  // namespace planetary_vo::render
