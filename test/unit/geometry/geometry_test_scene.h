#pragma once
/// The thesis section 3.4.3 scene (synthetic_scene.h) by its five knobs, shared by the geometry tests.

#include <Eigen/Geometry>

#include "planetary_vo/geometry/pose.h"
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

/// A pose from a rotation vector in degrees (axis times angle) and a translation.
inline Pose makePose(const Eigen::Vector3d& axis_angle_deg, const Eigen::Vector3d& t) {
  Pose T = Pose::Identity();
  if (axis_angle_deg.norm() > 0)
    T.linear() = Eigen::AngleAxisd(axis_angle_deg.norm() * M_PI / 180.0, axis_angle_deg.normalized())
                     .toRotationMatrix();
  T.translation() = t;
  return T;
}

}  // namespace planetary_vo::test
