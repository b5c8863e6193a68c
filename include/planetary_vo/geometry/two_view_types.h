#pragma once
/// @file two_view_types.h
/// Options and result types shared by the two-view estimators (E, F, H) and the pose recovery.
///
/// Frame convention: camera 1 is the reference view, camera 2 the current one. `R_c2_c1`, `t_c2_c1` map a
/// point from camera 1 into camera 2 (p_c2 = R_c2_c1 * p_c1 + t_c2_c1), which is the thesis' P2 = K [R | t]
/// with P1 = K [I | 0]. Monocular two-view geometry has no scale, so `t_c2_c1_unit` has unit norm.
///
/// Pixel inputs are IDEAL (undistorted) pixels: call PinholeCamera::undistortPixels() first when the lens has
/// distortion. Normalised inputs (x/z, y/z) are accepted through normalizedToVirtualPixels() + virtualK().

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

/// RANSAC settings. The defaults are the thesis' (99 % confidence, 1 px threshold).
struct RansacOptions {
  double confidence = 0.99;
  /// Inlier threshold in pixels: Sampson (first-order epipolar) distance for E and F, one-way transfer error
  /// for H, reprojection error for PnP.
  double threshold_px = 1.0;
  int max_iterations = 2000;
  /// Seed of the estimators that run our own RANSAC loop (F); OpenCV's loops are deterministic by themselves.
  std::uint64_t seed = 0x5eed;
  /// E and H: OpenCV's USAC with local optimisation and a final least-squares fit on the inliers
  /// (cv::USAC_ACCURATE) instead of plain RANSAC, whose model comes from a minimal sample only. With 1 px
  /// noise and a 1 px threshold the minimal-sample model is visibly worse (see docs/geometry_benchmark.md).
  bool local_optimization = true;
};

/// Thresholds that decide whether an estimate is trusted (`valid`). Each rejection names the failed check.
struct TwoViewQualityThresholds {
  /// Fewer inliers than this leaves the model under-determined in practice.
  int min_inliers = 15;
  /// Share of the input that must agree with the model; below it the model explains too little of the scene.
  /// Low on purpose: with 1 px noise and the thesis' 1 px threshold a correct H keeps only ~15-25 % of the
  /// points (its one-way transfer error has sigma*sqrt(2) per axis) and E ~35 % (benchmark).
  double min_inlier_ratio = 0.1;
  /// Share of inliers that must triangulate in front of both cameras for the chosen motion. The wrong one of
  /// the four E solutions puts about half the points behind a camera; noise at tiny parallax does the same.
  double min_front_ratio = 0.9;
  /// E recovered from F (K^T F K) must have two equal singular values: sigma2 / sigma1 at least this.
  double min_essential_singular_ratio = 0.8;
  /// Degeneracy of the 8-point system on the F inliers. Coplanar points leave a 3-dimensional null space
  /// (sigma7 ~ sigma8 ~ sigma9 ~ 0 of the Hartley-normalised design matrix) and F is then any member of a
  /// family [e']x H: the pose from it is arbitrary. Noise-free planes give sigma7/sigma1 ~ 1e-8 (round-off)
  /// against
  /// >= 2e-5 for 100 units of depth relief at 1500 units; with noise, sigma7/sigma9 measured ~1.9-2.4 on
  /// planes, 2.5-3.6 on scenes with too little relief for F (direction errors 4-60 deg) and > 6 where F
  /// works.
  double min_fundamental_conditioning = 1e-6;
  double min_fundamental_null_space_gap = 4.0;
  /// Median parallax angle (deg) of the inliers below which the translation direction is noise, not geometry:
  /// 0.2 deg is ~3 px at f = 886 px; at the thesis' baseline 3 (~0.1 deg) 1 px noise turns the translation
  /// direction by tens of degrees (benchmark). 0 disables the check.
  double min_median_parallax_deg = 0.2;
  /// Homography: relative margin (n_best - n_second) / n_best of in-front counts below which the two
  /// physically valid decompositions are considered indistinguishable (the two-fold ambiguity) unless a prior
  /// decides.
  double min_homography_margin = 0.1;
  /// Homography with a prior normal: the chosen plane normal must be within this angle (deg) of the prior.
  double max_prior_normal_angle_deg = 45.0;
};

