#include "planetary_vo/geometry/two_view_conditioning.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace planetary_vo {

namespace {

/// d(pixel)/d(point in the camera) of the pinhole projection.
Eigen::Matrix<double, 2, 3> projectionJacobian(const Eigen::Vector3d& p, double fx, double fy) {
  const double iz = 1.0 / p.z();
  Eigen::Matrix<double, 2, 3> J;
  J << fx * iz, 0.0, -fx * p.x() * iz * iz, 0.0, fy * iz, -fy * p.y() * iz * iz;
  return J;
}

}  // namespace

TwoViewConditioning twoViewConditioning(const std::vector<Eigen::Vector3d>& points_c1, const Pose& T_c2_c1,
                                        double fx, double fy, double sigma_px) {
  TwoViewConditioning out;
  out.rotation_sigma_deg = out.direction_sigma_deg = std::numeric_limits<double>::infinity();
  const Eigen::Vector3d t = T_c2_c1.translation();
  if (!(t.norm() > 0.0) || !(fx > 0.0) || !(fy > 0.0) || !(sigma_px > 0.0)) return out;
  const Eigen::Vector3d dir = t.normalized();
  // The direction of travel varies in the plane normal to it (2 degrees of freedom); the rotation by a
  // perturbation applied on the left: p_c2 = exp(w) R p_c1 + |t| (dir + a b1 + b b2).
  const Eigen::Vector3d helper =
      std::abs(dir.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d b1 = dir.cross(helper).normalized();
  const Eigen::Vector3d b2 = dir.cross(b1);
  const Eigen::Matrix3d R = T_c2_c1.linear();
  Eigen::Matrix<double, 5, 5> H = Eigen::Matrix<double, 5, 5>::Zero();
  int used = 0;
  for (const Eigen::Vector3d& p1 : points_c1) {
    if (!p1.allFinite() || !(p1.z() > 0.0)) continue;
    const Eigen::Vector3d Rp = R * p1;
    const Eigen::Vector3d p2 = Rp + t;
    if (!(p2.z() > 0.0)) continue;
    const Eigen::Matrix<double, 2, 3> J2 = projectionJacobian(p2, fx, fy);
    Eigen::Matrix<double, 3, 5> dp2_dm;
    dp2_dm.leftCols<3>() = -skew(Rp);
    dp2_dm.col(3) = t.norm() * b1;
    dp2_dm.col(4) = t.norm() * b2;
    const Eigen::Matrix<double, 2, 5> Jm = J2 * dp2_dm;
    const Eigen::Matrix<double, 2, 3> Jp2 = J2 * R;
    const Eigen::Matrix<double, 2, 3> Jp1 = projectionJacobian(p1, fx, fy);
    const Eigen::Matrix3d Hpp = Jp2.transpose() * Jp2 + Jp1.transpose() * Jp1;
    const Eigen::Matrix<double, 5, 3> Hmp = Jm.transpose() * Jp2;
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(Hpp);
    if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) continue;
    H += Jm.transpose() * Jm - Hmp * ldlt.solve(Hmp.transpose());
    ++used;
  }
  if (used == 0) return out;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 5, 5>> information(H);
  // Rank-deficient up to rounding (e.g. fewer than 5 points): not determined.
  if (information.info() != Eigen::Success ||
      !(information.eigenvalues().minCoeff() > 1e-12 * information.eigenvalues().maxCoeff()))
    return out;
  const Eigen::Matrix<double, 5, 5> covariance = sigma_px * sigma_px * H.inverse();
  const auto largestSigmaDeg = [](const Eigen::MatrixXd& block) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(block);
    return std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff())) * 180.0 / M_PI;
  };
  out.rotation_sigma_deg = largestSigmaDeg(covariance.topLeftCorner<3, 3>());
  out.direction_sigma_deg = largestSigmaDeg(covariance.bottomRightCorner<2, 2>());
  out.valid = std::isfinite(out.rotation_sigma_deg) && std::isfinite(out.direction_sigma_deg);
  return out;
}

}  // namespace planetary_vo
