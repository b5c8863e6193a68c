#pragma once
/// @file model_selection.h
/// Planarity / parallax scores that tell whether a homography or an epipolar model explains a pair of views,
/// following ORB-SLAM's initialisation: symmetric transfer-error scores S_H, S_F and R_H = S_H / (S_H + S_F).

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/two_view_types.h"

namespace planetary_vo {

struct PlanarityScore {
  double score_h = 0.0;  ///< S_H: sum over points of the truncated chi-square scores of both transfer errors
  double score_f = 0.0;  ///< S_F: same for the point-to-epipolar-line distances in both images
  double ratio_h = 0.0;  ///< R_H = S_H / (S_H + S_F); ~0.5 or more when H explains the points as well as F
  bool planar = false;   ///< ratio_h > the threshold given to scoreHomographyVsFundamental()
};

/// ORB-SLAM's model score (Mur-Artal et al. 2015, sec. IV): with sigma the noise of one image (px), each
/// point adds (5.99 - chi2) per direction whose chi2 = d^2 / (2 sigma^2) is under the chi-square bound (5.99
/// for H, 2 dof; 3.84 for F, 1 dof; the same 5.99 offset for both so that the scores are comparable). Unlike
/// ORB-SLAM we use 2 sigma^2 because both images are noisy.
/// @param H_px x2 ~ H x1 in pixels; @param F_px x2^T F x1 = 0 in pixels (for E: F = K^-T E K^-1).
/// @param planar_threshold ORB-SLAM picks H when R_H > 0.40. Measured here (1000 points, thesis camera): a
/// plane gives R_H 0.43-0.50, depth relief 0-500 at baseline 100 gives 0.15-0.25.
PlanarityScore scoreHomographyVsFundamental(const std::vector<cv::Point2d>& px1,
                                            const std::vector<cv::Point2d>& px2, const Eigen::Matrix3d& H_px,
                                            const Eigen::Matrix3d& F_px, double sigma_px = 1.0,
                                            double planar_threshold = 0.40);

/// F in pixels from a calibrated E: F = K^-T E K^-1.
Eigen::Matrix3d fundamentalFromEssential(const Eigen::Matrix3d& E, const Eigen::Matrix3d& K);

/// Median parallax angle (deg) of the selected correspondences (mask empty = all) for a known rotation: the
/// angle between ray 1 and ray 2 rotated into camera 1. Rotation alone gives no parallax, so this is what
/// carries depth information; under ~0.1 deg at 1 px noise the translation direction is unreliable.
double medianParallaxDeg(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                         const Eigen::Matrix3d& K, const Eigen::Matrix3d& R_c2_c1,
                         const std::vector<std::uint8_t>& mask = {});

/// Result of the automatic choice between the homography and the essential matrix.
struct ModelSelection {
  TwoViewResult essential;
  TwoViewResult homography;
  PlanarityScore planarity;
  /// The chosen one: homography when planar, else essential. Check chosen().valid before using it.
  bool homography_chosen = false;
  const TwoViewResult& chosen() const { return homography_chosen ? homography : essential; }
};

/// Runs E (five-point) and H on the same points and picks by R_H, as ORB-SLAM does with F and H. E stands in
/// for F because five-point E stays well-defined on planes, so its score is fair when the scene is planar.
ModelSelection selectTwoViewModel(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                  const Eigen::Matrix3d& K, const TwoViewOptions& options = {},
                                  double planar_threshold = 0.40);

}  // namespace planetary_vo