/// Options of one two-view estimate.
struct TwoViewOptions {
  RansacOptions ransac;
  TwoViewQualityThresholds quality;
  /// Homography only: expected unit normal of the scene plane in camera 1, pointing from the camera towards
  /// the plane (for a camera over flat ground: the nadir direction in the camera frame). Zero vector = no
  /// prior.
  Eigen::Vector3d prior_plane_normal_c1 = Eigen::Vector3d::Zero();
};

enum class TwoViewModel { kEssential, kFundamental, kHomography };
const char* toString(TwoViewModel model);

/// Numbers used to judge an estimate; NaN where a number does not apply to the model.
struct TwoViewQuality {
  /// Singular values of the calibrated matrix (E, K^T F K, or K^-1 H K), divided by the largest.
  Eigen::Vector3d singular_values_normalized = Eigen::Vector3d::Constant(NAN);
  /// det of the calibrated matrix divided by sigma1^3 (0 for a perfect E or F).
  double det_normalized = NAN;
  /// F only: sigma7 / sigma1 of the normalised 8-point design matrix over the inliers (~0 =
  /// degenerate/planar).
  double fundamental_conditioning = NAN;
  /// F only: sigma7 / sigma9 of the same design matrix (~1-3 when planar: no direction above the noise).
  double fundamental_null_space_gap = NAN;
  double inlier_ratio = 0.0;
  /// Share of inliers in front of both cameras for the chosen motion.
  double front_ratio = 0.0;
  /// (n_best - n_second) / n_best of the in-front counts of the best and second-best motion candidates.
  double candidate_margin = 0.0;
  /// Median angle (deg) between the two viewing rays of the inliers in front.
  double median_parallax_deg = 0.0;
};

/// One physically plausible motion from a homography decomposition.
struct HomographyCandidate {
  Eigen::Matrix3d R_c2_c1 = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_c2_c1_unit = Eigen::Vector3d::Zero();
  /// Unit plane normal in camera 1, pointing from camera 1 towards the plane.
  Eigen::Vector3d normal_c1 = Eigen::Vector3d::Zero();
  /// |t| / d: translation over plane distance (the homography knows only this ratio).
  double translation_over_distance = 0.0;
  int num_in_front = 0;
  /// Angle (deg) to the prior normal; NaN without a prior.
  double prior_normal_angle_deg = NAN;
};

/// Result of one two-view estimate. When `valid` is false, `reason` says which check failed; R and t are
/// still filled with the best guess (for diagnostics) when a model was found at all.
struct TwoViewResult {
  TwoViewModel model = TwoViewModel::kEssential;
  /// The estimated matrix as defined on the input points: E (calibrated), F or H (pixels).
  Eigen::Matrix3d matrix = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d R_c2_c1 = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_c2_c1_unit = Eigen::Vector3d::Zero();
  /// One byte per input correspondence: 1 = RANSAC inlier.
  std::vector<std::uint8_t> inlier_mask;
  int num_points = 0;
  int num_inliers = 0;
  int num_in_front = 0;
  TwoViewQuality quality;
  /// Homography only: the physically valid decompositions, best first (at most two survive in practice).
  std::vector<HomographyCandidate> homography_candidates;
  /// Homography only: true when the prior normal chose between candidates the points could not separate.
  bool resolved_by_prior = false;
  /// Homography only: every check passed except that the two decompositions could not be told apart (in-front
  /// margin too small, no prior). valid is false; a caller with more information (later views, triangulation)
  /// may still choose between homography_candidates.
  bool ambiguous = false;
  bool valid = false;
  std::string reason;

  /// Pose of camera 1 in camera 2 with unit-length translation.
  Pose T_c2_c1_unit() const;
};

/// Ideal pixels of a virtual camera K = diag(f, f, 1) from normalised coordinates, so that normalised points
/// can be fed to the pixel-based estimators with thresholds still meaning pixels of a camera of focal length
/// f.
std::vector<cv::Point2d> normalizedToVirtualPixels(const std::vector<cv::Point2d>& normalized,
                                                   double focal_px);
Eigen::Matrix3d virtualK(double focal_px);

}  // namespace planetary_vo
