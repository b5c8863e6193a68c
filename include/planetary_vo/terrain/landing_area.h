#pragma once
/// @file landing_area.h
/// The landing area a hazard map covers and the lander it is analysed for: the one place of their defaults
/// (the renderer's ground-truth terrain grids use them; sequence_renderer.h).

#include "planetary_vo/terrain/grid.h"

namespace planetary_vo::terrain {

struct LandingAreaParams {
  /// The square [-half_extent_m, half_extent_m]^2 around the landing site (world origin). 256 m a side: it
  /// holds the site and the ground below the Approach's low gate (x, y = 0, -100 m; 100 m up), and is about
  /// what a nadir 60 deg camera sees from 220 m.
  double half_extent_m = 128.0;
  /// Eight cells across the footprint; a boulder 0.3 m high (the roughness limit of issue 11) is about
  /// 0.86 m wide in the renderer's model (height 0.35 x diameter), about two cells. 513 x 513 cells.
  double cell_size_m = 0.5;
  /// Diameter of the disc the lander's legs stand in, over which slope and roughness are computed.
  double footprint_diameter_m = 4.0;

  GridGeometry geometry() const { return GridGeometry::centeredOnOrigin(half_extent_m, cell_size_m); }
};

}  // namespace planetary_vo::terrain
