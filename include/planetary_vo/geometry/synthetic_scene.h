#pragma once
/// @file synthetic_scene.h
/// The synthetic point clouds of the thesis' section 3.4.3, used by the geometry tests and benchmark: random
/// points in front of camera 1, seen by camera 1 and by a camera 2 displaced by a baseline and a rotation.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

struct SyntheticSceneConfig {
  int num_points = 1000;
  double xy_half_extent = 1000.0;  ///< x, y uniform in [-e, e] (units)
  double depth_min = 1500.0;       ///< z uniform in [depth_min, depth_min + depth_spread]; spread 0 = a plane
  double depth_spread = 0.0;
  double baseline = 30.0;  ///< distance between the camera centres (units)
  /// Direction of camera 2's centre in camera 1 (sideways, as in the thesis: no altitude change).
  Eigen::Vector3d centre_direction_c1 = Eigen::Vector3d::UnitX();
  /// Camera 2 rotated by this angle about x, then by the same angle about y (thesis: 30 deg about two axes).
  double rotation_deg = 0.0;
  double noise_px = 0.0;  ///< std-dev of Gaussian noise added to both images' pixels
  std::uint32_t seed = 1;
};

struct SyntheticTwoViewScene {
  PinholeCamera camera;
  Pose T_c2_c1 = Pose::Identity();  ///< ground truth, p_c2 = T_c2_c1 * p_c1
  std::vector<Eigen::Vector3d> points_c1;
  std::vector<cv::Point2d> px1, px2;  ///< noisy ideal pixels (not clipped to the image, as in the thesis)
};

/// The thesis camera: 1024 x 1024 px, fx = fy = 886.51, cx = cy = 512 (60 deg aperture).
PinholeCamera thesisCamera();

SyntheticTwoViewScene makeSyntheticScene(const SyntheticSceneConfig& config);

}  // namespace planetary_vo
