#pragma once
/// @file pnp_tracker.h
/// Stage 5: the pose of a frame from its live tracks that carry map points (3D-2D correspondences by track
/// id). With a predicted pose (pnp.from_prediction), a motion-only robust refinement over all correspondences
/// starts from it (geometry/pose_gauss_newton.h); when its final reprojection errors leave at least
/// pnp.prediction_min_inlier_ratio of the correspondences as inliers, that is the pose, with no RANSAC (SVO's
/// sparse image alignment plays this part there). Otherwise, or without a prediction: EPnP in RANSAC with
/// Levenberg-Marquardt on the inliers (geometry/pnp_solver.h), then the same refinement from that pose. The
/// refinement's final reprojection errors decide the inliers.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/geometry/pose_gauss_newton.h"
#include "planetary_vo/vo/config.h"

namespace planetary_vo {

struct PnpTrackResult {
  bool valid = false;
  std::string reason;  ///< why tracking failed ("" when valid)
  Pose T_world_cam = Pose::Identity();
  std::vector<uint8_t> inlier_mask;  ///< per correspondence, after the refinement
  int num_points = 0;
  int num_inliers = 0;
  double reprojection_rms_px = 0.0;  ///< over the inliers
  bool from_prediction = false;      ///< posed from the prediction, without RANSAC
};

/// Frame-to-map tracker. Not thread-safe (reuses buffers); one per pipeline.
class PnpTracker {
 public:
  /// @param config RANSAC, acceptance and refinement switch.
  /// @param refinement robust loss and iteration cap of the motion-only refinement (bundle adjustment
  /// section).
  PnpTracker(const PnpConfig& config, const BundleAdjustmentConfig& refinement);

  /// @param p_world map points; @param px their ideal pixels in this frame; @param K intrinsics;
  /// @param T_world_cam_predicted where the frame is expected (motion model), or null: RANSAC only.
  PnpTrackResult track(const std::vector<Eigen::Vector3d>& p_world, const std::vector<Eigen::Vector2d>& px,
                       const Eigen::Matrix3d& K, const Pose* T_world_cam_predicted = nullptr);

  /// The robust-loss scale of the refinement from now on (the constructor's is
  /// refinement.robust_loss_scale_px); the Pipeline sets the one of the frame's tracking method. Must be
  /// positive.
  void setRobustLossScale(double loss_scale_px);

 private:
  /// Robust refinement from T_cam_world, then its inliers; false when too few.
  bool refineAndScore(Pose T_cam_world, const std::vector<Eigen::Vector3d>& p_world,
                      const std::vector<Eigen::Vector2d>& px, const Eigen::Matrix3d& K,
                      PnpTrackResult* result);

  PnpConfig config_;
  BundleAdjustmentConfig refinement_;
  std::vector<cv::Point2d> px_cv_;
  PoseGaussNewtonScratch refine_scratch_;
};

}  // namespace planetary_vo
