#include "planetary_vo/geometry/two_view_geometry.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/LU>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>

#include "planetary_vo/geometry/fundamental_ransac.h"
#include "planetary_vo/geometry/pose_recovery.h"

namespace planetary_vo {
namespace {

cv::Matx33d toCv(const Eigen::Matrix3d& M) {
  cv::Matx33d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = M(r, c);
  return out;
}

Eigen::Matrix3d toEigen(const cv::Mat& M) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = M.at<double>(r, c);
  return out;
}

int ransacMethod(const RansacOptions& o) { return o.local_optimization ? cv::USAC_ACCURATE : cv::RANSAC; }

std::vector<Eigen::Vector2d> toNormalized(const std::vector<cv::Point2d>& px, const Eigen::Matrix3d& K) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(px.size());
  const double fx = K(0, 0), fy = K(1, 1), cx = K(0, 2), cy = K(1, 2), s = K(0, 1);
  for (const auto& p : px) {
    const double y = (p.y - cy) / fy;
    out.emplace_back((p.x - cx - s * y) / fx, y);
  }
  return out;
}

std::string format(const char* what, double value, const char* op, double bound) {
  std::ostringstream os;
  os << what << " " << value << " " << op << " " << bound;
  return os.str();
}

/// Input checks common to all estimators; returns false (and fills `result`) when the input cannot be used.
bool checkInput(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                std::size_t min_points, TwoViewResult* result) {
  result->num_points = static_cast<int>(px1.size());
  result->inlier_mask.assign(px1.size(), 0);
  if (px1.size() != px2.size()) {
    result->reason = "px1 and px2 differ in size";
    return false;
  }
  if (px1.size() < min_points) {
    result->reason =
        "too few correspondences: " + std::to_string(px1.size()) + " < " + std::to_string(min_points);
    return false;
  }
  return true;
}

void copyMask(const cv::Mat& mask, TwoViewResult* result) {
  result->num_inliers = 0;
  for (int i = 0; i < result->num_points; ++i) {
    result->inlier_mask[i] = mask.empty() ? 1 : (mask.at<std::uint8_t>(i) != 0);
    result->num_inliers += result->inlier_mask[i];
  }
  result->quality.inlier_ratio =
      result->num_points > 0 ? double(result->num_inliers) / result->num_points : 0.0;
}

void setSingularValues(const Eigen::Matrix3d& M, TwoViewQuality* q) {
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(M).singularValues();
  if (s(0) <= 0.0) return;
  q->singular_values_normalized = s / s(0);
  q->det_normalized = M.determinant() / (s(0) * s(0) * s(0));
}

/// Checks shared by every model, in the order a failure is most informative. Returns the reason or "".
std::string commonChecks(const TwoViewResult& r, const TwoViewQualityThresholds& th) {
  if (r.num_inliers < th.min_inliers) return format("too few inliers:", r.num_inliers, "<", th.min_inliers);
  if (r.quality.inlier_ratio < th.min_inlier_ratio)
    return format("inlier ratio", r.quality.inlier_ratio, "<", th.min_inlier_ratio);
  if (r.quality.front_ratio < th.min_front_ratio)
    return format("share of inliers in front of both cameras", r.quality.front_ratio, "<",
                  th.min_front_ratio);
  if (r.quality.median_parallax_deg < th.min_median_parallax_deg)
    return format("median parallax (deg)", r.quality.median_parallax_deg, "<", th.min_median_parallax_deg);
  return "";
}

/// R, t from an essential matrix over the inliers, then the checks of E (and of E = K^T F K).
void finishEpipolar(const Eigen::Matrix3d& E_raw, const std::vector<cv::Point2d>& px1,
                    const std::vector<cv::Point2d>& px2, const Eigen::Matrix3d& K,
                    const TwoViewOptions& options, TwoViewResult* r) {
  setSingularValues(E_raw, &r->quality);
  // Project on the essential manifold (singular values 1, 1, 0) so that the decomposition gives true
  // rotations.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(E_raw, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d E = svd.matrixU() * Eigen::Vector3d(1, 1, 0).asDiagonal() * svd.matrixV().transpose();
  const PoseRecovery pose =
      recoverPoseFromEssential(E, toNormalized(px1, K), toNormalized(px2, K), r->inlier_mask);
  r->R_c2_c1 = pose.R_c2_c1;
  r->t_c2_c1_unit = pose.t_c2_c1_unit;
  r->num_in_front = pose.num_in_front;
  r->quality.front_ratio = r->num_inliers > 0 ? double(pose.num_in_front) / r->num_inliers : 0.0;
  r->quality.candidate_margin =
      pose.num_in_front > 0 ? double(pose.num_in_front - pose.num_in_front_second) / pose.num_in_front : 0.0;
  r->quality.median_parallax_deg = pose.median_parallax_deg;

  const TwoViewQualityThresholds& th = options.quality;
  std::string reason = commonChecks(*r, th);
  if (reason.empty() && r->quality.singular_values_normalized(1) < th.min_essential_singular_ratio)
    reason = format("not an essential matrix: sigma2/sigma1", r->quality.singular_values_normalized(1), "<",
                    th.min_essential_singular_ratio);
  r->reason = reason;
  r->valid = reason.empty();
}

}  // namespace

