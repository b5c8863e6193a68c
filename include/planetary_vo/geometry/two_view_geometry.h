#pragma once
/// @file two_view_geometry.h
/// Relative motion of two calibrated views from 2D-2D correspondences: essential matrix (five-point in
/// RANSAC), fundamental matrix (normalised eight-point in RANSAC, then E = K^T F K) and homography (DLT in
/// RANSAC), each followed by the recovery of R, t and the quality checks that reject a bad model instead of
/// returning a wrong pose silently. See two_view_types.h for the frame convention and options.
///
/// Which one to use: E for general scenes with parallax, H for planar (or effectively planar, low-parallax)
/// scenes such as lunar terrain from altitude; F is kept for comparison with the thesis and is rejected on
/// planar scenes, where it is degenerate. model_selection.h scores H against F/E to choose automatically.

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/two_view_types.h"

namespace planetary_vo {

/// Five-point essential matrix in RANSAC (cv::findEssentialMat), then R, t by cheirality over all inliers.
/// @param px1, px2 ideal pixels of the same points in camera 1 and camera 2 (same size, >= 5).
/// @param K intrinsics of both views.
TwoViewResult estimateEssential(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                const Eigen::Matrix3d& K, const TwoViewOptions& options = {});
TwoViewResult estimateEssential(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                const PinholeCamera& camera, const TwoViewOptions& options = {});

/// Normalised eight-point fundamental matrix in our RANSAC (Sampson distance), E = K^T F K, then R, t as for
/// E. Rejected when K^T F K is not an essential matrix or the 8-point system is degenerate (planar scene).
TwoViewResult estimateFundamental(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                  const Eigen::Matrix3d& K, const TwoViewOptions& options = {});
TwoViewResult estimateFundamental(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                  const PinholeCamera& camera, const TwoViewOptions& options = {});

/// DLT homography in RANSAC (cv::findHomography), decomposition into up to four (R, t/d, n), of which the
/// physically valid ones (points in front of both cameras, plane facing camera 1) are reported best first.
/// The two-fold ambiguity is resolved by in-front counts when they differ clearly, otherwise by
/// options.prior_plane_normal_c1; with neither, the result is returned but marked invalid ("ambiguous").
TwoViewResult estimateHomography(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                 const Eigen::Matrix3d& K, const TwoViewOptions& options = {});
TwoViewResult estimateHomography(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                 const PinholeCamera& camera, const TwoViewOptions& options = {});

}  // namespace planetary_vo
