#include "planetary_vo/vo/motion_filter.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "planetary_vo/fusion/imu_preintegration.h"  // skew, expSO3, logSO3

namespace planetary_vo {

namespace {

using Matrix15d = Eigen::Matrix<double, 15, 15>;

/// The piecewise-constant random acceleration over dt: the [position, velocity] block of the process noise.
void addProcessNoise(double sigma, double dt, int pos, int vel, Matrix15d* P) {
  const double q = sigma * sigma;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  P->block<3, 3>(pos, pos) += q * dt * dt * dt * dt / 4.0 * I;
  P->block<3, 3>(pos, vel) += q * dt * dt * dt / 2.0 * I;
  P->block<3, 3>(vel, pos) += q * dt * dt * dt / 2.0 * I;
  P->block<3, 3>(vel, vel) += q * dt * dt * I;
}

/// The piecewise-constant random jerk over dt: the [position, velocity, acceleration] blocks (0, 6, 12).
void addJerkNoise(double sigma, double dt, Matrix15d* P) {
  const double q = sigma * sigma;
  const double g[3] = {dt * dt * dt / 6.0, dt * dt / 2.0, dt};
  const int at[3] = {0, 6, 12};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) P->block<3, 3>(at[i], at[j]) += q * g[i] * g[j] * Eigen::Matrix3d::Identity();
}

}  // namespace

PoseMeasurement poseMeasurement(double timestamp_s, const Pose& T_world_cam,
                                const std::vector<Eigen::Vector3d>& p_world,
                                const std::vector<Eigen::Vector2d>& px,
                                const std::vector<unsigned char>& inlier, double fx, double fy, double cx,
                                double cy, double min_pixel_sigma_px, std::vector<double>* depth_scratch) {
  if (p_world.size() != px.size() || (!inlier.empty() && inlier.size() != px.size()))
    throw std::invalid_argument("poseMeasurement: p_world, px and inlier differ in size");
  PoseMeasurement m;
  m.timestamp_s = timestamp_s;
  m.T_world_cam = T_world_cam;
  const Eigen::Matrix3d R_cam_world = T_world_cam.linear().transpose();
  const Eigen::Vector3d c = T_world_cam.translation();
  Matrix6d JtJ = Matrix6d::Zero();
  double sum_sq = 0.0;
  std::vector<double> local_depths;
  std::vector<double>& depths = depth_scratch ? *depth_scratch : local_depths;
  depths.clear();
  for (size_t i = 0; i < p_world.size(); ++i) {
    if (!inlier.empty() && inlier[i] == 0) continue;
    const Eigen::Vector3d d_world = p_world[i] - c;
    const Eigen::Vector3d p = R_cam_world * d_world;
    if (!(p.z() > 0.0)) continue;
    const double iz = 1.0 / p.z();
    const Eigen::Vector2d predicted(fx * p.x() * iz + cx, fy * p.y() * iz + cy);
    sum_sq += (predicted - px[i]).squaredNorm();
    Eigen::Matrix<double, 2, 3> J_proj;
    J_proj << fx * iz, 0.0, -fx * p.x() * iz * iz, 0.0, fy * iz, -fy * p.y() * iz * iz;
    // p_cam = R^T (X - c) with R = Exp(dtheta) R_est, c = c_est + dc.
    Eigen::Matrix<double, 3, 6> J_p;
    J_p.leftCols<3>() = -R_cam_world;
    J_p.rightCols<3>() = R_cam_world * skew(d_world);
    const Eigen::Matrix<double, 2, 6> J = J_proj * J_p;
    JtJ.noalias() += J.transpose() * J;
    depths.push_back(p.z());
  }
  const int n = static_cast<int>(depths.size());
  if (n < 3) return m;
  std::nth_element(depths.begin(), depths.begin() + n / 2, depths.end());
  m.median_depth = depths[static_cast<size_t>(n / 2)];
  // RMS of the 2n residuals' components, with the 6 degrees of freedom of the pose taken out.
  const double dof = std::max(1, 2 * n - 6);
  m.pixel_sigma_px = std::max(min_pixel_sigma_px, std::sqrt(sum_sq / dof));
  m.information = JtJ / (m.pixel_sigma_px * m.pixel_sigma_px);
  const Eigen::LDLT<Matrix6d> ldlt(m.information);
  m.valid = ldlt.info() == Eigen::Success && ldlt.isPositive() && (ldlt.vectorD().array() > 0.0).all();
  if (m.valid) {
    const Matrix6d cov = ldlt.solve(Matrix6d::Identity());
    m.covariance = 0.5 * (cov + cov.transpose());
  }
  return m;
}

