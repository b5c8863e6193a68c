#pragma once
/// Views of level ground for the terrain tests: a nadir pose, and an image ray-cast onto the plane z =
/// ground_z with each pixel's value given by a function of the ground point it sees.
#include <cstdint>
#include <functional>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"

namespace planetary_vo::test {

/// Camera at (x, y, z) looking straight down: optical z along -z, image x along +x, image y along -y.
inline Pose nadirAt(double x, double y, double z) {
  Pose T = Pose::Identity();
  T.linear().col(0) = Eigen::Vector3d::UnitX();
  T.linear().col(1) = -Eigen::Vector3d::UnitY();
  T.linear().col(2) = -Eigen::Vector3d::UnitZ();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

/// CV_8U image of the camera's size: value(ground point) where the pixel's ray meets z = ground_z, 0 where it
/// does not (looking up).
inline cv::Mat renderLevelGround(const PinholeCamera& camera, const Pose& T_world_cam, double ground_z,
                                 const std::function<uint8_t(const Eigen::Vector3d&)>& value) {
  cv::Mat image(camera.height(), camera.width(), CV_8U);
  const Eigen::Vector3d o = T_world_cam.translation();
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c) {
      const Eigen::Vector3d d = T_world_cam.linear() * camera.distortedPixelToBearing({double(c), double(r)});
      image.at<uint8_t>(r, c) = d.z() < 0.0 ? value(o + (ground_z - o.z()) / d.z() * d) : 0;
    }
  return image;
}

}  // namespace planetary_vo::test
