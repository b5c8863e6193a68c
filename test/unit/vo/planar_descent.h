#pragma once
/// The rendered planar descent of the pipeline tests: a textured ground plane z = 0 (1 m per texture pixel,
/// centred on the world origin) warped into each view by its exact plane-induced homography, seen by a
/// 320x240, 60 deg nadir camera flying along +x on a descending curve with a gentle yaw and pitch
/// oscillation, so that every pose is known.

#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "octave_texture.h"
#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"

namespace planetary_vo::test {

constexpr int kPlanarWidth = 320, kPlanarHeight = 240;
constexpr int kGroundTextureSizePx = 2048;

/// Octaves of smooth noise, from 8 m to 256 m features.
inline cv::Mat groundTexture() { return octaveNoiseTexture(kGroundTextureSizePx, 12345, 8, 256, 0.8); }

inline PinholeCamera planarDescentCamera() {
  return PinholeCamera::fromFieldOfView(kPlanarWidth, kPlanarHeight, 60.0);
}

/// Nadir camera (REP-103 optical frame: x right = world x, y down = world -y, z forward = world -z) over the
/// plane z = 0, flying along +x on a curve (so that the Sim(3) alignment is well posed), descending, with a
/// gentle yaw and pitch oscillation.
inline Pose truePose(double t) {
  Eigen::Matrix3d R_nadir;
  R_nadir.col(0) = Eigen::Vector3d::UnitX();
  R_nadir.col(1) = -Eigen::Vector3d::UnitY();
  R_nadir.col(2) = -Eigen::Vector3d::UnitZ();
  const double yaw = 3.0 * M_PI / 180.0 * std::sin(0.5 * t);
  const double pitch = 1.5 * M_PI / 180.0 * std::sin(0.7 * t);
  Pose T = Pose::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()).toRotationMatrix() * R_nadir;
  T.translation() = Eigen::Vector3d(-90.0 + 30.0 * t, 4.0 * t + 1.5 * t * t, 500.0 - 6.0 * t - 0.8 * t * t);
  return T;
}

/// The image of the textured plane seen from T_world_cam: texture pixel -> world (x, y, 0) -> camera ->
/// pixel.
inline cv::Mat renderView(const cv::Mat& texture, const PinholeCamera& camera, const Pose& T_world_cam) {
  const Pose T_cam_world = T_world_cam.inverse();
  Eigen::Matrix3d Rt;
  Rt.col(0) = T_cam_world.linear().col(0);
  Rt.col(1) = T_cam_world.linear().col(1);
  Rt.col(2) = T_cam_world.translation();
  Eigen::Matrix3d world_from_texture;
  const double half = kGroundTextureSizePx / 2.0;
  world_from_texture << 1, 0, -half, 0, -1, half, 0, 0, 1;
  const Eigen::Matrix3d H = camera.K() * Rt * world_from_texture;
  cv::Mat Hcv(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Hcv.at<double>(r, c) = H(r, c);
  cv::Mat image;
  cv::warpPerspective(texture, image, Hcv, cv::Size(camera.width(), camera.height()), cv::INTER_LINEAR,
                      cv::BORDER_REFLECT);
  return image;
}

}  // namespace planetary_vo::test
