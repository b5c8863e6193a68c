/// @file inertial_factors.cpp
/// Ceres cost functions of the inertial problem with analytic Jacobians (inertial_factors.h; derivation in
/// docs/fusion/imu_preintegration.md).

#include "planetary_vo/fusion/inertial_factors.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

namespace planetary_vo {
namespace {

/// Lower Cholesky factor L of a symmetric positive definite matrix (M = L L^T); throws naming `what`.
template <int N>
Eigen::Matrix<double, N, N> choleskyLower(const Eigen::Matrix<double, N, N>& M, const std::string& what) {
  if (!M.allFinite()) throw std::invalid_argument(what + " is not finite");
  if (!M.isApprox(M.transpose(), 1e-9)) throw std::invalid_argument(what + " is not symmetric");
  const Eigen::Matrix<double, N, N> S = 0.5 * (M + M.transpose());
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(S);
  if (llt.info() != Eigen::Success || !(llt.matrixL().toDenseMatrix().diagonal().array() > 0.0).all())
    throw std::invalid_argument(what + " is not positive definite");
  return llt.matrixL();
}

/// W = L^-1 for a covariance C = L L^T, so that W^T W = C^-1.
template <int N>
Eigen::Matrix<double, N, N> whiteningFromCovariance(const Eigen::Matrix<double, N, N>& C,
                                                    const std::string& what) {
  const Eigen::Matrix<double, N, N> L = choleskyLower<N>(C, what);
  return L.template triangularView<Eigen::Lower>().solve(Eigen::Matrix<double, N, N>::Identity());
}

/// A writable map of the output array `data` as M (a named function, so that `out<M>(p) = ...` is an
/// expression and not a declaration).
template <typename M>
Eigen::Map<M> out(double* data) {
  return Eigen::Map<M>(data);
}

/// Unit quaternion of an Eigen-ordered (x, y, z, w) block; false for a (near) zero one. *norm = |q|.
bool readQuaternion(const double* q, Eigen::Quaterniond* unit, double* norm) {
  const Eigen::Map<const Eigen::Quaterniond> raw(q);
  *norm = raw.norm();
  if (!(*norm > 1e-12) || !std::isfinite(*norm)) return false;
  *unit = Eigen::Quaterniond(raw.coeffs() / *norm);
  return true;
}

/// d theta / d q (3x4, columns x, y, z, w) of the world-frame rotation perturbation theta of the NORMALISED
/// quaternion (R(q/|q|) = Exp(theta) R): 2 [q_w I + [q_v]x, -q_v] / |q|, with q the unit quaternion.
Eigen::Matrix<double, 3, 4> thetaByQuaternion(const Eigen::Quaterniond& unit, double norm) {
  Eigen::Matrix<double, 3, 4> T;
  T.leftCols<3>() = unit.w() * Eigen::Matrix3d::Identity() + skew(unit.vec());
  T.col(3) = -unit.vec();
  return (2.0 / norm) * T;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// NavStateParameters
// ---------------------------------------------------------------------------------------------------------

NavStateParameters NavStateParameters::fromNavState(const NavState& state) {
  NavStateParameters p;
  Eigen::Quaterniond q(state.T_world_body.linear());
  q.normalize();
  Eigen::Map<Eigen::Vector4d>(p.q_world_body.data()) = q.coeffs();
  Eigen::Map<Eigen::Vector3d>(p.p_world_body.data()) = state.T_world_body.translation();
  Eigen::Map<Eigen::Vector3d>(p.v_world.data()) = state.v_world_mps;
  Eigen::Map<Eigen::Vector3d>(p.gyro_bias.data()) = state.gyro_bias_radps;
  Eigen::Map<Eigen::Vector3d>(p.accel_bias.data()) = state.accel_bias_mps2;
  return p;
}

NavState NavStateParameters::toNavState(double timestamp_s) const {
  NavState s;
  s.timestamp_s = timestamp_s;
  const Eigen::Quaterniond q =
      Eigen::Quaterniond(Eigen::Map<const Eigen::Vector4d>(q_world_body.data())).normalized();
  s.T_world_body.linear() = q.toRotationMatrix();
  s.T_world_body.translation() = Eigen::Map<const Eigen::Vector3d>(p_world_body.data());
  s.v_world_mps = Eigen::Map<const Eigen::Vector3d>(v_world.data());
  s.gyro_bias_radps = Eigen::Map<const Eigen::Vector3d>(gyro_bias.data());
  s.accel_bias_mps2 = Eigen::Map<const Eigen::Vector3d>(accel_bias.data());
  return s;
}

void NavStateParameters::addParameterBlocks(ceres::Problem* problem, ceres::Manifold* quaternion_manifold) {
  problem->AddParameterBlock(q_world_body.data(), 4, quaternion_manifold);
  problem->AddParameterBlock(p_world_body.data(), 3);
  problem->AddParameterBlock(v_world.data(), 3);
  problem->AddParameterBlock(gyro_bias.data(), 3);
  problem->AddParameterBlock(accel_bias.data(), 3);
}

// ---------------------------------------------------------------------------------------------------------
// ImuFactor
// ---------------------------------------------------------------------------------------------------------

ImuFactor::ImuFactor(std::shared_ptr<const ImuPreintegration> preintegration,
                     const Eigen::Vector3d& gravity_world_mps2)
    : preintegration_(std::move(preintegration)), gravity_world_mps2_(gravity_world_mps2) {
  if (!preintegration_) throw std::invalid_argument("ImuFactor: null preintegration");
  if (!gravity_world_mps2.allFinite()) throw std::invalid_argument("ImuFactor: gravity is not finite");
  whitening_ =
      whiteningFromCovariance<9>(preintegration_->preintegrationCovariance(),
                                 "ImuFactor: the preintegration covariance (zero IMU noise densities?)");
}

std::vector<double*> ImuFactor::parameterBlocks(NavStateParameters* i, NavStateParameters* j) {
  return {i->q_world_body.data(), i->p_world_body.data(), i->v_world.data(),      i->gyro_bias.data(),
          i->accel_bias.data(),   j->q_world_body.data(), j->p_world_body.data(), j->v_world.data()};
}

bool ImuFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  Eigen::Quaterniond q_i, q_j;
  double norm_i, norm_j;
  if (!readQuaternion(parameters[0], &q_i, &norm_i) || !readQuaternion(parameters[5], &q_j, &norm_j))
    return false;
  const Eigen::Map<const Eigen::Vector3d> p_i(parameters[1]), v_i(parameters[2]), bg_i(parameters[3]),
      ba_i(parameters[4]), p_j(parameters[6]), v_j(parameters[7]);
  const ImuPreintegration& pre = *preintegration_;
  const Eigen::Vector3d& g = gravity_world_mps2_;
  const double dt = pre.deltaTime_s();
  const Eigen::Matrix3d R_i = q_i.toRotationMatrix(), R_j = q_j.toRotationMatrix();
  const Eigen::Matrix3d Rt_i = R_i.transpose();

  // First-order bias correction of the deltas to (bg_i, ba_i).
  const Eigen::Vector3d dbg = bg_i - pre.linearizationBias().gyro_radps;
  const Eigen::Vector3d dba = ba_i - pre.linearizationBias().accel_mps2;
  const Eigen::Vector3d phi_bg = pre.dR_dbg() * dbg;
  const Eigen::Matrix3d dR = pre.deltaR() * expSO3(phi_bg);
  const Eigen::Vector3d dv = pre.deltaV_mps() + pre.dV_dbg() * dbg + pre.dV_dba() * dba;
  const Eigen::Vector3d dp = pre.deltaP_m() + pre.dP_dbg() * dbg + pre.dP_dba() * dba;

  const Eigen::Vector3d dv_world = v_j - v_i - g * dt;
  const Eigen::Vector3d dp_world = p_j - p_i - v_i * dt - 0.5 * g * dt * dt;
  Eigen::Matrix<double, 9, 1> r;
  const Eigen::Matrix3d E = dR.transpose() * Rt_i * R_j;
  const Eigen::Vector3d r_R = logSO3(E);
  r.segment<3>(0) = r_R;
  r.segment<3>(3) = Rt_i * dv_world - dv;
  r.segment<3>(6) = Rt_i * dp_world - dp;
  out<Eigen::Matrix<double, 9, 1>>(residuals) = whitening_ * r;
  if (!jacobians) return true;

  // Unwhitened Jacobians; rotations w.r.t. world-frame perturbations R <- Exp(theta) R:
  //   d r_R / d theta_i = -Jr^-1(r_R) R_j^T        d r_R / d theta_j = Jr^-1(r_R) R_j^T
  //   d r_v / d theta_i = R_i^T [dv_world]x        d r_p / d theta_i = R_i^T [dp_world]x
  //   d r_R / d bg = -Jr^-1(r_R) E^T Jr(dR/dbg dbg) dR/dbg
  //   d r_v / d v_i = -R_i^T, d r_v / d v_j = R_i^T, d r_p / d p_i = -R_i^T, d r_p / d p_j = R_i^T,
  //   d r_p / d v_i = -R_i^T dt, d r_v,p / d b = -(bias Jacobian of the delta).
  const Eigen::Matrix3d Jr_inv = rightJacobianInverseSO3(r_R);
  using Matrix93 = Eigen::Matrix<double, 9, 3>;
  using Matrix94 = Eigen::Matrix<double, 9, 4, Eigen::RowMajor>;
  using Matrix93R = Eigen::Matrix<double, 9, 3, Eigen::RowMajor>;
  if (jacobians[0]) {
    Matrix93 J;
    J.block<3, 3>(0, 0) = -Jr_inv * R_j.transpose();
    J.block<3, 3>(3, 0) = Rt_i * skew(dv_world);
    J.block<3, 3>(6, 0) = Rt_i * skew(dp_world);
    out<Matrix94>(jacobians[0]) = whitening_ * J * thetaByQuaternion(q_i, norm_i);
  }
  if (jacobians[1]) {
    Matrix93 J = Matrix93::Zero();
    J.block<3, 3>(6, 0) = -Rt_i;
    out<Matrix93R>(jacobians[1]) = whitening_ * J;
  }
  if (jacobians[2]) {
    Matrix93 J = Matrix93::Zero();
    J.block<3, 3>(3, 0) = -Rt_i;
    J.block<3, 3>(6, 0) = -Rt_i * dt;
    out<Matrix93R>(jacobians[2]) = whitening_ * J;
  }
  if (jacobians[3]) {
    Matrix93 J;
    J.block<3, 3>(0, 0) = -Jr_inv * E.transpose() * rightJacobianSO3(phi_bg) * pre.dR_dbg();
    J.block<3, 3>(3, 0) = -pre.dV_dbg();
    J.block<3, 3>(6, 0) = -pre.dP_dbg();
    out<Matrix93R>(jacobians[3]) = whitening_ * J;
  }
  if (jacobians[4]) {
    Matrix93 J;
    J.block<3, 3>(0, 0).setZero();
    J.block<3, 3>(3, 0) = -pre.dV_dba();
    J.block<3, 3>(6, 0) = -pre.dP_dba();
    out<Matrix93R>(jacobians[4]) = whitening_ * J;
  }
  if (jacobians[5]) {
    Matrix93 J = Matrix93::Zero();
    J.block<3, 3>(0, 0) = Jr_inv * R_j.transpose();
    out<Matrix94>(jacobians[5]) = whitening_ * J * thetaByQuaternion(q_j, norm_j);
  }
  if (jacobians[6]) {
    Matrix93 J = Matrix93::Zero();
    J.block<3, 3>(6, 0) = Rt_i;
    out<Matrix93R>(jacobians[6]) = whitening_ * J;
  }
  if (jacobians[7]) {
    Matrix93 J = Matrix93::Zero();
    J.block<3, 3>(3, 0) = Rt_i;
    out<Matrix93R>(jacobians[7]) = whitening_ * J;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------------------
// BiasRandomWalkFactor
// ---------------------------------------------------------------------------------------------------------

namespace {
Eigen::Matrix<double, 6, 6> randomWalkCovariance(const ImuNoiseParams& noise, double dt_s) {
  validate(noise);
  if (!std::isfinite(dt_s) || !(dt_s > 0.0))
    throw std::invalid_argument("BiasRandomWalkFactor: dt_s must be finite and > 0");
  if (!(noise.gyro_random_walk_radps2_per_sqrt_hz > 0.0) || !(noise.accel_random_walk_mps3_per_sqrt_hz > 0.0))
    throw std::invalid_argument("BiasRandomWalkFactor: both bias random walk densities must be > 0");
  Eigen::Matrix<double, 6, 1> d;
  d << Eigen::Vector3d::Constant(std::pow(noise.gyro_random_walk_radps2_per_sqrt_hz, 2) * dt_s),
      Eigen::Vector3d::Constant(std::pow(noise.accel_random_walk_mps3_per_sqrt_hz, 2) * dt_s);
  return d.asDiagonal();
}
}  // namespace

BiasRandomWalkFactor::BiasRandomWalkFactor(const ImuNoiseParams& noise, double dt_s)
    : BiasRandomWalkFactor(randomWalkCovariance(noise, dt_s)) {}

BiasRandomWalkFactor::BiasRandomWalkFactor(const Eigen::Matrix<double, 6, 6>& covariance)
    : whitening_(whiteningFromCovariance<6>(covariance, "BiasRandomWalkFactor: the covariance")) {}

std::vector<double*> BiasRandomWalkFactor::parameterBlocks(NavStateParameters* i, NavStateParameters* j) {
  return {i->gyro_bias.data(), i->accel_bias.data(), j->gyro_bias.data(), j->accel_bias.data()};
}

bool BiasRandomWalkFactor::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  Eigen::Matrix<double, 6, 1> r;
  for (int k = 0; k < 3; ++k) {
    r[k] = parameters[2][k] - parameters[0][k];
    r[3 + k] = parameters[3][k] - parameters[1][k];
  }
  out<Eigen::Matrix<double, 6, 1>>(residuals) = whitening_ * r;
  if (!jacobians) return true;
  using Matrix63R = Eigen::Matrix<double, 6, 3, Eigen::RowMajor>;
  // d r / d bg_i = -[I; 0], d r / d ba_i = -[0; I], d r / d bg_j = [I; 0], d r / d ba_j = [0; I].
  if (jacobians[0]) out<Matrix63R>(jacobians[0]) = -whitening_.leftCols<3>();
  if (jacobians[1]) out<Matrix63R>(jacobians[1]) = -whitening_.rightCols<3>();
  if (jacobians[2]) out<Matrix63R>(jacobians[2]) = whitening_.leftCols<3>();
  if (jacobians[3]) out<Matrix63R>(jacobians[3]) = whitening_.rightCols<3>();
  return true;
}

// ---------------------------------------------------------------------------------------------------------
// NavStatePriorFactor
// ---------------------------------------------------------------------------------------------------------

NavStatePriorFactor::NavStatePriorFactor(const NavState& prior, const Matrix15d& information) {
  if (!isFinite(prior)) throw std::invalid_argument("NavStatePriorFactor: the prior state is not finite");
  Eigen::Quaterniond q(prior.T_world_body.linear());
  q.normalize();
  R_prior_ = q.toRotationMatrix();
  p_prior_ = prior.T_world_body.translation();
  v_prior_ = prior.v_world_mps;
  bg_prior_ = prior.gyro_bias_radps;
  ba_prior_ = prior.accel_bias_mps2;
  // information = L L^T  ->  W = L^T, W^T W = information.
  whitening_ = choleskyLower<15>(information, "NavStatePriorFactor: the information matrix").transpose();
}

std::vector<double*> NavStatePriorFactor::parameterBlocks(NavStateParameters* s) {
  return {s->q_world_body.data(), s->p_world_body.data(), s->v_world.data(), s->gyro_bias.data(),
          s->accel_bias.data()};
}

bool NavStatePriorFactor::Evaluate(double const* const* parameters, double* residuals,
                                   double** jacobians) const {
  Eigen::Quaterniond q;
  double norm;
  if (!readQuaternion(parameters[0], &q, &norm)) return false;
  const Eigen::Matrix3d R = q.toRotationMatrix();
  Eigen::Matrix<double, 15, 1> r;
  const Eigen::Vector3d r_R = logSO3(R_prior_.transpose() * R);
  r.segment<3>(0) = r_R;
  r.segment<3>(3) = Eigen::Map<const Eigen::Vector3d>(parameters[1]) - p_prior_;
  r.segment<3>(6) = Eigen::Map<const Eigen::Vector3d>(parameters[2]) - v_prior_;
  r.segment<3>(9) = Eigen::Map<const Eigen::Vector3d>(parameters[3]) - bg_prior_;
  r.segment<3>(12) = Eigen::Map<const Eigen::Vector3d>(parameters[4]) - ba_prior_;
  out<Eigen::Matrix<double, 15, 1>>(residuals) = whitening_ * r;
  if (!jacobians) return true;
  // d r_R / d theta = Jr^-1(r_R) R^T (R <- Exp(theta) R = R Exp(R^T theta)); the other blocks are identities.
  using Matrix15x3R = Eigen::Matrix<double, 15, 3, Eigen::RowMajor>;
  using Matrix15x4R = Eigen::Matrix<double, 15, 4, Eigen::RowMajor>;
  if (jacobians[0]) {
    const Eigen::Matrix3d J_theta = rightJacobianInverseSO3(r_R) * R.transpose();
    out<Matrix15x4R>(jacobians[0]) = whitening_.leftCols<3>() * J_theta * thetaByQuaternion(q, norm);
  }
  for (int b = 1; b < 5; ++b)
    if (jacobians[b]) out<Matrix15x3R>(jacobians[b]) = whitening_.middleCols<3>(3 * b);
  return true;
}

}  // namespace planetary_vo
