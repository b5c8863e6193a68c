#pragma once
/// The thesis section 3.4.3 scene (synthetic_scene.h) by its five knobs, shared by the geometry tests.

#include "planetary_vo/geometry/synthetic_scene.h"

namespace planetary_vo::test {

inline SyntheticTwoViewScene scene(double baseline, double spread, double rotation_deg, double noise,
                                   unsigned seed) {
  SyntheticSceneConfig c;
  c.baseline = baseline;
  c.depth_spread = spread;
  c.rotation_deg = rotation_deg;
  c.noise_px = noise;
  c.seed = seed;
  return makeSyntheticScene(c);
}

}  // namespace planetary_vo::test
