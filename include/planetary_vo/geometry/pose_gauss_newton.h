#pragma once
/// @file pose_gauss_newton.h
/// Motion-only pose refinement without Ceres: the camera pose that minimises the robust sum of reprojection
/// errors of fixed 3D points, by Levenberg-Marquardt damped Gauss-Newton on SE(3) with iteratively reweighted
/// residuals. It is the same problem as the Ceres motion-only refinement of bundle_adjuster.h (refinePose:
/// same residual, same Huber or Cauchy loss on the pixel error's norm), solved in a few tens of microseconds for
/// a few hundred points instead of a few hundred: this runs on every frame (pnp_tracker.h).
///
/// The update is a left perturbation in the camera frame, T_cam_world <- exp(xi) * T_cam_world with xi =
/// (rotation, translation). The translation columns are scaled by the median point depth before the 6x6 solve,
/// so a map of any unit (a monocular map 1e-5 wide far from its origin, issue 12's soak) is solved as well
/// conditioned as one in metres.

#include <vector>

#include <Eigen/Core>

#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

struct PoseGaussNewtonOptions {
  enum class Loss { kNone, kHuber, kCauchy };
  Loss loss = Loss::kHuber;
  double loss_scale_px = 2.0;  ///< pixel error where the loss starts to flatten (Ceres' HuberLoss(a) / CauchyLoss(a))
  int max_iterations = 20;     ///< accepted or rejected steps, in all
  /// Converged when an accepted step changes the cost by less than this fraction (Ceres' function_tolerance).
  double function_tolerance = 1e-6;
  /// ... or moves the pose by less than this (radians; translation in units of the median point depth).
  double parameter_tolerance = 1e-8;
};

struct PoseGaussNewtonSummary {
  bool converged = false;  ///< a tolerance was met (false: iteration cap, or nothing to solve)
  int iterations = 0;
  int num_residuals = 0;     ///< points in front of the camera at the start
  double initial_cost = 0.0;  ///< sum of rho(|e|^2) / 2 over those points, px^2
  double final_cost = 0.0;
};

/// Buffers of one call, kept by a caller that refines every frame so that the call allocates nothing.
struct PoseGaussNewtonScratch {
  std::vector<int> used;
  std::vector<double> depths;
};

/// Refines `T_cam_world` (p_cam = T_cam_world * p_world) in place from its current value; the pose is written
/// whenever the cost went down (also when the iteration cap stopped it: `converged` says which). Points behind
/// the camera at the start take no part. Leaves the pose unchanged when fewer than 3 points are in front, or
/// when the normal equations are singular.
PoseGaussNewtonSummary refinePoseGaussNewton(Pose* T_cam_world, const std::vector<Eigen::Vector3d>& p_world,
                                            const std::vector<Eigen::Vector2d>& px, const Eigen::Matrix3d& K,
                                            const PoseGaussNewtonOptions& options = {},
                                            PoseGaussNewtonScratch* scratch = nullptr);

}  // namespace planetary_vo
