#pragma once
/// @file reprojection_cost.h
/// The bundle adjustment's reprojection residual with analytic Jacobians.
///
/// Residual (2): the ideal pixel of a pinhole camera, K * (R(q) * p + t) projected, minus the measured
/// pixel. Blocks: q_cam_world (4, Eigen order x, y, z, w, on ceres::EigenQuaternionManifold), t_cam_world
/// (3), p_world (3). The rotation is Eigen's (q * p for a unit quaternion), differentiated in closed form, so
/// the values and Jacobians are those Ceres' automatic differentiation of the same expression gives, at a
/// fraction of the cost (test_reprojection_cost.cpp checks both).
///
/// A point on or behind the image plane (camera z <= 0) has no projection: the evaluation fails, so that
/// Levenberg-Marquardt rejects the step instead of following a sign flip of the depth.

#include <ceres/sized_cost_function.h>
#include <Eigen/Core>

namespace planetary_vo {

class ReprojectionCost final : public ceres::SizedCostFunction<2, 4, 3, 3> {
 public:
  ReprojectionCost(const Eigen::Vector2d& px, double fx, double fy, double cx, double cy)
      : px_(px), fx_(fx), fy_(fy), cx_(cx), cy_(cy) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector2d px_;
  double fx_, fy_, cx_, cy_;
};

}  // namespace planetary_vo
