#pragma once
/// @file inertial_factors.h
/// Ceres cost functions of the inertial navigation problem, with analytic Jacobians:
///  - ImuFactor: the preintegrated IMU measurement between keyframe states i and j (residual 9);
///  - BiasRandomWalkFactor: the bias random walk between consecutive bias blocks (residual 6);
///  - NavStatePriorFactor: a prior on a full NavState, e.g. the initial state handed over by guidance (15).
///
/// Parameter blocks of one state (NavStateParameters): q_world_body (4, Eigen coefficient order x, y, z, w,
/// to be used with ceres::EigenQuaternionManifold as in vo/bundle_adjuster.cpp), p_world_body (3, m), v_world
/// (3, m/s), gyro_bias (3, rad/s), accel_bias (3, m/s^2); frames and gravity as in nav_state.h.
///
/// Residual conventions (the equations and Jacobians are derived in docs/fusion/imu_preintegration.md):
/// rotation errors are right-perturbation rotation vectors, e.g. Log(R_prior^T R) (body frame). Every
/// residual is whitened: r_w = W r with W^T W = covariance^-1 (W the inverse of the lower Cholesky factor
/// of the covariance), so the cost 0.5 |r_w|^2 is 0.5 chi^2.
///
/// Jacobians: analytic, w.r.t. the ambient parameters. For the quaternion the Jacobian is the exact
/// derivative of the residual of the NORMALISED quaternion (the residuals normalise q), i.e.
/// d r / d q = d r / d theta * 2 [q_w I + [q_v]x, -q_v] / |q| for a world-frame rotation perturbation theta
/// (R <- Exp(theta) R); it is orthogonal to q, so it composes correctly with any quaternion manifold.
/// Cost: ImuFactor ~2.5 us per evaluation with all Jacobians (measured in test_inertial_factors, Release).
///
/// Contract: constructors throw std::invalid_argument for a covariance / information that is not finite,
/// symmetric-positive-definite (e.g. an ImuPreintegration built with zero noise densities), a non-finite
/// gravity, a non-positive or non-finite dt. Evaluate() returns false (Ceres then rejects the step) only for
/// a zero quaternion.

#include <array>
#include <memory>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Core>

#include "planetary_vo/fusion/imu_preintegration.h"
#include "planetary_vo/fusion/nav_state.h"

namespace planetary_vo {

/// The Ceres parameter blocks of one NavState. The storage must outlive the ceres::Problem that uses it.
struct NavStateParameters {
  std::array<double, 4> q_world_body{0.0, 0.0, 0.0, 1.0};  ///< x, y, z, w (Eigen coefficient order)
  std::array<double, 3> p_world_body{};
  std::array<double, 3> v_world{};
  std::array<double, 3> gyro_bias{};
  std::array<double, 3> accel_bias{};

  static NavStateParameters fromNavState(const NavState& state);
  /// The state these blocks hold (the quaternion normalised), stamped timestamp_s.
  NavState toNavState(double timestamp_s) const;
  /// Adds the five blocks to `problem`, the quaternion with `quaternion_manifold` (normally a
  /// ceres::EigenQuaternionManifold; ownership follows the problem's options).
  void addParameterBlocks(ceres::Problem* problem, ceres::Manifold* quaternion_manifold);
};

/// Preintegrated IMU factor between states i and j. Parameter blocks, in order:
/// q_i (4), p_i (3), v_i (3), bg_i (3), ba_i (3), q_j (4), p_j (3), v_j (3). The residual is
/// W [r_R, r_v, r_p] of ImuPreintegration::residual(): the deltas are bias-corrected to first order to
/// (bg_i, ba_i); W whitens with the preintegration covariance (the 9x9 block, read at construction). The
/// biases of j are tied to those of i by a BiasRandomWalkFactor.
///
/// The factor keeps a shared pointer to the preintegration: after preintegration->repropagate() (never
/// during a solve) build a new factor, since W is cached.
class ImuFactor final : public ceres::SizedCostFunction<9, 4, 3, 3, 3, 3, 4, 3, 3> {
 public:
  ImuFactor(std::shared_ptr<const ImuPreintegration> preintegration,
            const Eigen::Vector3d& gravity_world_mps2);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

  /// The parameter block pointers of states i and j in the order above, for ceres::Problem::AddResidualBlock.
  static std::vector<double*> parameterBlocks(NavStateParameters* state_i, NavStateParameters* state_j);

  const ImuPreintegration& preintegration() const { return *preintegration_; }
  const Eigen::Matrix<double, 9, 9>& whitening() const { return whitening_; }

 private:
  std::shared_ptr<const ImuPreintegration> preintegration_;
  Eigen::Vector3d gravity_world_mps2_;
  Eigen::Matrix<double, 9, 9> whitening_;
};

/// Bias random walk between consecutive bias blocks: residual W [bg_j - bg_i, ba_j - ba_i] with covariance
/// diag(sigma_bg^2 I, sigma_ba^2 I) * dt (ImuPreintegration::biasRandomWalkCovariance()). Parameter blocks,
/// in order: bg_i (3), ba_i (3), bg_j (3), ba_j (3).
class BiasRandomWalkFactor final : public ceres::SizedCostFunction<6, 3, 3, 3, 3> {
 public:
  /// From the random-walk densities of `noise` (both must be > 0) over dt_s > 0.
  BiasRandomWalkFactor(const ImuNoiseParams& noise, double dt_s);
  /// From a 6x6 covariance of [dbg, dba] (symmetric positive definite).
  explicit BiasRandomWalkFactor(const Eigen::Matrix<double, 6, 6>& covariance);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

  static std::vector<double*> parameterBlocks(NavStateParameters* state_i, NavStateParameters* state_j);
  const Eigen::Matrix<double, 6, 6>& whitening() const { return whitening_; }

 private:
  Eigen::Matrix<double, 6, 6> whitening_;
};

/// Prior on a full NavState: residual W [Log(R_prior^T R), p - p_prior, v - v_prior, bg - bg_prior,
/// ba - ba_prior] (rotation error in the body frame, the others in the world / IMU frame), with
/// W^T W = information (15x15 in that order, symmetric positive definite). Parameter blocks, in order:
/// q (4), p (3), v (3), bg (3), ba (3).
class NavStatePriorFactor final : public ceres::SizedCostFunction<15, 4, 3, 3, 3, 3> {
 public:
  using Matrix15d = Eigen::Matrix<double, 15, 15>;
  NavStatePriorFactor(const NavState& prior, const Matrix15d& information);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

  static std::vector<double*> parameterBlocks(NavStateParameters* state);
  const Matrix15d& whitening() const { return whitening_; }

 private:
  Eigen::Matrix3d R_prior_;
  Eigen::Vector3d p_prior_, v_prior_, bg_prior_, ba_prior_;
  Matrix15d whitening_;
};

}  // namespace planetary_vo