MotionFilter::MotionFilter(const MotionFilterConfig& config) : config_(config) {}

void MotionFilter::reset() {
  num_updates_ = 0;
  last_gated_ = false;
}

void MotionFilter::restartPose(const PoseMeasurement& m) {
  c_world_ = m.T_world_cam.translation();
  R_world_cam_ = m.T_world_cam.linear();
  P_.topRows<6>().setZero();
  P_.leftCols<6>().setZero();
  P_.topLeftCorner<6, 6>() = m.covariance;
}

void MotionFilter::startFromTwo(const PoseMeasurement& m, double dt) {
  // The rates from last_ and m, their covariance from the two measurements'.
  restartPose(m);
  v_world_ = (m.T_world_cam.translation() - last_.T_world_cam.translation()) / dt;
  omega_world_ = logSO3(m.T_world_cam.linear() * last_.T_world_cam.linear().transpose()) / dt;
  P_.block<6, 6>(6, 6) = (last_.covariance + m.covariance) / (dt * dt);
  P_.block<6, 6>(6, 0) = m.covariance / dt;
  P_.block<6, 6>(0, 6) = m.covariance / dt;
  // The acceleration starts at zero, as uncertain as a braking lander's (constant velocity: zero, and fixed).
  a_world_.setZero();
  P_.middleRows<3>(12).setZero();
  P_.middleCols<3>(12).setZero();
  if (config_.constant_acceleration) {
    const double sigma = config_.initial_accel_sigma_ratio_per_s * v_world_.norm();
    P_.block<3, 3>(12, 12) = sigma * sigma * Eigen::Matrix3d::Identity();
  }
}

void MotionFilter::moveWithMap(const Pose& T_new_old) {
  if (num_updates_ == 0) return;
  const Eigen::Matrix3d R = T_new_old.linear();
  c_world_ = T_new_old * c_world_;
  R_world_cam_ = R * R_world_cam_;
  v_world_ = R * v_world_;
  omega_world_ = R * omega_world_;
  a_world_ = R * a_world_;
  // Every error state is a world-frame vector (the attitude error too: R_true = Exp(dtheta) R_est).
  Matrix15d G = Matrix15d::Zero();
  for (int b = 0; b < 5; ++b) G.block<3, 3>(3 * b, 3 * b) = R;
  P_ = G * P_ * G.transpose();
  // The last measurement moves along (the rates start from it after a rejection).
  const Matrix6d G6 = G.topLeftCorner<6, 6>();
  last_.T_world_cam = T_new_old * last_.T_world_cam;
  last_.covariance = G6 * last_.covariance * G6.transpose();
  last_.information = G6 * last_.information * G6.transpose();
}

FilteredMotion MotionFilter::motion() const {
  FilteredMotion out;
  out.valid = true;
  out.v_world = v_world_;
  out.v_covariance = P_.block<3, 3>(6, 6);
  out.omega_world = omega_world_;
  out.omega_covariance = P_.block<3, 3>(9, 9);
  out.a_world = a_world_;
  return out;
}

