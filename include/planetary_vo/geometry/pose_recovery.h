#pragma once
/// @file pose_recovery.h
/// R, t from an essential matrix or a homography, with the checks that decide between their candidate
/// solutions. Works on normalised image coordinates (x/z, y/z) of the inliers.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/geometry/two_view_types.h"

namespace planetary_vo {

/// Outcome of choosing among the motion candidates of one matrix.
struct PoseRecovery {
  Eigen::Matrix3d R_c2_c1 = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_c2_c1_unit = Eigen::Vector3d::Zero();
  int num_in_front = 0;         ///< inliers with positive triangulated depth in both cameras, chosen motion
  int num_in_front_second = 0;  ///< same for the runner-up candidate
  double median_parallax_deg = 0.0;
  std::vector<HomographyCandidate> homography_candidates;  ///< homography only, best first
  bool resolved_by_prior = false;
};

/// Four-fold ambiguity of E = [t]x R: (R1|R2) x (+t|-t). Each candidate triangulates ALL inliers (linear
/// two-ray depths) and the one with most points in front of both cameras wins; the runner-up count is kept so
/// that the caller can see how clearly it won.
/// @param xn1, xn2 normalised coordinates; @param mask selects the points to use (empty = all).
PoseRecovery recoverPoseFromEssential(const Eigen::Matrix3d& E, const std::vector<Eigen::Vector2d>& xn1,
                                      const std::vector<Eigen::Vector2d>& xn2,
                                      const std::vector<std::uint8_t>& mask);

/// Decomposes the calibrated homography H_n = K^-1 H K (cv::decomposeHomographyMat) and keeps candidates
/// whose plane is in front of camera 1 for the points (n . x1 > 0, the plane faces the camera) and whose
/// points are in front of camera 2. Best first by in-front count; when the counts are within `min_margin` of
/// each other and `prior_normal_c1` is non-zero, the candidate whose normal is closest to the prior goes
/// first.
PoseRecovery recoverPoseFromHomography(const Eigen::Matrix3d& H_normalized,
                                       const std::vector<Eigen::Vector2d>& xn1,
                                       const std::vector<Eigen::Vector2d>& xn2,
                                       const std::vector<std::uint8_t>& mask,
                                       const Eigen::Vector3d& prior_normal_c1, double min_margin);

/// Depths of a point along its two normalised rays: p_c1 = z1 * [x1; 1], p_c2 = z2 * [x2; 1] = R p_c1 + t, in
/// the least-squares sense. Returns false when the rays are parallel (no parallax: depth undetermined).
bool twoRayDepths(const Eigen::Matrix3d& R_c2_c1, const Eigen::Vector3d& t_c2_c1, const Eigen::Vector2d& xn1,
                  const Eigen::Vector2d& xn2, double* z1, double* z2);

/// Angle (deg) between the two viewing rays of a correspondence, with camera 2's ray rotated into camera 1.
double parallaxAngleDeg(const Eigen::Matrix3d& R_c2_c1, const Eigen::Vector2d& xn1,
                        const Eigen::Vector2d& xn2);

}  // namespace planetary_vo
