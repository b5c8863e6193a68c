#include "planetary_vo/vo/pnp_tracker.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "planetary_vo/geometry/pnp_solver.h"

namespace planetary_vo {

PnpTracker::PnpTracker(const PnpConfig& config, const BundleAdjustmentConfig& refinement)
    : config_(config), refinement_(refinement) {}

void PnpTracker::setRobustLossScale(double loss_scale_px) {
  if (!(loss_scale_px > 0.0 && std::isfinite(loss_scale_px)))
    throw std::invalid_argument("PnpTracker: robust-loss scale must be positive, got " +
                                std::to_string(loss_scale_px));
  refinement_.robust_loss_scale_px = loss_scale_px;
}

namespace {

PoseGaussNewtonOptions motionOnlyOptions(const BundleAdjustmentConfig& refinement) {
  PoseGaussNewtonOptions options;
  // The robust loss lets the refinement use every correspondence, so points that RANSAC's hard threshold
  // dropped near its border still constrain the pose, while gross outliers are down-weighted.
  options.loss = refinement.robust_loss == RobustLoss::kCauchy ? PoseGaussNewtonOptions::Loss::kCauchy
                                                               : PoseGaussNewtonOptions::Loss::kHuber;
  options.loss_scale_px = refinement.robust_loss_scale_px;
  options.max_iterations = refinement.max_iterations;
  return options;
}

}  // namespace

bool PnpTracker::refineAndScore(Pose T_cam_world, const std::vector<Eigen::Vector3d>& p_world,
                                const std::vector<Eigen::Vector2d>& px, const Eigen::Matrix3d& K,
                                PnpTrackResult* result) {
  if (config_.refine)
    refinePoseGaussNewton(&T_cam_world, p_world, px, K, motionOnlyOptions(refinement_), &refine_scratch_);
  const double threshold_sq = config_.ransac_reprojection_error_px * config_.ransac_reprojection_error_px;
  result->inlier_mask.assign(p_world.size(), 0);
  result->num_inliers = 0;
  double sum_sq = 0.0;
  for (size_t i = 0; i < p_world.size(); ++i) {
    const Eigen::Vector3d p_cam = T_cam_world * p_world[i];
    if (p_cam.z() <= 0.0) continue;
    const Eigen::Vector2d proj(K(0, 0) * p_cam.x() / p_cam.z() + K(0, 2),
                               K(1, 1) * p_cam.y() / p_cam.z() + K(1, 2));
    const double err_sq = (proj - px[i]).squaredNorm();
    if (err_sq > threshold_sq) continue;
    result->inlier_mask[i] = 1;
    ++result->num_inliers;
    sum_sq += err_sq;
  }
  result->reprojection_rms_px = result->num_inliers > 0 ? std::sqrt(sum_sq / result->num_inliers) : 0.0;
  result->T_world_cam = T_cam_world.inverse();
  return result->num_inliers >= config_.min_inliers;
}

PnpTrackResult PnpTracker::track(const std::vector<Eigen::Vector3d>& p_world,
                                 const std::vector<Eigen::Vector2d>& px, const Eigen::Matrix3d& K,
                                 const Pose* T_world_cam_predicted) {
  PnpTrackResult result;
  result.num_points = static_cast<int>(p_world.size());
  if (p_world.size() != px.size() || result.num_points < std::max(6, config_.min_inliers)) {
    result.reason = "too few map points in view (" + std::to_string(p_world.size()) + ")";
    return result;
  }

  if (T_world_cam_predicted != nullptr && config_.from_prediction && config_.refine &&
      T_world_cam_predicted->matrix().allFinite()) {
    if (refineAndScore(T_world_cam_predicted->inverse(), p_world, px, K, &result) &&
        result.num_inliers >= config_.prediction_min_inlier_ratio * result.num_points) {
      result.from_prediction = true;
      result.valid = true;
      return result;
    }
  }

  px_cv_.resize(px.size());
  for (size_t i = 0; i < px.size(); ++i) px_cv_[i] = cv::Point2d(px[i].x(), px[i].y());
  PnpOptions options;
  options.ransac.threshold_px = config_.ransac_reprojection_error_px;
  options.ransac.max_iterations = config_.ransac_iterations;
  options.ransac.confidence = config_.ransac_confidence;
  options.refine_lm = config_.refine;
  options.min_inliers = config_.min_inliers;
  const PnpResult pnp = solvePnpRansac(p_world, px_cv_, K, options);
  if (!pnp.valid) {
    result = PnpTrackResult();
    result.num_points = static_cast<int>(p_world.size());
    result.reason = "PnP: " + pnp.reason;
    return result;
  }
  if (!refineAndScore(pnp.T_cam_world, p_world, px, K, &result)) {
    result.reason = "only " + std::to_string(result.num_inliers) + " PnP inliers after refinement";
    return result;
  }
  result.valid = true;
  return result;
}

}  // namespace planetary_vo