FilteredPose MotionFilter::update(const PoseMeasurement& m) {
  if (!m.valid) throw std::invalid_argument("MotionFilter::update: invalid measurement");
  FilteredPose out;
  out.T_world_cam = m.T_world_cam;
  if (num_updates_ > 0 && (m.timestamp_s <= t_s_ || m.timestamp_s - t_s_ > config_.max_gap_s)) reset();
  const double dt = m.timestamp_s - t_s_;
  t_s_ = m.timestamp_s;
  if (num_updates_ < 2) {
    if (num_updates_ == 1) startFromTwo(m, dt);
    ++num_updates_;
    last_ = m;
    return out;
  }

  // Predict: constant velocity (or acceleration) and rate.
  c_world_ += v_world_ * dt + 0.5 * dt * dt * a_world_;
  v_world_ += dt * a_world_;
  R_world_cam_ = expSO3(omega_world_ * dt) * R_world_cam_;
  Matrix15d F = Matrix15d::Identity();
  F.block<3, 3>(0, 6) = dt * Eigen::Matrix3d::Identity();
  F.block<3, 3>(3, 9) = dt * Eigen::Matrix3d::Identity();
  if (config_.constant_acceleration) {
    F.block<3, 3>(0, 12) = 0.5 * dt * dt * Eigen::Matrix3d::Identity();
    F.block<3, 3>(6, 12) = dt * Eigen::Matrix3d::Identity();
  }
  P_ = F * P_ * F.transpose();
  // A turn rotates the velocity at the angular rate (a car's, a slewing lander's thrust): its acceleration is
  // |omega| |v|, on top of the random one.
  const double accel_sigma =
      std::max((config_.accel_sigma_ratio_per_s + omega_world_.norm()) * v_world_.norm(),
               config_.min_accel_sigma_depth_ratio * m.median_depth);
  addProcessNoise(accel_sigma, dt, 0, 6, &P_);
  addProcessNoise(config_.angular_accel_sigma_dps2 * M_PI / 180.0, dt, 3, 9, &P_);
  if (config_.constant_acceleration) addJerkNoise(config_.jerk_sigma_ratio_per_s2 * v_world_.norm(), dt, &P_);

  // Update with the frame's pose.
  Eigen::Matrix<double, 6, 1> y;
  y.head<3>() = m.T_world_cam.translation() - c_world_;
  y.tail<3>() = logSO3(m.T_world_cam.linear() * R_world_cam_.transpose());
  const Eigen::LDLT<Matrix6d> S_ldlt(P_.topLeftCorner<6, 6>() + m.covariance);
  out.nis = y.dot(S_ldlt.solve(y));
  if (!std::isfinite(out.nis) || out.nis > config_.gate_nis) {
    // The prediction does not explain the frame: the frame's pose as it is. The rates are kept (a map that
    // moved as a whole leaves them right) but made as uncertain as two frames make them, so that the next
    // frames correct them if the motion changed (a jolt, a turn). A second rejection in a row says the rates
    // themselves are wrong (they would never be corrected, every frame rejected): they start again from this
    // frame and the last one. (Vision + altimeter, main_brake_down 512 ideal: an acceleration misjudged at
    // the start, 150 m/s^2, kept the filter rejecting every frame for 11 s, its velocity 1500 m/s off.)
    if (last_gated_) {
      startFromTwo(m, dt);
    } else {
      const Eigen::Matrix<double, 9, 9> rates_cov = P_.bottomRightCorner<9, 9>();
      restartPose(m);
      P_.bottomRightCorner<9, 9>() = rates_cov;
      P_.block<6, 6>(6, 6) += (last_.covariance + m.covariance) / (dt * dt);
    }
    last_gated_ = true;
    last_ = m;
    out.gated = true;
    out.motion = motion();
    return out;
  }
  last_ = m;
  last_gated_ = false;
  const Eigen::Matrix<double, 15, 6> K = S_ldlt.solve(P_.topRows<6>()).transpose();
  const Eigen::Matrix<double, 15, 1> dx = K * y;
  c_world_ += dx.segment<3>(0);
  R_world_cam_ = expSO3(dx.segment<3>(3)) * R_world_cam_;
  v_world_ += dx.segment<3>(6);
  omega_world_ += dx.segment<3>(9);
  a_world_ += dx.segment<3>(12);
  // Joseph form.
  Matrix15d IKH = Matrix15d::Identity();
  IKH.leftCols<6>() -= K;
  P_ = IKH * P_ * IKH.transpose() + K * m.covariance * K.transpose();
  P_ = 0.5 * (P_ + P_.transpose()).eval();

  // Re-orthonormalise the attitude.
  R_world_cam_ = Eigen::Quaterniond(R_world_cam_).normalized().toRotationMatrix();
  out.T_world_cam = Pose::Identity();
  out.T_world_cam.linear() = R_world_cam_;
  out.T_world_cam.translation() = c_world_;
  out.motion = motion();
  out.filtered = true;
  return out;
}

}  // namespace planetary_vo
