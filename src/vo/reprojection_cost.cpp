/// @file reprojection_cost.cpp
/// Closed-form Jacobians of the reprojection residual (see the header).

#include "planetary_vo/vo/reprojection_cost.h"

#include <Eigen/Geometry>

#include "planetary_vo/geometry/pose.h"  // skew()

namespace planetary_vo {

bool ReprojectionCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  // Eigen's rotation of a vector by a quaternion (u, w), exactly as q * p evaluates it (unit norm assumed):
  //   a = 2 u x p,  R p = p + w a + u x a.
  const Eigen::Map<const Eigen::Vector3d> u(parameters[0]);
  const double w = parameters[0][3];
  const Eigen::Map<const Eigen::Vector3d> t(parameters[1]);
  const Eigen::Map<const Eigen::Vector3d> p(parameters[2]);
  const Eigen::Vector3d a = 2.0 * u.cross(p);
  const Eigen::Vector3d p_cam = p + w * a + u.cross(a) + t;
  if (!(p_cam.z() > 0.0)) return false;
  const double inv_z = 1.0 / p_cam.z();
  const double x = p_cam.x() * inv_z, y = p_cam.y() * inv_z;
  residuals[0] = fx_ * x + cx_ - px_.x();
  residuals[1] = fy_ * y + cy_ - px_.y();
  if (jacobians == nullptr) return true;

  // d residual / d p_cam.
  Eigen::Matrix<double, 2, 3> d_proj;
  d_proj << fx_ * inv_z, 0.0, -fx_ * x * inv_z, 0.0, fy_ * inv_z, -fy_ * y * inv_z;
  if (jacobians[0] != nullptr) {
    // d(R p)/du = -2 w [p]x - [a]x - 2 [u]x [p]x ;  d(R p)/dw = a.
    Eigen::Matrix<double, 3, 4> d_q;
    d_q.leftCols<3>() = -2.0 * w * skew(p) - skew(a) - 2.0 * skew(u) * skew(p);
    d_q.col(3) = a;
    Eigen::Map<Eigen::Matrix<double, 2, 4, Eigen::RowMajor>> j_q(jacobians[0]);
    j_q = d_proj * d_q;
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j_t(jacobians[1]);
    j_t = d_proj;
  }
  if (jacobians[2] != nullptr) {
    // d(R p)/dp = I + 2 w [u]x + 2 [u]x [u]x (the rotation matrix of a unit quaternion).
    const Eigen::Matrix3d su = skew(u);
    const Eigen::Matrix3d d_p = Eigen::Matrix3d::Identity() + 2.0 * w * su + 2.0 * su * su;
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j_p(jacobians[2]);
    j_p = d_proj * d_p;
  }
  return true;
}

}  // namespace planetary_vo
