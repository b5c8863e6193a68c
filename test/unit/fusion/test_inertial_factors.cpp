/// Inertial Ceres factors (fusion/inertial_factors.h): analytic Jacobians against central differences (in the
/// ambient quaternion coordinates and on the EigenQuaternionManifold tangent space), zero residual at the
/// true states of a Lunar descent, whitening, and a small visual-inertial-like solve in which the factors
/// recover the IMU biases; then the constructors' contract.

#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <ceres/ceres.h>
#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "fusion_test_util.h"
#include "planetary_vo/fusion/imu_preintegration.h"
#include "planetary_vo/fusion/inertial_factors.h"
#include "planetary_vo/render/descent_trajectory.h"
#include "planetary_vo/sensors/imu_model.h"

namespace planetary_vo {
namespace {

constexpr double kRateHz = 200.0;
const Eigen::Vector3d kGravity = kLunarGravityWorldMps2;

/// The renderer's IMU (trajectory.imu(t) through the error model) on the 200 Hz grid over [t0, t1].
std::vector<ImuSample> simulateImu(const render::DescentTrajectory& trajectory, double t0, double t1,
                                   const sensors::ImuErrorParams& params, uint64_t seed, ImuBias* true_bias) {
  sensors::ImuErrorModel model(params, kRateHz, seed);
  std::vector<ImuSample> samples;
  for (int k = static_cast<int>(std::floor(t0 * kRateHz)); k <= static_cast<int>(std::ceil(t1 * kRateHz));
       ++k)
    samples.push_back(model.measure(trajectory.imu(k / kRateHz)));
  if (true_bias) *true_bias = {model.trueErrors().gyro_bias_radps, model.trueErrors().accel_bias_mps2};
  return samples;
}

/// The noise densities of the MEMS grade (what sensors.yaml would say), with the random walks.
ImuNoiseParams memsNoise() {
  const sensors::ImuErrorParams g = sensors::imuGrade("mems");
  ImuNoiseParams n;
  n.gyro_noise_density_radps_per_sqrt_hz = g.gyro.white_noise_density;
  n.accel_noise_density_mps2_per_sqrt_hz = g.accel.white_noise_density;
  n.gyro_random_walk_radps2_per_sqrt_hz = std::max(g.gyro.bias_random_walk, 1e-5);
  n.accel_random_walk_mps3_per_sqrt_hz = std::max(g.accel.bias_random_walk, 1e-4);
  return n;
}

/// A state moved away from `s` by a rotation of ~3 deg, decimetres, dm/s and bias changes (generic point).
NavState perturbed(const NavState& s, double scale) {
  NavState p = s;
  p.T_world_body.linear() = expSO3(scale * Eigen::Vector3d(0.03, -0.05, 0.02)) * s.T_world_body.linear();
  p.T_world_body.translation() += scale * Eigen::Vector3d(0.2, -0.1, 0.3);
  p.v_world_mps += scale * Eigen::Vector3d(-0.1, 0.2, 0.05);
  p.gyro_bias_radps += scale * Eigen::Vector3d(2e-3, -1e-3, 3e-3);
  p.accel_bias_mps2 += scale * Eigen::Vector3d(0.02, 0.03, -0.01);
  return p;
}

/// Evaluates `cost` at `blocks` and compares every analytic Jacobian block with central differences of the
/// residual: in the ambient coordinates (all blocks), and for 4-vectors also on the tangent space of
/// ceres::EigenQuaternionManifold (x (+) delta, the way the solver uses them). Returns the worst relative
/// error max |J_ana - J_num| / max(1, max |J_num|).
double worstJacobianError(const ceres::CostFunction& cost, std::vector<std::vector<double>> blocks) {
  const int m = cost.num_residuals();
  const std::vector<int32_t>& sizes = cost.parameter_block_sizes();
  std::vector<double*> ptrs;
  for (auto& b : blocks) ptrs.push_back(b.data());
  std::vector<std::vector<double>> jac(sizes.size());
  std::vector<double*> jac_ptrs;
  for (size_t b = 0; b < sizes.size(); ++b) {
    jac[b].assign(m * sizes[b], 0.0);
    jac_ptrs.push_back(jac[b].data());
  }
  Eigen::VectorXd r0(m);
  EXPECT_TRUE(cost.Evaluate(ptrs.data(), r0.data(), jac_ptrs.data()));
  const auto residual = [&]() {
    Eigen::VectorXd r(m);
    EXPECT_TRUE(cost.Evaluate(ptrs.data(), r.data(), nullptr));
    return r;
  };
  double worst = 0.0;
  const ceres::EigenQuaternionManifold manifold;
  for (size_t b = 0; b < sizes.size(); ++b) {
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
        jac[b].data(), m, sizes[b]);
    Eigen::MatrixXd J_num(m, sizes[b]);
    const std::vector<double> saved = blocks[b];
    for (int k = 0; k < sizes[b]; ++k) {
      const double h = 1e-6 * std::max(1.0, std::abs(saved[k]));
      blocks[b][k] = saved[k] + h;
      const Eigen::VectorXd rp = residual();
      blocks[b][k] = saved[k] - h;
      const Eigen::VectorXd rm = residual();
      blocks[b][k] = saved[k];
      J_num.col(k) = (rp - rm) / (2 * h);
    }
    worst = std::max(worst, (J - J_num).cwiseAbs().maxCoeff() / std::max(1.0, J_num.cwiseAbs().maxCoeff()));
    if (sizes[b] == 4) {
      // Tangent-space Jacobian: J * PlusJacobian against differences of r(x (+) delta).
      Eigen::Matrix<double, 4, 3, Eigen::RowMajor> plus_jacobian;
      manifold.PlusJacobian(saved.data(), plus_jacobian.data());
      const Eigen::MatrixXd J_local = J * plus_jacobian;
      Eigen::MatrixXd J_local_num(m, 3);
      for (int k = 0; k < 3; ++k) {
        const double h = 1e-6;
        Eigen::Vector3d delta = Eigen::Vector3d::Zero();
        delta[k] = h;
        manifold.Plus(saved.data(), delta.data(), blocks[b].data());
        const Eigen::VectorXd rp = residual();
        delta[k] = -h;
        manifold.Plus(saved.data(), delta.data(), blocks[b].data());
        const Eigen::VectorXd rm = residual();
        J_local_num.col(k) = (rp - rm) / (2 * h);
      }
      blocks[b] = saved;
      worst = std::max(worst, (J_local - J_local_num).cwiseAbs().maxCoeff() /
                                  std::max(1.0, J_local_num.cwiseAbs().maxCoeff()));
    }
  }
  return worst;
}

std::vector<std::vector<double>> imuBlocks(const NavState& i, const NavState& j) {
  NavStateParameters a = NavStateParameters::fromNavState(i), b = NavStateParameters::fromNavState(j);
  const auto v = [](const auto& arr) { return std::vector<double>(arr.begin(), arr.end()); };
  return {v(a.q_world_body), v(a.p_world_body), v(a.v_world),      v(a.gyro_bias),
          v(a.accel_bias),   v(b.q_world_body), v(b.p_world_body), v(b.v_world)};
}

struct Window {
  render::DescentTrajectory trajectory{render::TrajectoryPhase::kMainBrake,
                                       render::CameraMode::kPitchDownTo30};
  double t0 = 44.0, t1 = 45.0;
  ImuBias true_bias;
  std::vector<ImuSample> samples;
  std::shared_ptr<ImuPreintegration> pre;
};
/// Pitch manoeuvre, 1 s, MEMS turn-on biases, preintegrated at a bias 10 % off the truth (so that the bias
/// correction is exercised) with the MEMS noise densities.
Window pitchWindow() {
  Window w;
  w.samples = simulateImu(w.trajectory, w.t0, w.t1, constantBiasOnly("mems"), 4, &w.true_bias);
  const ImuBias linearization{0.9 * w.true_bias.gyro_radps, 0.9 * w.true_bias.accel_mps2};
  w.pre = std::make_shared<ImuPreintegration>(w.samples, w.t0, w.t1, linearization, memsNoise());
  return w;
}

// ---------------------------------------------------------------------------------------------------------
// Jacobians
// ---------------------------------------------------------------------------------------------------------

TEST(InertialFactors, ImuFactorJacobiansMatchNumericDifferentiation) {
  // At the true states and at generic perturbed ones (rotation residual of several degrees, so Jr^-1 is not
  // the identity; biases away from the linearisation point, so the bias correction's Jacobian is not
  // trivial), also with a non-unit quaternion. Central differences are accurate to ~1e-8 relative here; the
  // bound 1e-6 catches any wrong term (a Jacobian with Jr^-1 replaced by I is off by ~1e-2 relative).
  const Window w = pitchWindow();
  const ImuFactor factor(w.pre, kGravity);
  const NavState i = trueState(w.trajectory, w.t0, w.true_bias),
                 j = trueState(w.trajectory, w.t1, w.true_bias);
  double worst = worstJacobianError(factor, imuBlocks(i, j));
  for (const double scale : {1.0, 3.0}) {
    NavState pj = perturbed(j, -scale);
    pj.setBias(j.bias());
    worst = std::max(worst, worstJacobianError(factor, imuBlocks(perturbed(i, scale), pj)));
  }
  auto blocks = imuBlocks(perturbed(i, 1.0), perturbed(j, 2.0));
  for (double& c : blocks[0]) c *= 1.7;  // a non-unit quaternion: the factor normalises it
  worst = std::max(worst, worstJacobianError(factor, blocks));
  EXPECT_LT(worst, 1e-6);
  // Cost of one evaluation with all Jacobians (printed for the header's figure, not asserted).
  NavStateParameters a = NavStateParameters::fromNavState(i), b = NavStateParameters::fromNavState(j);
  const std::vector<double*> ptrs = ImuFactor::parameterBlocks(&a, &b);
  double r[9], J[8][36];
  double* jacobians[8] = {J[0], J[1], J[2], J[3], J[4], J[5], J[6], J[7]};
  const auto start = std::chrono::steady_clock::now();
  constexpr int kEvaluations = 20000;
  for (int k = 0; k < kEvaluations; ++k) factor.Evaluate(ptrs.data(), r, jacobians);
  const double us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count() /
      kEvaluations;
  std::printf("[ measured ] ImuFactor evaluation with Jacobians: %.2f us\n", us);
  std::printf("[ measured ] ImuFactor worst relative Jacobian error %.2e\n", worst);
}

TEST(InertialFactors, BiasAndPriorFactorJacobiansMatchNumericDifferentiation) {
  const ImuNoiseParams noise = memsNoise();
  const BiasRandomWalkFactor bias_factor(noise, 0.5);
  const std::vector<std::vector<double>> bias_blocks{
      {1e-3, -2e-3, 5e-4}, {0.1, -0.05, 0.02}, {2e-3, 1e-3, 0}, {0, 0.1, 0.3}};
  const double worst_bias = worstJacobianError(bias_factor, bias_blocks);
  EXPECT_LT(worst_bias, 1e-8);

  const Window w = pitchWindow();
  const NavState truth = trueState(w.trajectory, w.t0, w.true_bias);
  // A full information matrix (correlated), e.g. from guidance's covariance.
  Eigen::Matrix<double, 15, 15> A = Eigen::Matrix<double, 15, 15>::Random();
  const Eigen::Matrix<double, 15, 15> information =
      A * A.transpose() + 15 * Eigen::Matrix<double, 15, 15>::Identity();
  const NavStatePriorFactor prior(truth, information);
  NavStateParameters p = NavStateParameters::fromNavState(perturbed(truth, 2.0));
  const auto v = [](const auto& arr) { return std::vector<double>(arr.begin(), arr.end()); };
  const double worst_prior = worstJacobianError(
      prior, {v(p.q_world_body), v(p.p_world_body), v(p.v_world), v(p.gyro_bias), v(p.accel_bias)});
  EXPECT_LT(worst_prior, 1e-6);
  std::printf("[ measured ] worst relative Jacobian error: bias factor %.2e, prior %.2e\n", worst_bias,
              worst_prior);

  // Whitening: the cost is 0.5 r^T info r.
  NavStateParameters q = NavStateParameters::fromNavState(perturbed(truth, 0.1));
  const std::vector<double*> blocks = NavStatePriorFactor::parameterBlocks(&q);
  Eigen::Matrix<double, 15, 1> r;
  ASSERT_TRUE(prior.Evaluate(blocks.data(), r.data(), nullptr));
  const NavState s = q.toNavState(0.0);
  Eigen::Matrix<double, 15, 1> e;
  e << logSO3(truth.T_world_body.linear().transpose() * s.T_world_body.linear()),
      s.T_world_body.translation() - truth.T_world_body.translation(), s.v_world_mps - truth.v_world_mps,
      s.gyro_bias_radps - truth.gyro_bias_radps, s.accel_bias_mps2 - truth.accel_bias_mps2;
  EXPECT_NEAR(r.squaredNorm(), e.dot(information * e), 1e-9 * e.dot(information * e));
}

// ---------------------------------------------------------------------------------------------------------
// Residual at the truth
// ---------------------------------------------------------------------------------------------------------

TEST(InertialFactors, ResidualIsZeroAtTheTrueStatesOfADescent) {
  // At the true states of the pitch manoeuvre (1 s, MEMS turn-on biases): preintegrated AT the true bias,
  // the unwhitened residual is the integration scheme's error (measured ~5e-8 rad, ~2e-7 m/s and m; bounds
  // 5e-7 rad, 2e-6 m/s, 5e-6 m as in test_imu_preintegration). Preintegrated 10 % off the true bias and
  // corrected to it by the factor, the first-order remainder adds ~3e-5 m/s (bounds 1e-6 rad, 1e-4 m/s,
  // 5e-5 m); whitened by the MEMS covariance the residual stays far below 1 (chi^2 of 9 dof would be ~9
  // with real noise). Without the correction (the state's biases at the linearisation point) the residual
  // is ~1e-3 rad and ~2e-2 m/s, and with the wrong gravity sign ~3 m/s.
  const Window w = pitchWindow();
  const NavState i = trueState(w.trajectory, w.t0, w.true_bias),
                 j = trueState(w.trajectory, w.t1, w.true_bias);
  const ImuPreintegration at_truth(w.samples, w.t0, w.t1, w.true_bias, memsNoise());
  const Eigen::Matrix<double, 9, 1> exact = at_truth.residual(i, j, kGravity);
  EXPECT_LT(exact.segment<3>(0).norm(), 5e-7);
  EXPECT_LT(exact.segment<3>(3).norm(), 2e-6);
  EXPECT_LT(exact.segment<3>(6).norm(), 5e-6);

  const ImuFactor factor(w.pre, kGravity);
  const Eigen::Matrix<double, 9, 1> raw = w.pre->residual(i, j, kGravity);
  EXPECT_LT(raw.segment<3>(0).norm(), 1e-6);
  EXPECT_LT(raw.segment<3>(3).norm(), 1e-4);
  EXPECT_LT(raw.segment<3>(6).norm(), 5e-5);
  NavStateParameters a = NavStateParameters::fromNavState(i), b = NavStateParameters::fromNavState(j);
  const std::vector<double*> blocks = ImuFactor::parameterBlocks(&a, &b);
  Eigen::Matrix<double, 9, 1> whitened;
  ASSERT_TRUE(factor.Evaluate(blocks.data(), whitened.data(), nullptr));
  EXPECT_LT((whitened - factor.whitening() * raw).norm(), 1e-9 * std::max(1.0, whitened.norm()));
  EXPECT_LT(whitened.norm(), 0.1);
  std::printf(
      "[ measured ] residual at the truth: at the true bias %.2e rad, %.2e m/s, %.2e m; bias-corrected "
      "from 10 %% off %.2e rad, %.2e m/s, %.2e m; whitened norm %.2e\n",
      exact.segment<3>(0).norm(), exact.segment<3>(3).norm(), exact.segment<3>(6).norm(),
      raw.segment<3>(0).norm(), raw.segment<3>(3).norm(), raw.segment<3>(6).norm(), whitened.norm());

  NavState i_uncorrected = i;
  i_uncorrected.setBias(w.pre->linearizationBias());
  const Eigen::Matrix<double, 9, 1> uncorrected = w.pre->residual(i_uncorrected, j, kGravity);
  EXPECT_GT(uncorrected.segment<3>(0).norm(), 1e-4);
  EXPECT_GT(uncorrected.segment<3>(3).norm(), 1e-3);
  EXPECT_GT(w.pre->residual(i, j, -kGravity).segment<3>(3).norm(), 1.0);
}

// ---------------------------------------------------------------------------------------------------------
// A small solve
// ---------------------------------------------------------------------------------------------------------

TEST(InertialFactors, SolveRecoversStatesAndBiases) {
  // Five keyframes 0.5 s apart over the Main Brake pitch manoeuvre, MEMS turn-on biases, preintegrated at
  // zero bias. A full prior on keyframe 0 (true pose and velocity, biases unknown: 0 +- 0.05 rad/s, 0.5
  // m/s^2) and, standing in for vision, pose priors on the others (1 mrad, 1 cm; velocity and bias left free
  // with a negligible information). The solver starts from the states dead-reckoned with zero bias and must
  // recover the biases and velocities; only the bias correction inside the IMU factor can move the
  // biases. Measured: gyro bias error 3.9e-6 rad/s (of 1.6e-2), accel 3.0e-4 m/s^2 (of 0.11), velocity
  // 1.7e-4 m/s, position 1.5e-4 m, from 0.25 m off; bounds 5e-5 rad/s, 5e-3 m/s^2, 2 mm/s and 2 mm (>= 10x).
  // Without the bias correction in the factor the biases stay at zero (errors of 1e-2 and 0.1).
  const render::DescentTrajectory trajectory(render::TrajectoryPhase::kMainBrake,
                                             render::CameraMode::kPitchDownTo30);
  const double t0 = 42.0, dt = 0.5;
  const int n = 5;
  ImuBias true_bias;
  const std::vector<ImuSample> samples =
      simulateImu(trajectory, t0, t0 + (n - 1) * dt, constantBiasOnly("mems"), 21, &true_bias);
  const ImuNoiseParams noise = memsNoise();

  std::vector<NavState> truth;
  for (int k = 0; k < n; ++k) truth.push_back(trueState(trajectory, t0 + k * dt, true_bias));
  std::vector<std::shared_ptr<ImuPreintegration>> pre;
  for (int k = 0; k + 1 < n; ++k)
    pre.push_back(std::make_shared<ImuPreintegration>(samples, truth[k].timestamp_s, truth[k + 1].timestamp_s,
                                                      ImuBias{}, noise));
  // Initial guess: dead reckoning from the true first pose with zero bias.
  std::vector<NavStateParameters> x(n);
  NavState guess = truth[0];
  guess.setBias({});
  x[0] = NavStateParameters::fromNavState(guess);
  for (int k = 0; k + 1 < n; ++k) {
    guess = pre[k]->predict(guess, kGravity);
    x[k + 1] = NavStateParameters::fromNavState(guess);
  }
  const double initial_error =
      (guess.T_world_body.translation() - truth.back().T_world_body.translation()).norm();

  ceres::Problem::Options options;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(options);
  ceres::EigenQuaternionManifold manifold;
  for (auto& s : x) s.addParameterBlocks(&problem, &manifold);
  Eigen::Matrix<double, 15, 1> prior0;
  prior0 << Eigen::Vector3d::Constant(1e-8), Eigen::Vector3d::Constant(1e-8), Eigen::Vector3d::Constant(1e-8),
      Eigen::Vector3d::Constant(0.05 * 0.05), Eigen::Vector3d::Constant(0.25);
  NavState prior_state = truth[0];
  prior_state.setBias({});
  problem.AddResidualBlock(
      new NavStatePriorFactor(prior_state, prior0.cwiseInverse().asDiagonal().toDenseMatrix()), nullptr,
      NavStatePriorFactor::parameterBlocks(&x[0]));
  Eigen::Matrix<double, 15, 1> pose_prior;
  pose_prior << Eigen::Vector3d::Constant(1e-6), Eigen::Vector3d::Constant(1e-4),
      Eigen::Vector3d::Constant(1e6), Eigen::Vector3d::Constant(1e6), Eigen::Vector3d::Constant(1e6);
  for (int k = 1; k < n; ++k)
    problem.AddResidualBlock(
        new NavStatePriorFactor(truth[k], pose_prior.cwiseInverse().asDiagonal().toDenseMatrix()), nullptr,
        NavStatePriorFactor::parameterBlocks(&x[k]));
  for (int k = 0; k + 1 < n; ++k) {
    problem.AddResidualBlock(new ImuFactor(pre[k], kGravity), nullptr,
                             ImuFactor::parameterBlocks(&x[k], &x[k + 1]));
    problem.AddResidualBlock(new BiasRandomWalkFactor(pre[k]->biasRandomWalkCovariance()), nullptr,
                             BiasRandomWalkFactor::parameterBlocks(&x[k], &x[k + 1]));
  }
  ceres::Solver::Options solver_options;
  solver_options.max_num_iterations = 50;
  solver_options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();

  double worst_bg = 0, worst_ba = 0, worst_v = 0, worst_p = 0;
  for (int k = 0; k < n; ++k) {
    const NavState s = x[k].toNavState(truth[k].timestamp_s);
    worst_bg = std::max(worst_bg, (s.gyro_bias_radps - true_bias.gyro_radps).norm());
    worst_ba = std::max(worst_ba, (s.accel_bias_mps2 - true_bias.accel_mps2).norm());
    worst_v = std::max(worst_v, (s.v_world_mps - truth[k].v_world_mps).norm());
    worst_p = std::max(worst_p, (s.T_world_body.translation() - truth[k].T_world_body.translation()).norm());
  }
  EXPECT_LT(worst_bg, 5e-5);
  EXPECT_LT(worst_ba, 5e-3);
  EXPECT_LT(worst_v, 2e-3);
  EXPECT_LT(worst_p, 2e-3);
  EXPECT_GT(initial_error, 0.1) << "the dead-reckoned guess starts far off";
  std::printf(
      "[ measured ] solve (%d iterations): |bg| %.2e -> error %.2e rad/s, |ba| %.2e -> error %.2e m/s^2, "
      "velocity %.2e m/s, position %.2e m (start %.2e m)\n",
      static_cast<int>(summary.iterations.size()), true_bias.gyro_radps.norm(), worst_bg,
      true_bias.accel_mps2.norm(), worst_ba, worst_v, worst_p, initial_error);
}

// ---------------------------------------------------------------------------------------------------------
// Contract
// ---------------------------------------------------------------------------------------------------------

TEST(InertialFactors, ConstructorsRejectBadInput) {
  std::vector<ImuSample> samples;
  for (int k = 0; k <= 20; ++k)
    samples.push_back({k * 0.005, Eigen::Vector3d(0.01, 0, 0), Eigen::Vector3d(0, 0, 1.62)});
  const auto exact = std::make_shared<ImuPreintegration>(samples, 0.0, 0.1, ImuBias{}, ImuNoiseParams{});
  EXPECT_THROW(ImuFactor(exact, kGravity), std::invalid_argument)
      << "zero noise: no covariance to whiten with";
  const auto noisy = std::make_shared<ImuPreintegration>(samples, 0.0, 0.1, ImuBias{}, memsNoise());
  EXPECT_NO_THROW(ImuFactor(noisy, kGravity));
  EXPECT_THROW(ImuFactor(noisy, Eigen::Vector3d(0, 0, NAN)), std::invalid_argument);
  EXPECT_THROW(ImuFactor(nullptr, kGravity), std::invalid_argument);

  EXPECT_THROW(BiasRandomWalkFactor(memsNoise(), 0.0), std::invalid_argument);
  EXPECT_THROW(BiasRandomWalkFactor(ImuNoiseParams{}, 0.1), std::invalid_argument);
  EXPECT_THROW(BiasRandomWalkFactor(Eigen::Matrix<double, 6, 6>::Zero()), std::invalid_argument);

  Eigen::Matrix<double, 15, 15> info = Eigen::Matrix<double, 15, 15>::Identity();
  EXPECT_NO_THROW(NavStatePriorFactor(NavState{}, info));
  info(3, 3) = -1.0;
  EXPECT_THROW(NavStatePriorFactor(NavState{}, info), std::invalid_argument);
  info(3, 3) = 1.0;
  info(0, 5) = 0.5;  // not symmetric
  EXPECT_THROW(NavStatePriorFactor(NavState{}, info), std::invalid_argument);
  NavState bad;
  bad.v_world_mps.x() = NAN;
  EXPECT_THROW(NavStatePriorFactor(bad, Eigen::Matrix<double, 15, 15>::Identity()), std::invalid_argument);

  // A zero quaternion cannot be evaluated: Evaluate() returns false.
  const ImuFactor factor(noisy, kGravity);
  NavStateParameters a, b;
  a.q_world_body = {0, 0, 0, 0};
  const std::vector<double*> blocks = ImuFactor::parameterBlocks(&a, &b);
  double r[9];
  EXPECT_FALSE(factor.Evaluate(blocks.data(), r, nullptr));
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