TwoViewResult estimateEssential(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                const Eigen::Matrix3d& K, const TwoViewOptions& options) {
  TwoViewResult r;
  r.model = TwoViewModel::kEssential;
  if (!checkInput(px1, px2, 5, &r)) return r;
  cv::Mat mask;
  const cv::Mat E = cv::findEssentialMat(px1, px2, cv::Mat(toCv(K)), ransacMethod(options.ransac),
                                         options.ransac.confidence, options.ransac.threshold_px,
                                         options.ransac.max_iterations, mask);
  // Degenerate samples can give several stacked 3x3 solutions or none; RANSAC keeps the best in the first
  // block.
  if (E.rows < 3 || E.cols != 3) {
    r.reason = "five-point RANSAC found no essential matrix";
    return r;
  }
  r.matrix = toEigen(E.rowRange(0, 3));
  copyMask(mask, &r);
  finishEpipolar(r.matrix, px1, px2, K, options, &r);
  return r;
}

TwoViewResult estimateFundamental(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                  const Eigen::Matrix3d& K, const TwoViewOptions& options) {
  TwoViewResult r;
  r.model = TwoViewModel::kFundamental;
  if (!checkInput(px1, px2, 8, &r)) return r;
  const FundamentalRansacResult ransac = fundamentalRansac(px1, px2, options.ransac);
  if (!ransac.solution.ok) {
    r.reason = "eight-point RANSAC found no fundamental matrix";
    return r;
  }
  r.matrix = ransac.solution.F;
  r.inlier_mask = ransac.inlier_mask;
  r.num_inliers = ransac.num_inliers;
  r.quality.inlier_ratio = double(r.num_inliers) / r.num_points;
  r.quality.fundamental_conditioning = ransac.solution.conditioning;
  r.quality.fundamental_null_space_gap = ransac.solution.null_space_gap;
  finishEpipolar(K.transpose() * r.matrix * K, px1, px2, K, options, &r);
  // Checked first when it fails: on a plane every check above may pass with an arbitrary F of the family.
  if (ransac.solution.conditioning < options.quality.min_fundamental_conditioning) {
    r.valid = false;
    r.reason = format("degenerate eight-point system (planar scene): sigma7/sigma1",
                      ransac.solution.conditioning, "<", options.quality.min_fundamental_conditioning);
  } else if (ransac.solution.null_space_gap < options.quality.min_fundamental_null_space_gap) {
    r.valid = false;
    r.reason = format("near-degenerate eight-point system (planar or low-relief scene): sigma7/sigma9",
                      ransac.solution.null_space_gap, "<", options.quality.min_fundamental_null_space_gap);
  }
  return r;
}

TwoViewResult estimateHomography(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                 const Eigen::Matrix3d& K, const TwoViewOptions& options) {
  TwoViewResult r;
  r.model = TwoViewModel::kHomography;
  if (!checkInput(px1, px2, 4, &r)) return r;
  cv::Mat mask;
  const cv::Mat H = cv::findHomography(px1, px2, ransacMethod(options.ransac), options.ransac.threshold_px,
                                       mask, options.ransac.max_iterations, options.ransac.confidence);
  if (H.rows != 3 || H.cols != 3) {
    r.reason = "DLT RANSAC found no homography";
    return r;
  }
  r.matrix = toEigen(H);
  copyMask(mask, &r);
  const Eigen::Matrix3d Hn = K.inverse() * r.matrix * K;
  setSingularValues(Hn, &r.quality);
  const PoseRecovery pose =
      recoverPoseFromHomography(Hn, toNormalized(px1, K), toNormalized(px2, K), r.inlier_mask,
                                options.prior_plane_normal_c1, options.quality.min_homography_margin);
  r.homography_candidates = pose.homography_candidates;
  r.resolved_by_prior = pose.resolved_by_prior;
  if (r.homography_candidates.empty()) {
    r.reason = "no homography decomposition puts the points in front of both cameras";
    return r;
  }
  r.R_c2_c1 = pose.R_c2_c1;
  r.t_c2_c1_unit = pose.t_c2_c1_unit;
  r.num_in_front = pose.num_in_front;
  r.quality.front_ratio = r.num_inliers > 0 ? double(pose.num_in_front) / r.num_inliers : 0.0;
  const int top = std::max(pose.num_in_front, pose.num_in_front_second);
  r.quality.candidate_margin =
      top > 0 ? std::abs(pose.num_in_front - pose.num_in_front_second) / double(top) : 0.0;
  r.quality.median_parallax_deg = pose.median_parallax_deg;

  const TwoViewQualityThresholds& th = options.quality;
  std::string reason = commonChecks(r, th);
  const bool two_candidates = r.homography_candidates.size() >= 2;
  if (reason.empty() && two_candidates && r.quality.candidate_margin < th.min_homography_margin &&
      !r.resolved_by_prior) {
    r.ambiguous = true;
    reason = format("ambiguous homography decomposition: two candidates, in-front margin",
                    r.quality.candidate_margin, "<", th.min_homography_margin) +
             " and no prior plane normal";
  }
  const double prior_angle = r.homography_candidates[0].prior_normal_angle_deg;
  if (reason.empty() && std::isfinite(prior_angle) && prior_angle > th.max_prior_normal_angle_deg)
    reason = format("plane normal disagrees with the prior (deg):", prior_angle, ">",
                    th.max_prior_normal_angle_deg);
  r.reason = reason;
  r.valid = reason.empty();
  return r;
}

TwoViewResult estimateEssential(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                const PinholeCamera& camera, const TwoViewOptions& options) {
  return estimateEssential(px1, px2, camera.K(), options);
}
TwoViewResult estimateFundamental(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                  const PinholeCamera& camera, const TwoViewOptions& options) {
  return estimateFundamental(px1, px2, camera.K(), options);
}
TwoViewResult estimateHomography(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                 const PinholeCamera& camera, const TwoViewOptions& options) {
  return estimateHomography(px1, px2, camera.K(), options);
}

}  // namespace planetary_vo
