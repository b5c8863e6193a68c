/// The drift of a metric map as the navigation's covariance (vo/map_drift.h), against Monte Carlo draws of
/// the very error model it propagates: a map whose attitude walks at every keyframe and whose scale error is
/// correlated over a window of keyframes, flown along a descent. The NEES of the drawn errors under the
/// propagated covariance has its chi-square mean; without the propagation it is far above.

#include <cmath>
#include <iostream>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "planetary_vo/fusion/imu_preintegration.h"  // expSO3()
#include "planetary_vo/vo/map_drift.h"

namespace planetary_vo {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// A velocity measured against a map whose scale is off by a relative s and whose attitude is off by a small
// rotation theta is (1 + s) Exp(theta) v. Draws of both (1 %, 0.2 deg per axis) plus the filter's own error
// (0.05 m/s per axis) on a main-brake velocity (300 m/s, descending): with the drift's velocity covariance
// added the NEES has its chi-square mean (3); with the filter's covariance alone it is thousands (the map's
// error at 300 m/s is metres per second); with only the scale or only the attitude part, hundreds.
TEST(MapDrift, TheMapsScaleLiesAlongTheVelocityAndItsAttitudeAcrossIt) {
  const Eigen::Vector3d v(250.0, 160.0, -30.0), c(0.0, 0.0, 1000.0);
  const double scale_sigma = 0.01, attitude_sigma_rad = 0.2 * kDegToRad, filter_sigma_mps = 0.05;
  MapDrift::Matrix6d start = MapDrift::Matrix6d::Zero();
  start.bottomRightCorner<3, 3>().diagonal().setConstant(attitude_sigma_rad * attitude_sigma_rad);
  auto drift = [&](double s, double a) {
    MapDrift d(0.0, 10);
    MapDrift::Matrix6d st = MapDrift::Matrix6d::Zero();
    st.bottomRightCorner<3, 3>().diagonal().setConstant(a * a);
    d.start(c, c, 0, s, st);
    return d.velocityCovariance(v);
  };
  const Eigen::Matrix3d P_filter = filter_sigma_mps * filter_sigma_mps * Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d with_drift = P_filter + drift(scale_sigma, attitude_sigma_rad);
  const Eigen::Matrix3d scale_only = P_filter + drift(scale_sigma, 0.0);
  const Eigen::Matrix3d attitude_only = P_filter + drift(0.0, attitude_sigma_rad);
  const Eigen::Vector3d u = v.normalized();
  const Eigen::Vector3d across = u.cross(Eigen::Vector3d::UnitZ()).normalized();
  EXPECT_NEAR(u.dot(drift(scale_sigma, 0.0) * u), std::pow(scale_sigma * v.norm(), 2), 1e-9);
  EXPECT_NEAR(u.dot(drift(0.0, attitude_sigma_rad) * u), 0.0, 1e-9);
  EXPECT_NEAR(across.dot(drift(0.0, attitude_sigma_rad) * across), std::pow(attitude_sigma_rad * v.norm(), 2),
              1e-9);

  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  constexpr int kDraws = 4000;
  double nees = 0.0, nees_filter = 0.0, nees_scale_only = 0.0, nees_attitude_only = 0.0;
  for (int i = 0; i < kDraws; ++i) {
    const double s = scale_sigma * normal(rng);
    const Eigen::Vector3d theta = attitude_sigma_rad * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d noise = filter_sigma_mps * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d e = (1.0 + s) * (expSO3(theta) * v) + noise - v;
    nees += e.dot(with_drift.ldlt().solve(e)) / kDraws;
    nees_filter += e.dot(P_filter.ldlt().solve(e)) / kDraws;
    nees_scale_only += e.dot(scale_only.ldlt().solve(e)) / kDraws;
    nees_attitude_only += e.dot(attitude_only.ldlt().solve(e)) / kDraws;
  }
  std::cout << "velocity NEES with the map's drift " << nees << ", the filter's covariance alone "
            << nees_filter << ", scale part only " << nees_scale_only << ", attitude part only "
            << nees_attitude_only << "\n";
  EXPECT_NEAR(nees, 3.0, 0.2);  // standard error of the mean of 4000 chi-square(3) draws: 0.04
  EXPECT_GT(nees_filter, 100.0);
  EXPECT_GT(nees_scale_only, 10.0);
  EXPECT_GT(nees_attitude_only, 10.0);
}

// A 30 s descent at 10 Hz (60 m/s forward, 15 m/s down, braking), a keyframe every 3 frames, the map made
// metric after 20 frames: its attitude walks 0.05 deg per keyframe per axis, its scale error (2 %) has a
// correlation of exp(-1/10) per keyframe, and the handed-over start is off by 1 m and 0.05 deg. The
// position error is the sum of the displacements' errors. Over 3000 draws the NEES of the position, the
// attitude and the whole pose at the end have their chi-square means; the start's covariance alone (no
// propagation) gives a position NEES in the hundreds.
TEST(MapDrift, ThePositionErrorOfADescentOverADriftingMapMatchesItsCovariance) {
  const double q_rad = 0.05 * kDegToRad, scale_sigma = 0.02, p0_sigma = 1.0, a0_sigma = 0.05 * kDegToRad;
  constexpr int kWindow = 10, kFrames = 300, kFix = 20, kKeyframeEvery = 3, kDraws = 3000;
  const double dt = 0.1, a = std::exp(-1.0 / kWindow);
  auto position = [&](int k) {
    const double t = k * dt;
    return Eigen::Vector3d(60.0 * t - 0.5 * t * t, 5.0 * t, 2000.0 - 15.0 * t + 0.1 * t * t);
  };
  MapDrift::Matrix6d start = MapDrift::Matrix6d::Zero();
  start.topLeftCorner<3, 3>().diagonal().setConstant(p0_sigma * p0_sigma);
  start.bottomRightCorner<3, 3>().diagonal().setConstant(a0_sigma * a0_sigma);
  const int keyframes_at_fix = kFix / kKeyframeEvery;

  MapDrift drift(q_rad, kWindow);
  EXPECT_FALSE(drift.running());
  drift.start(position(0), position(kFix), keyframes_at_fix, scale_sigma, start);
  for (int k = kFix + 1; k < kFrames; ++k) {
    if (k % kKeyframeEvery == 0) drift.addKeyframe();
    drift.setScaleSigma(scale_sigma);  // the range factors: the same sigma, the correlation kept
    drift.moveTo(position(k));
  }
  const MapDrift::Matrix6d P = drift.poseCovariance();

  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto vec = [&](double sigma) {
    return Eigen::Vector3d(sigma * Eigen::Vector3d(normal(rng), normal(rng), normal(rng)));
  };
  double nees_p = 0.0, nees_a = 0.0, nees_pose = 0.0, nees_start_only = 0.0;
  for (int i = 0; i < kDraws; ++i) {
    Eigen::Vector3d e_p = vec(p0_sigma);
    Eigen::Vector3d theta = vec(a0_sigma);
    for (int kf = 0; kf < keyframes_at_fix; ++kf) theta += vec(q_rad);
    double s = scale_sigma * normal(rng);
    auto step = [&](const Eigen::Vector3d& d) { e_p += (1.0 + s) * (expSO3(theta) * d) - d; };
    step(position(kFix) - position(0));  // the path before the fix, scaled by it
    for (int k = kFix + 1; k < kFrames; ++k) {
      if (k % kKeyframeEvery == 0) {
        theta += vec(q_rad);
        s = a * s + std::sqrt(1.0 - a * a) * scale_sigma * normal(rng);
      }
      step(position(k) - position(k - 1));
    }
    Eigen::Matrix<double, 6, 1> e;
    e << e_p, theta;
    nees_p += e_p.dot(P.topLeftCorner<3, 3>().ldlt().solve(e_p)) / kDraws;
    nees_a += theta.dot(P.bottomRightCorner<3, 3>().ldlt().solve(theta)) / kDraws;
    nees_pose += e.dot(P.ldlt().solve(e)) / kDraws;
    nees_start_only += e_p.dot(start.topLeftCorner<3, 3>().ldlt().solve(e_p)) / kDraws;
  }
  std::cout << "end of the descent: position NEES " << nees_p << ", attitude " << nees_a << ", pose "
            << nees_pose << " (position 1-sigma " << std::sqrt(P.topLeftCorner<3, 3>().trace())
            << " m); start only " << nees_start_only << "\n";
  // Standard errors of the means of 3000 draws: 0.045 (3 dof), 0.063 (6 dof); the linearisation adds a
  // little.
  EXPECT_NEAR(nees_p, 3.0, 0.25);
  EXPECT_NEAR(nees_a, 3.0, 0.25);
  EXPECT_NEAR(nees_pose, 6.0, 0.4);
  EXPECT_GT(nees_start_only, 100.0);
}

TEST(MapDrift, RefusesBadParametersAndDoesNothingBeforeItStarts) {
  EXPECT_THROW(MapDrift(-1.0, 10), std::invalid_argument);
  EXPECT_THROW(MapDrift(0.001, 0), std::invalid_argument);
  EXPECT_THROW(MapDrift(std::nan(""), 10), std::invalid_argument);
  MapDrift drift(0.001, 10);
  drift.addKeyframe();
  drift.setScaleSigma(0.01);
  drift.moveTo(Eigen::Vector3d(100.0, 0.0, 0.0));
  EXPECT_FALSE(drift.running());
  EXPECT_TRUE(drift.poseCovariance().isZero());
  drift.start(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0, 0.01, MapDrift::Matrix6d::Zero());
  EXPECT_TRUE(drift.running());
  drift.reset();
  EXPECT_FALSE(drift.running());
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
