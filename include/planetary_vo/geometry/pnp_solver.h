#pragma once
/// @file pnp_solver.h
/// Absolute pose from 3D-2D correspondences: EPnP in RANSAC (cv::solvePnPRansac, SOLVEPNP_EPNP), then
/// Levenberg-Marquardt refinement on the inliers (cv::solvePnPRefineLM).

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/geometry/two_view_types.h"

namespace planetary_vo {

struct PnpOptions {
  RansacOptions ransac;  ///< threshold_px = reprojection error bound of an inlier
  bool refine_lm = true;
  /// EPnP needs 4 points (RANSAC samples 5); fewer inliers than this is not a pose worth trusting.
  int min_inliers = 10;
  /// Low for the same reason as TwoViewQualityThresholds::min_inlier_ratio (1 px threshold vs noisy points).
  double min_inlier_ratio = 0.1;
};

struct PnpResult {
  /// Maps world points into the camera: p_cam = T_cam_world * p_world. T_world_cam() is the camera pose.
  Pose T_cam_world = Pose::Identity();
  std::vector<std::uint8_t> inlier_mask;
  int num_points = 0;
  int num_inliers = 0;
  /// RMS reprojection error (px) over the inliers after refinement.
  double reprojection_rms_px = 0.0;
  bool valid = false;
  std::string reason;

  Pose T_world_cam() const { return T_cam_world.inverse(); }
};

/// @param p_world 3D points in the world (or any reference) frame; @param px ideal pixels of them.
PnpResult solvePnpRansac(const std::vector<Eigen::Vector3d>& p_world, const std::vector<cv::Point2d>& px,
                         const Eigen::Matrix3d& K, const PnpOptions& options = {});

}  // namespace planetary_vo
