#pragma once
/// @file triangulation.h
/// Two-view triangulation: linear DLT (Hartley & Zisserman 12.2) with an optional optimal (Hartley-Sturm)
/// correction of the measurements first (cv::correctMatches), and per-point depth, reprojection and parallax
/// checks so that points at infinity or mismatches do not enter the map.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

/// Linear DLT triangulation of one point from two 3x4 projection matrices and its two image points (the image
/// points in the same units as the P's: pixels with P = K[R|t], normalised with P = [R|t]). Returns the
/// inhomogeneous point in the frame the P's project from; NaN when the point is at infinity.
Eigen::Vector3d triangulateDlt(const Eigen::Matrix<double, 3, 4>& P1, const Eigen::Matrix<double, 3, 4>& P2,
                               const Eigen::Vector2d& x1, const Eigen::Vector2d& x2);

struct TriangulationOptions {
  /// Move the two measurements to the closest pair that satisfies the epipolar constraint exactly before the
  /// DLT.
  bool optimal_correction = true;
  /// Both reprojection errors (px, against the ORIGINAL measurements) must be below this.
  double max_reprojection_error_px = 2.0;
  /// Angle between the two rays must be at least this (deg): below it depth is dominated by noise.
  double min_parallax_deg = 0.5;
};

struct TriangulationResult {
  std::vector<Eigen::Vector3d> points_c1;     ///< in camera 1 (NaN for points at infinity)
  std::vector<double> reprojection_error_px;  ///< max over the two views
  std::vector<double> parallax_deg;
  std::vector<std::uint8_t> valid;  ///< in front of both cameras, reprojection and parallax checks passed
  int num_valid = 0;
};

/// Triangulates correspondences between camera 1 and camera 2 given T_c2_c1 (p_c2 = T_c2_c1 * p_c1).
/// @param px1, px2 ideal pixels; @param K intrinsics of both views.
TriangulationResult triangulatePoints(const std::vector<cv::Point2d>& px1,
                                      const std::vector<cv::Point2d>& px2, const Eigen::Matrix3d& K,
                                      const Pose& T_c2_c1, const TriangulationOptions& options = {});

}  // namespace planetary_vo
