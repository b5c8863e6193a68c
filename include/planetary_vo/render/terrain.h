#pragma once
/// @file terrain.h
/// The Lunar terrain seen by the renderer: real DEM relief (bicubic) + procedural craters, boulders and
/// fractal roughness, all evaluated at a given level of detail (LOD) = ground size of one pixel footprint.
///
/// The LOD is a band limit, not a blur: every feature of wavelength >= 2 * lod is present at full amplitude,
/// features between 1 and 2 footprints fade in smoothly, smaller ones are absent. So a frame from 2 km
/// altitude gets no sub-pixel aliasing and a frame from 50 m still has texture down to its own pixel size.

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/render/crater_field.h"
#include "planetary_vo/render/dem.h"

namespace planetary_vo::render {

struct TerrainParams {
  uint64_t seed = 1;
  CraterFieldParams craters;
  double roughness_rms_1m = 0.012;  ///< amplitude of the 1 m wavelength roughness octave
  double hurst = 0.85;              ///< amplitude ~ wavelength^hurst (self-affine regolith)
  double roughness_max_wavelength_m = 512.0;
  double albedo = 0.12;             ///< mean normal albedo of mature regolith
  double albedo_variation = 0.025;  ///< amplitude of the large-scale albedo patches
};

class LunarTerrain {
 public:
  LunarTerrain(std::shared_ptr<const LunarDem> dem, const DemPlacement& placement,
               const TerrainParams& params);

  struct Sample {
    double height_m = 0.0;  ///< world z
    double albedo = 0.0;
  };
  /// Height and albedo at world (x, y) with detail down to the footprint `lod_m` (> 0).
  Sample sample(double x, double y, double lod_m) const;
  double height(double x, double y, double lod_m) const { return sample(x, y, lod_m).height_m; }
  /// sample() at every node ((i0 + i) * spacing, (j0 + j) * spacing), i < nx, j < ny, written to
  /// height[j * nx + i] and albedo[...]. Identical to sample() node by node, but evaluated per feature:
  /// noise lattice corners hashed once per grid, craters and boulders splatted onto the nodes they reach.
  /// This is what the renderer bakes its LOD lattices with.
  void sampleGrid(int64_t i0, int64_t j0, int nx, int ny, double spacing, double lod_m, float* height,
                  float* albedo) const;
  /// Upward unit normal from central differences one footprint apart.
  Eigen::Vector3d normal(double x, double y, double lod_m) const;
  /// Large-scale relief only (DEM, in world z): used for trajectory placement and region bounds.
  double demHeight(double x, double y) const;

  const LunarDem& dem() const { return *dem_; }
  const DemPlacement& placement() const { return placement_; }
  const TerrainParams& params() const { return params_; }
  const CraterField& craters() const { return craters_; }
  /// Upper bound of |procedural relief| added on top of the DEM (craters + rims + roughness), metres.
  double maxProceduralReliefM() const;

 private:
  std::shared_ptr<const LunarDem> dem_;
  DemPlacement placement_;
  TerrainParams params_;
  CraterField craters_;
  double octave_amplitude_[40] = {};
  double cos_heading_ = 1.0, sin_heading_ = 0.0;  // of the placement, computed once (demHeight is hot)
};

}  // namespace planetary_vo::render
