#include "planetary_vo/vo/inertial_initializer.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

namespace planetary_vo {
namespace {

/// Two unit vectors orthogonal to g (and to each other).
Eigen::Matrix<double, 3, 2> tangentBasis(const Eigen::Vector3d& g) {
  const Eigen::Vector3d a = g.normalized();
  Eigen::Vector3d helper = std::abs(a.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d b1 = (helper - a * a.dot(helper)).normalized();
  Eigen::Matrix<double, 3, 2> B;
  B << b1, a.cross(b1);
  return B;
}

}  // namespace

InertialAlignment alignVisualInertial(const InertialAlignmentInput& in) {
  const size_t n = in.timestamps_s.size();
  if (n < 3) throw std::invalid_argument("visual-inertial alignment: needs at least 3 keyframes");
  if (in.T_map_cam.size() != n || in.preintegrations.size() + 1 != n)
    throw std::invalid_argument("visual-inertial alignment: sizes of times, poses and preintegrations differ");
  for (size_t k = 0; k + 1 < n; ++k) {
    const auto& p = in.preintegrations[k];
    if (!p) throw std::invalid_argument("visual-inertial alignment: null preintegration");
    if (std::abs(p->startTime_s() - in.timestamps_s[k]) > 1e-6 ||
        std::abs(p->endTime_s() - in.timestamps_s[k + 1]) > 1e-6)
      throw std::invalid_argument("visual-inertial alignment: preintegration " + std::to_string(k) +
                                  " does not span its keyframe interval");
  }
  InertialAlignment out;
  const Eigen::Matrix3d R_ci = in.T_cam_imu.linear();
  const Eigen::Vector3d t_ci = in.T_cam_imu.translation();
  std::vector<Eigen::Matrix3d> R_wb(n), R_wc(n);
  std::vector<Eigen::Vector3d> p_c(n);
  for (size_t k = 0; k < n; ++k) {
    R_wc[k] = in.T_map_cam[k].linear();
    R_wb[k] = R_wc[k] * R_ci;
    p_c[k] = in.T_map_cam[k].translation();
  }

  // 1. Gyro bias: one Gauss-Newton step on the rotation residuals, then re-integration at it.
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (size_t k = 0; k + 1 < n; ++k) {
    const ImuPreintegration& p = *in.preintegrations[k];
    const Eigen::Vector3d r = logSO3(p.deltaR().transpose() * R_wb[k].transpose() * R_wb[k + 1]);
    const Eigen::Matrix3d J = p.dR_dbg();
    H += J.transpose() * J;
    rhs += J.transpose() * r;
  }
  const ImuBias linearisation = in.preintegrations.front()->linearizationBias();
  ImuBias bias;
  if (in.gyro_bias_prior_sigma_radps > 0.0) {
    // MAP with a zero-mean prior on the bias: H + (sigma_r / sigma_b)^2 I, the prior about zero total bias.
    const double w = std::pow(in.rotation_sigma_rad / in.gyro_bias_prior_sigma_radps, 2);
    H += w * Eigen::Matrix3d::Identity();
    rhs -= w * linearisation.gyro_radps;
  }
  bias.gyro_radps = linearisation.gyro_radps + H.ldlt().solve(rhs);
  out.gyro_bias_radps = bias.gyro_radps;
  std::vector<ImuPreintegration> pre;
  pre.reserve(n - 1);
  for (size_t k = 0; k + 1 < n; ++k) {
    pre.push_back(*in.preintegrations[k]);
    pre.back().repropagate(bias);
  }

  // 2./3. Velocities, gravity (free, then on its sphere) and scale.
  const double G = in.gravity_mps2;
  const bool gravity_known = in.known_gravity_map.has_value();
  Eigen::Vector3d g = gravity_known ? *in.known_gravity_map : Eigen::Vector3d::Zero();
  double gravity_sigma_rad = 0.0;
  auto solve = [&](int gravity_unknowns, const Eigen::Matrix<double, 3, 2>& B, Eigen::VectorXd* x,
                   double* sigma_s_rel) {
    const int nv = 3 * static_cast<int>(n);
    const int ns = in.known_scale ? 0 : 1;
    const int cols = nv + gravity_unknowns + ns;
    const int rows = 6 * static_cast<int>(n - 1);
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(rows, cols);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(rows);
    for (size_t k = 0; k + 1 < n; ++k) {
      const ImuPreintegration& p = pre[k];
      const double dt = p.deltaTime_s();
      const int r = 6 * static_cast<int>(k);
      const int vi = 3 * static_cast<int>(k), vj = vi + 3;
      const Eigen::Vector3d dpc = p_c[k + 1] - p_c[k];
      // Position rows.
      A.block<3, 3>(r, vi) = -dt * Eigen::Matrix3d::Identity();
      b.segment<3>(r) = R_wb[k] * p.deltaP_m() + (R_wc[k] - R_wc[k + 1]) * t_ci;
      // Velocity rows.
      A.block<3, 3>(r + 3, vj) = Eigen::Matrix3d::Identity();
      A.block<3, 3>(r + 3, vi) = -Eigen::Matrix3d::Identity();
      b.segment<3>(r + 3) = R_wb[k] * p.deltaV_mps();
      // Gravity: g = g0 + B w (or free, or known).
      if (gravity_unknowns == 3) {
        A.block<3, 3>(r, nv) = -0.5 * dt * dt * Eigen::Matrix3d::Identity();
        A.block<3, 3>(r + 3, nv) = -dt * Eigen::Matrix3d::Identity();
      } else {
        if (gravity_unknowns == 2) {
          A.block<3, 2>(r, nv) = -0.5 * dt * dt * B;
          A.block<3, 2>(r + 3, nv) = -dt * B;
        }
        b.segment<3>(r) += 0.5 * dt * dt * g;
        b.segment<3>(r + 3) += dt * g;
      }
      if (ns == 1)
        A.block<3, 1>(r, cols - 1) = dpc;
      else
        b.segment<3>(r) -= dpc;
    }
    *x = A.colPivHouseholderQr().solve(b);
    const Eigen::VectorXd residual = A * *x - b;
    out.residual_rms = std::sqrt(residual.squaredNorm() / rows);
    *sigma_s_rel = 0.0;
    if (rows > cols) {
      const double var = residual.squaredNorm() / (rows - cols);
      const Eigen::MatrixXd cov = var * (A.transpose() * A).inverse();
      if (ns == 1) *sigma_s_rel = std::sqrt(cov(cols - 1, cols - 1)) / std::abs((*x)(cols - 1));
      // The gravity direction's 1-sigma: the larger tangent axis, in rad.
      if (gravity_unknowns == 2)
        gravity_sigma_rad =
            std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov.block<2, 2>(nv, nv)).eigenvalues()(1)) / G;
    }
  };
  Eigen::VectorXd x;
  double sigma_s = 0.0;
  const Eigen::Matrix<double, 3, 2> no_basis = Eigen::Matrix<double, 3, 2>::Zero();
  if (!gravity_known) {
    solve(3, no_basis, &x, &sigma_s);
    g = x.segment<3>(3 * static_cast<int>(n));
    if (!(std::abs(g.norm() - G) < 0.1 * G)) {
      // Under a constant acceleration a the system cannot tell gravity from scale (g + (k - 1) a with scale
      // k s fits as well): the free solve is then arbitrary.
      out.reason = "the estimated gravity is " + std::to_string(g.norm()) + " m/s^2, not " + std::to_string(G) +
                   ": the acceleration did not vary enough to separate gravity from the scale (hand over the "
                   "attitude, or wait for more motion)";
      return out;
    }
    for (int pass = 0; pass < 4; ++pass) {
      g = g.normalized() * G;
      const Eigen::Matrix<double, 3, 2> B = tangentBasis(g);
      solve(2, B, &x, &sigma_s);
      g = (g + B * x.segment<2>(3 * static_cast<int>(n))).normalized() * G;
    }
  }
  out.gravity_sigma_deg = gravity_sigma_rad * 180.0 / M_PI;
  if (!gravity_known && !(out.gravity_sigma_deg <= in.max_gravity_sigma_deg)) {
    out.reason = "the gravity direction is not observable enough (1-sigma " + std::to_string(out.gravity_sigma_deg) +
                 " deg): the acceleration did not vary enough (hand over the attitude, or wait for more motion)";
    return out;
  }
  solve(0, no_basis, &x, &sigma_s);
  out.scale = in.known_scale ? 1.0 : x(x.size() - 1);
  out.scale_sigma = sigma_s;
  out.gravity_map = g;
  if (!(out.scale > 0.0)) {
    out.reason = "non-positive scale " + std::to_string(out.scale);
    return out;
  }
  if (!in.known_scale && !(sigma_s <= in.max_scale_sigma)) {
    out.reason = "the scale is not observable enough (1-sigma " + std::to_string(100.0 * sigma_s) +
                 " %): the accelerometer saw too little acceleration besides gravity";
    return out;
  }
  out.velocities_map_mps.resize(n);
  for (size_t k = 0; k < n; ++k) out.velocities_map_mps[k] = x.segment<3>(3 * static_cast<int>(k));
  out.valid = true;
  return out;
}

}  // namespace planetary_vo
