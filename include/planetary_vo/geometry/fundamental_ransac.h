#pragma once
/// @file fundamental_ransac.h
/// Hartley's normalised eight-point algorithm and a RANSAC loop around it (Sampson distance, adaptive number
/// of iterations). OpenCV's FM_RANSAC samples 7 points; the thesis evaluates the 8-point method, so we own
/// it.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/two_view_types.h"

namespace planetary_vo {

struct EightPointSolution {
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();  ///< rank 2, Frobenius norm 1, x2^T F x1 = 0
  /// sigma7 / sigma1 of the normalised design matrix: ~0 when noise-free points are coplanar (3-dim null
  /// space).
  double conditioning = 0.0;
  /// sigma7 / sigma9 of the design matrix: how far the third-smallest direction stands above the noise floor.
  /// Coplanar points leave sigma7, sigma8, sigma9 all at the noise level (ratio ~1-3); points with depth
  /// relief lift sigma7 well above sigma9.
  double null_space_gap = 0.0;
  bool ok = false;
};

/// Normalised eight-point F from the correspondences selected by `indices` (>= 8).
EightPointSolution fundamentalEightPoint(const std::vector<cv::Point2d>& px1,
                                         const std::vector<cv::Point2d>& px2,
                                         const std::vector<int>& indices);

/// Squared Sampson distance (px^2) of a correspondence to F: the first-order geometric epipolar error.
double sampsonDistanceSq(const Eigen::Matrix3d& F, const cv::Point2d& p1, const cv::Point2d& p2);

struct FundamentalRansacResult {
  EightPointSolution solution;  ///< refit on all inliers
  std::vector<std::uint8_t> inlier_mask;
  int num_inliers = 0;
  int iterations = 0;
};

/// RANSAC over minimal 8-point samples, then a least-squares refit on the inliers (twice, re-selecting
/// inliers).
FundamentalRansacResult fundamentalRansac(const std::vector<cv::Point2d>& px1,
                                          const std::vector<cv::Point2d>& px2, const RansacOptions& options);

}  // namespace planetary_vo
