#include "planetary_vo/geometry/synthetic_scene.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>

namespace planetary_vo {

PinholeCamera thesisCamera() { return PinholeCamera(1024, 1024, 886.51, 886.51, 512.0, 512.0); }

SyntheticTwoViewScene makeSyntheticScene(const SyntheticSceneConfig& config) {
  SyntheticTwoViewScene s;
  s.camera = thesisCamera();
  const double a = config.rotation_deg * M_PI / 180.0;
  // Orientation of camera 2 in camera 1: first about x, then about the new y.
  const Eigen::Matrix3d R_c1_c2 =
      (Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  const Eigen::Vector3d centre2_c1 = config.baseline * config.centre_direction_c1.normalized();
  s.T_c2_c1.linear() = R_c1_c2.transpose();
  s.T_c2_c1.translation() = -R_c1_c2.transpose() * centre2_c1;

  std::mt19937 rng(config.seed);
  std::uniform_real_distribution<double> xy(-config.xy_half_extent, config.xy_half_extent);
  std::uniform_real_distribution<double> depth(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  s.points_c1.reserve(config.num_points);
  s.px1.reserve(config.num_points);
  s.px2.reserve(config.num_points);
  for (int i = 0; i < config.num_points; ++i) {
    const double x = xy(rng), y = xy(rng);
    const double z = config.depth_min + config.depth_spread * depth(rng);
    const Eigen::Vector3d p_c1(x, y, z);
    const Eigen::Vector2d u1 = s.camera.project(p_c1);
    const Eigen::Vector2d u2 = s.camera.project(s.T_c2_c1 * p_c1);
    s.points_c1.push_back(p_c1);
    s.px1.emplace_back(u1.x() + config.noise_px * noise(rng), u1.y() + config.noise_px * noise(rng));
    s.px2.emplace_back(u2.x() + config.noise_px * noise(rng), u2.y() + config.noise_px * noise(rng));
  }
  return s;
}

}  // namespace planetary_vo
