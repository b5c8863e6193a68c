/// Tests of adjustBundle(), refinePose() and AsyncBundleAdjuster on a synthetic Lunar descent with known
/// answers: keyframes descending from 500 m to 275 m over rough terrain, observations projected exactly (then
/// noised, then corrupted with gross outliers), starting values perturbed by a known amount.

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <iostream>

#include "planetary_vo/vo/bundle_adjuster.h"

namespace planetary_vo {
namespace {

constexpr double kFx = 443.0, kFy = 443.0, kCx = 255.5, kCy = 255.5;
constexpr int kWidth = 512, kHeight = 512;
constexpr double kDegToRad = M_PI / 180.0;

using ObsKey = std::pair<uint64_t, uint64_t>;  // (keyframe id, point id)

/// Rolling terrain with metre-scale roughness (heights in m, world z up).
double terrainHeight(double x, double y) {
  return 12.0 * std::sin(x / 37.0) * std::cos(y / 53.0) + 6.0 * std::sin(x / 11.0 + y / 17.0) +
         3.0 * std::cos(x / 5.0 - y / 7.0);
}

Eigen::Vector3d cameraCentre(const Pose& T_cam_world) {
  return -T_cam_world.linear().transpose() * T_cam_world.translation();
}

bool project(const Pose& T_cam_world, const Eigen::Vector3d& p_world, Eigen::Vector2d* px) {
  const Eigen::Vector3d p = T_cam_world * p_world;
  if (p.z() <= 0.0) return false;
  *px = Eigen::Vector2d(kFx * p.x() / p.z() + kCx, kFy * p.y() / p.z() + kCy);
  return px->x() >= 0.0 && px->x() < kWidth && px->y() >= 0.0 && px->y() < kHeight;
}

/// `num_keyframes` cameras evenly spaced on a descent from (0, 0, 500) to (270, 90, 275), looking down with a
/// slight forward tilt and a random +-2 deg wobble; `num_points` terrain points, each seen by >= 3 keyframes.
/// Observations are exact. The first two keyframes are fixed: they fix the gauge including the scale.
BaProblem makeDescentScene(int num_keyframes, int num_points, uint64_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> wobble(-2.0 * kDegToRad, 2.0 * kDegToRad);
  BaProblem scene;
  scene.fx = kFx;
  scene.fy = kFy;
  scene.cx = kCx;
  scene.cy = kCy;
  const Eigen::Vector3d start(0.0, 0.0, 500.0), end(270.0, 90.0, 275.0);
  for (int i = 0; i < num_keyframes; ++i) {
    const Eigen::Vector3d c = start + (end - start) * (static_cast<double>(i) / (num_keyframes - 1));
    const Eigen::Vector3d z = Eigen::Vector3d(0.12, 0.04, -1.0).normalized();
    const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z).normalized();
    Eigen::Matrix3d R_world_cam;
    R_world_cam << x, z.cross(x), z;
    R_world_cam = R_world_cam * (Eigen::AngleAxisd(wobble(rng), Eigen::Vector3d::UnitX()) *
                                 Eigen::AngleAxisd(wobble(rng), Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(wobble(rng), Eigen::Vector3d::UnitZ()))
                                    .toRotationMatrix();
    BaKeyframe kf;
    kf.id = 100 + i;
    kf.T_cam_world.linear() = R_world_cam.transpose();
    kf.T_cam_world.translation() = -R_world_cam.transpose() * c;
    kf.fixed = i < 2;
    scene.keyframes.push_back(kf);
  }
  std::uniform_real_distribution<double> ux(0.0, 400.0), uy(-150.0, 250.0), boulder(-2.0, 2.0);
  while (static_cast<int>(scene.points.size()) < num_points) {
    const double x = ux(rng), y = uy(rng);
    const Eigen::Vector3d p(x, y, terrainHeight(x, y) + boulder(rng));
    std::vector<BaObservation> obs;
    for (const BaKeyframe& kf : scene.keyframes) {
      Eigen::Vector2d px;
      if (project(kf.T_cam_world, p, &px)) obs.push_back(BaObservation{kf.id, 0, px});
    }
    if (obs.size() < 3) continue;
    const uint64_t id = 5000 + scene.points.size();
    scene.points.push_back(BaPoint{id, p, false});
    for (BaObservation& o : obs) {
      o.point_id = id;
      scene.observations.push_back(o);
    }
  }
  return scene;
}

void addPixelNoise(BaProblem* problem, double sigma_px, uint64_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_px);
  for (BaObservation& o : problem->observations) o.px += Eigen::Vector2d(noise(rng), noise(rng));
}

/// Moves `fraction` of the observations by `offset_px` in a random direction; returns which.
std::set<ObsKey> addOutliers(BaProblem* problem, double fraction, double offset_px, uint64_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::set<ObsKey> outliers;
  for (BaObservation& o : problem->observations) {
    if (u(rng) >= fraction) continue;
    const double a = 2.0 * M_PI * u(rng);
    o.px += offset_px * Eigen::Vector2d(std::cos(a), std::sin(a));
    outliers.insert({o.keyframe_id, o.point_id});
  }
  return outliers;
}

Eigen::Vector3d randomUnit(std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Vector3d(n(*rng), n(*rng), n(*rng)).normalized();
}

double windowBaseline(const BaProblem& p) {
  return (cameraCentre(p.keyframes.back().T_cam_world) - cameraCentre(p.keyframes.front().T_cam_world))
      .norm();
}

/// Perturbs every non-fixed keyframe by `rot_deg` about a random axis and its centre by `trans_frac` of the
/// window baseline, and every non-fixed point by `point_frac` of its distance to the first camera.
void perturb(BaProblem* problem, double rot_deg, double trans_frac, double point_frac, uint64_t seed) {
  std::mt19937 rng(seed);
  const double baseline = windowBaseline(*problem);
  const Eigen::Vector3d c0 = cameraCentre(problem->keyframes.front().T_cam_world);
  for (BaKeyframe& kf : problem->keyframes) {
    if (kf.fixed) continue;
    const Eigen::Matrix3d R_world_cam =
        kf.T_cam_world.linear().transpose() * Eigen::AngleAxisd(rot_deg * kDegToRad, randomUnit(&rng));
    const Eigen::Vector3d c = cameraCentre(kf.T_cam_world) + trans_frac * baseline * randomUnit(&rng);
    kf.T_cam_world.linear() = R_world_cam.transpose();
    kf.T_cam_world.translation() = -R_world_cam.transpose() * c;
  }
  for (BaPoint& p : problem->points) {
    if (!p.fixed) p.p_world += point_frac * (p.p_world - c0).norm() * randomUnit(&rng);
  }
}

struct Errors {
  double max_rot_deg = 0.0, mean_rot_deg = 0.0;
  double max_trans_rel = 0.0, mean_trans_rel = 0.0;  ///< camera-centre error / window baseline
  double max_point_rel = 0.0;                        ///< point error / distance to the first camera
};

Errors errorsAgainst(const BaProblem& est, const BaProblem& truth) {
  Errors e;
  const double baseline = windowBaseline(truth);
  for (size_t k = 0; k < truth.keyframes.size(); ++k) {
    const Pose& a = est.keyframes[k].T_cam_world;
    const Pose& b = truth.keyframes[k].T_cam_world;
    const double rot = rotationAngleDeg(a.linear() * b.linear().transpose());
    const double trans = (cameraCentre(a) - cameraCentre(b)).norm() / baseline;
    e.max_rot_deg = std::max(e.max_rot_deg, rot);
    e.max_trans_rel = std::max(e.max_trans_rel, trans);
    e.mean_rot_deg += rot / truth.keyframes.size();
    e.mean_trans_rel += trans / truth.keyframes.size();
  }
  const Eigen::Vector3d c0 = cameraCentre(truth.keyframes.front().T_cam_world);
  for (size_t j = 0; j < truth.points.size(); ++j) {
    const double rel =
        (est.points[j].p_world - truth.points[j].p_world).norm() / (truth.points[j].p_world - c0).norm();
    e.max_point_rel = std::max(e.max_point_rel, rel);
  }
  return e;
}

void printErrors(const char* label, const Errors& e) {
  std::printf(
      "  %-10s rot max %.2e mean %.2e deg | centre max %.2e mean %.2e of baseline | points max %.2e\n", label,
      e.max_rot_deg, e.mean_rot_deg, e.max_trans_rel, e.mean_trans_rel, e.max_point_rel);
}

std::set<ObsKey> keysOf(const std::vector<BaObservation>& obs) {
  std::set<ObsKey> keys;
  for (const BaObservation& o : obs) keys.insert({o.keyframe_id, o.point_id});
  return keys;
}

/// RMS reprojection error of the true structure and motion against the observations of `observed`.
double rmsAtTruth(const BaProblem& truth, const BaProblem& observed) {
  BaProblem p = truth;
  p.observations = observed.observations;
  for (BaKeyframe& kf : p.keyframes) kf.fixed = true;
  for (BaPoint& pt : p.points) pt.fixed = true;
  return adjustBundle(&p, BundleAdjustmentConfig{}).final_rms_px;  // nothing free: only evaluates
}

/// Mean rotation (deg) and camera-centre (fraction of baseline) difference between two solutions.
std::pair<double, double> meanPoseDifference(const BaProblem& a, const BaProblem& b) {
  double rot = 0.0, trans = 0.0;
  const double baseline = windowBaseline(b);
  for (size_t k = 0; k < a.keyframes.size(); ++k) {
    rot += rotationAngleDeg(a.keyframes[k].T_cam_world.linear() *
                            b.keyframes[k].T_cam_world.linear().transpose());
    trans += (cameraCentre(a.keyframes[k].T_cam_world) - cameraCentre(b.keyframes[k].T_cam_world)).norm() /
             baseline;
  }
  return {rot / a.keyframes.size(), trans / a.keyframes.size()};
}

BundleAdjustmentConfig configWith(RobustLoss loss, int max_iterations = 50) {
  BundleAdjustmentConfig config;
  config.robust_loss = loss;
  config.robust_loss_scale_px = 2.0;
  config.max_iterations = max_iterations;
  return config;
}

// ------------------------------------------------------------------------------------------------------------
// adjustBundle
// ------------------------------------------------------------------------------------------------------------

TEST(AdjustBundle, NoiseFreeWindowReturnsToTruthAndLeavesFixedKeyframesAlone) {
  const BaProblem truth = makeDescentScene(10, 300, 1);
  BaProblem problem = truth;
  perturb(&problem, 0.5, 0.02, 0.01, 2);
  const Errors before = errorsAgainst(problem, truth);
  ASSERT_GT(before.max_rot_deg, 0.49);  // the perturbation is real

  const BaSummary s = adjustBundle(&problem, configWith(RobustLoss::kHuber));
  const Errors after = errorsAgainst(problem, truth);
  printErrors("before", before);
  printErrors("after", after);
  std::printf("  rms %.3f -> %.2e px in %d iterations, %.1f ms\n", s.initial_rms_px, s.final_rms_px,
              s.iterations, s.solve_ms);

  EXPECT_TRUE(s.converged);
  EXPECT_GT(s.initial_rms_px, 1.0);
  EXPECT_LT(s.final_rms_px, 1e-3);
  EXPECT_LT(after.max_rot_deg, 1e-3);
  EXPECT_LT(after.max_trans_rel, 1e-4);
  EXPECT_LT(after.max_point_rel, 1e-4);
  EXPECT_GT(s.iterations, 0);
  EXPECT_LE(s.iterations, 50);
  EXPECT_TRUE(s.outliers.empty());
  for (int k = 0; k < 2; ++k) {  // bitwise: a fixed keyframe is never written
    EXPECT_TRUE(problem.keyframes[k].T_cam_world.matrix() == truth.keyframes[k].T_cam_world.matrix());
  }
}

// The scale of a monocular window is not observable: a window scaled about its only fixed camera reprojects
// exactly as the truth does. Altimeter range factors (the measured range against the plane fitted to the map
// around each free keyframe's beam) bring it back to metres.
TEST(AdjustBundle, AltimeterRangesFixTheScaleThatReprojectionCannot) {
  const BaProblem truth = makeDescentScene(10, 400, 5);
  std::vector<Eigen::Vector3d> points;
  for (const BaPoint& p : truth.points) points.push_back(p.p_world);
  BaProblem problem = truth;
  problem.keyframes[1].fixed = false;  // only the oldest fixes the gauge
  const Eigen::Vector3d c0 = cameraCentre(truth.keyframes[0].T_cam_world);
  const double wrong_scale = 1.05;
  for (BaKeyframe& kf : problem.keyframes) {
    if (kf.fixed) continue;
    const Eigen::Vector3d c = c0 + wrong_scale * (cameraCentre(kf.T_cam_world) - c0);
    kf.T_cam_world.translation() = -kf.T_cam_world.linear() * c;
  }
  for (BaPoint& p : problem.points) p.p_world = c0 + wrong_scale * (p.p_world - c0);
  auto scaleOf = [&](const BaProblem& b) {
    return (cameraCentre(b.keyframes.back().T_cam_world) - c0).norm() /
           (cameraCentre(truth.keyframes.back().T_cam_world) - c0).norm();
  };

  BaProblem vision_only = problem;
  adjustBundle(&vision_only, configWith(RobustLoss::kHuber));
  EXPECT_NEAR(scaleOf(vision_only), wrong_scale, 1e-3);  // nothing pulls it back

  // Ranges of the free keyframes measured on the true terrain (0.3 m noise); the planes they are compared
  // with are fitted to the current map, as the pipeline does at each keyframe, and held fixed in a solve.
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::vector<double> measured_m;
  for (const BaKeyframe& kf : truth.keyframes) {
    const RangePrediction r = predictRange(points, {}, kf.T_cam_world.inverse());
    ASSERT_TRUE(r.valid()) << r.reason;
    measured_m.push_back(r.range + noise(rng));
  }
  auto attachRanges = [&](BaProblem* b) {
    std::vector<Eigen::Vector3d> map_points;
    for (const BaPoint& p : b->points) map_points.push_back(p.p_world);
    b->ranges.clear();
    for (size_t k = 1; k < b->keyframes.size(); ++k) {
      const RangePrediction r = predictRange(map_points, {}, b->keyframes[k].T_cam_world.inverse());
      if (!r.valid()) continue;
      BaRangeObservation o;
      o.keyframe_id = b->keyframes[k].id;
      o.plane = r.plane;
      // The 12 map points nearest the beam's hit carry the plane.
      std::vector<std::pair<double, uint64_t>> nearest;
      for (const BaPoint& p : b->points) nearest.emplace_back((p.p_world - r.hit_world).norm(), p.id);
      std::sort(nearest.begin(), nearest.end());
      for (size_t m = 0; m < 12; ++m) o.support_point_ids.push_back(nearest[m].second);
      o.measured_range_m = measured_m[k];
      o.sigma_m = std::hypot(0.3, r.sigma);
      b->ranges.push_back(o);
    }
  };
  BaSummary s;
  for (int round = 0; round < 4; ++round) {
    attachRanges(&problem);
    s = adjustBundle(&problem, configWith(RobustLoss::kHuber));
    std::printf("  round %d: scale %.5f, %d range factors, rms %.3f px\n", round, scaleOf(problem),
                s.range_factors, s.final_rms_px);
    EXPECT_TRUE(s.converged);
    EXPECT_EQ(s.range_factors, 9);
  }
  // 9 ranges of 0.3 m at 280-500 m: the scale to about 0.1 %; the reprojection stays exact.
  EXPECT_LT(std::abs(scaleOf(problem) - 1.0), 0.002);
  EXPECT_LT(s.final_rms_px, 0.05);

  BaProblem bad = problem;
  bad.ranges.front().keyframe_id = 999;
  EXPECT_THROW(adjustBundle(&bad, configWith(RobustLoss::kHuber)), std::invalid_argument);
}

/// A braking descent with an IMU: keyframes 1 s apart on c(t) = c0 + v0 t + a t^2 / 2 with a gently
/// oscillating attitude, 400 terrain points seen by >= 3 keyframes, and the IMU (mounted rotated in the
/// camera frame) sampled at 200 Hz: angular rate from the rotation's central difference, specific force
/// R_world_imu^T (a - g); when imu_seed > 0 plus constant biases drawn from the bias prior (2e-5 rad/s,
/// 7e-3 m/s^2) and white noise of the flight IMU's densities. The first keyframe is fixed; every keyframe
/// has its true velocity and biases.
struct InertialScene {
  BaProblem truth;
  Eigen::Vector3d c0;
};

InertialScene makeInertialScene(uint64_t imu_seed) {
  constexpr int kKeyframes = 8;
  constexpr double kKeyframeDtS = 1.0, kImuRateHz = 200.0;
  const Eigen::Vector3d gravity = kLunarGravityWorldMps2;
  const Eigen::Vector3d c0(0.0, 0.0, 500.0), v0(40.0, 10.0, -35.0), accel(-3.0, 0.5, 1.5);
  auto centre = [&](double t) { return Eigen::Vector3d(c0 + v0 * t + 0.5 * accel * t * t); };
  auto R_world_cam = [](double t) {
    const Eigen::Vector3d z = Eigen::Vector3d(0.12, 0.04, -1.0).normalized();
    const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z).normalized();
    Eigen::Matrix3d R;
    R << x, z.cross(x), z;
    return Eigen::Matrix3d(R * Eigen::AngleAxisd(0.03 * std::sin(0.9 * t), Eigen::Vector3d::UnitX()) *
                           Eigen::AngleAxisd(0.02 * std::sin(1.3 * t + 0.5), Eigen::Vector3d::UnitY()));
  };
  Pose T_cam_imu = Pose::Identity();
  T_cam_imu.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                       Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d R_cam_imu = T_cam_imu.linear();

  BaProblem truth;
  truth.fx = kFx;
  truth.fy = kFy;
  truth.cx = kCx;
  truth.cy = kCy;
  for (int i = 0; i < kKeyframes; ++i) {
    const double t = i * kKeyframeDtS;
    BaKeyframe kf;
    kf.id = 100 + i;
    kf.T_cam_world.linear() = R_world_cam(t).transpose();
    kf.T_cam_world.translation() = -R_world_cam(t).transpose() * centre(t);
    kf.fixed = i == 0;
    truth.keyframes.push_back(kf);
  }
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(0.0, 400.0), uy(-150.0, 250.0);
  while (truth.points.size() < 400) {
    const double x = ux(rng), y = uy(rng);
    const Eigen::Vector3d p(x, y, terrainHeight(x, y));
    std::vector<BaObservation> obs;
    for (const BaKeyframe& kf : truth.keyframes) {
      Eigen::Vector2d px;
      if (project(kf.T_cam_world, p, &px)) obs.push_back(BaObservation{kf.id, 0, px});
    }
    if (obs.size() < 3) continue;
    const uint64_t id = 5000 + truth.points.size();
    truth.points.push_back(BaPoint{id, p, false});
    for (BaObservation& o : obs) {
      o.point_id = id;
      truth.observations.push_back(o);
    }
  }
  ImuNoiseParams noise;  // the flight IMU's densities
  noise.gyro_noise_density_radps_per_sqrt_hz = 4.4e-5;
  noise.accel_noise_density_mps2_per_sqrt_hz = 1e-3;
  noise.gyro_random_walk_radps2_per_sqrt_hz = 2.5e-8;
  noise.accel_random_walk_mps3_per_sqrt_hz = 1.6e-5;
  std::mt19937 imu_rng(imu_seed);
  std::normal_distribution<double> gyro_noise(
      0.0, noise.gyro_noise_density_radps_per_sqrt_hz * std::sqrt(kImuRateHz));
  std::normal_distribution<double> accel_noise(
      0.0, noise.accel_noise_density_mps2_per_sqrt_hz * std::sqrt(kImuRateHz));
  ImuBias bias;
  if (imu_seed > 0) {
    std::normal_distribution<double> gyro_bias(0.0, 2e-5), accel_bias(0.0, 7e-3);
    bias.gyro_radps = Eigen::Vector3d(gyro_bias(imu_rng), gyro_bias(imu_rng), gyro_bias(imu_rng));
    bias.accel_mps2 = Eigen::Vector3d(accel_bias(imu_rng), accel_bias(imu_rng), accel_bias(imu_rng));
  }
  std::vector<ImuSample> imu;
  const double h = 1e-5;
  for (int k = 0; k <= static_cast<int>(kImuRateHz * kKeyframeDtS * (kKeyframes - 1)); ++k) {
    const double t = k / kImuRateHz;
    const Eigen::Matrix3d R_wi = R_world_cam(t) * R_cam_imu;
    const Eigen::Matrix3d R_next = R_world_cam(t + h) * R_cam_imu, R_prev = R_world_cam(t - h) * R_cam_imu;
    ImuSample s;
    s.timestamp_s = t;
    s.angular_velocity_radps = logSO3(R_prev.transpose() * R_next) / (2.0 * h);
    s.specific_force_mps2 = R_wi.transpose() * (accel - gravity);
    if (imu_seed > 0) {
      s.angular_velocity_radps += bias.gyro_radps;
      s.specific_force_mps2 += bias.accel_mps2;
      s.angular_velocity_radps +=
          Eigen::Vector3d(gyro_noise(imu_rng), gyro_noise(imu_rng), gyro_noise(imu_rng));
      s.specific_force_mps2 +=
          Eigen::Vector3d(accel_noise(imu_rng), accel_noise(imu_rng), accel_noise(imu_rng));
    }
    imu.push_back(s);
  }
  truth.inertial.gravity_world_mps2 = gravity;
  truth.inertial.T_cam_imu = T_cam_imu;
  for (int i = 0; i < kKeyframes; ++i) {
    const double t = i * kKeyframeDtS;
    truth.inertial.states.push_back({truth.keyframes[i].id, v0 + accel * t, bias});
    if (i > 0)
      truth.inertial.constraints.push_back(
          {truth.keyframes[i - 1].id, truth.keyframes[i].id,
           std::make_shared<const ImuPreintegration>(imu, t - kKeyframeDtS, t, ImuBias(), noise)});
  }
  truth.inertial.bias_priors.push_back(BaBiasPrior::diagonal(truth.keyframes[0].id, ImuBias(), 2e-5, 7e-3));
  return {truth, c0};
}

// The IMU between keyframes holds the scale too, while the lander accelerates: a window scaled about its only
// fixed keyframe reprojects exactly, but its positions no longer match the accelerometer's double integral.
// The IMU is exact and mounted rotated in the camera frame, so the conversion of the camera pose blocks to
// the IMU body is checked too. Without the IMU constraints (vision only) the wrong scale stays.
TEST(AdjustBundle, ImuFactorsFixTheScaleAndTheVelocities) {
  const InertialScene scene = makeInertialScene(0);
  const BaProblem& truth = scene.truth;
  const Eigen::Vector3d c0 = scene.c0;
  const int kKeyframes = static_cast<int>(truth.keyframes.size());

  // The window at 1.05 x the true scale about the fixed keyframe (positions, points, velocities).
  const double wrong_scale = 1.05;
  BaProblem problem = truth;
  for (BaKeyframe& kf : problem.keyframes) {
    if (kf.fixed) continue;
    const Eigen::Vector3d c = c0 + wrong_scale * (cameraCentre(kf.T_cam_world) - c0);
    kf.T_cam_world.translation() = -kf.T_cam_world.linear() * c;
  }
  for (BaPoint& p : problem.points) p.p_world = c0 + wrong_scale * (p.p_world - c0);
  for (BaInertialState& st : problem.inertial.states) st.v_world_mps *= wrong_scale;
  auto scaleOf = [&](const BaProblem& b) {
    return (cameraCentre(b.keyframes.back().T_cam_world) - c0).norm() /
           (cameraCentre(truth.keyframes.back().T_cam_world) - c0).norm();
  };

  BaProblem vision_only = problem;
  vision_only.inertial = BaInertial();
  const BaSummary sv = adjustBundle(&vision_only, configWith(RobustLoss::kHuber));
  EXPECT_EQ(sv.imu_factors, 0);
  EXPECT_NEAR(scaleOf(vision_only), wrong_scale, 1e-3);  // nothing pulls it back

  const BaSummary s = adjustBundle(&problem, configWith(RobustLoss::kHuber));
  double max_velocity_error = 0.0;
  for (size_t i = 0; i < problem.inertial.states.size(); ++i)
    max_velocity_error =
        std::max(max_velocity_error,
                 (problem.inertial.states[i].v_world_mps - truth.inertial.states[i].v_world_mps).norm());
  std::printf(
      "  vision only: scale %.5f; with the IMU: scale %.6f, velocity error <= %.2e m/s, %d factors, "
      "rms %.2e px, %d iterations\n",
      scaleOf(vision_only), scaleOf(problem), max_velocity_error, s.imu_factors, s.final_rms_px,
      s.iterations);
  EXPECT_TRUE(s.converged);
  EXPECT_EQ(s.imu_factors, kKeyframes - 1);
  EXPECT_LT(std::abs(scaleOf(problem) - 1.0), 1e-4);
  EXPECT_LT(max_velocity_error, 0.01);
  EXPECT_LT(s.final_rms_px, 1e-3);
  const Errors after = errorsAgainst(problem, truth);
  EXPECT_LT(after.max_rot_deg, 1e-3);

  BaProblem bad = problem;
  bad.inertial.constraints.front().keyframe_i = 999;
  EXPECT_THROW(adjustBundle(&bad, configWith(RobustLoss::kHuber)), std::invalid_argument);
}

// The covariance the adjuster reports for the window's states is what the errors show: over 30 draws of
// 1 px pixel noise (the unit the reprojection residual assumes) and of the IMU's white noise at its data
// sheet densities, the NEES of the newest keyframe's [position, attitude, velocity] has the chi-square mean
// of 9 dof (two-sided 95 % bounds of the mean of 30 draws: 7.5 .. 10.6), and the NEES of its biases (drawn
// from their prior) that of 6 dof (4.8 .. 7.2). A wrong tangent-space conversion
// (the factor 2 of Ceres' quaternion manifold, or the lever of the translation block) is off by 4x or more.
TEST(AdjustBundle, CovarianceOfTheWindowStatesIsConsistent) {
  constexpr int kDraws = 30;
  double nees_sum = 0.0, bias_nees_sum = 0.0, covariance_ms = 0.0;
  Eigen::Matrix<double, 9, 1> sq_sum = Eigen::Matrix<double, 9, 1>::Zero(), var_sum = sq_sum;
  for (int draw = 0; draw < kDraws; ++draw) {
    const InertialScene scene = makeInertialScene(100 + draw);
    BaProblem problem = scene.truth;
    addPixelNoise(&problem, 1.0, 200 + draw);
    problem.inertial.compute_covariance = true;
    problem.inertial.states.front().velocity_fixed = true;  // held with the pose, as the pipeline does
    // The oldest keyframe is the truth: an (almost) exact anchor.
    problem.inertial.anchor_covariance = 1e-12 * Eigen::Matrix<double, 9, 9>::Identity();
    const BaSummary s = adjustBundle(&problem, configWith(RobustLoss::kNone));
    ASSERT_TRUE(s.converged);
    covariance_ms += s.covariance_ms / kDraws;
    const BaInertialState& est = problem.inertial.states.back();
    ASSERT_TRUE(est.has_covariance);
    const Pose T_true = scene.truth.keyframes.back().T_cam_world.inverse();
    const Pose T_est = problem.keyframes.back().T_cam_world.inverse();
    Eigen::Matrix<double, 9, 1> e;
    e << T_true.translation() - T_est.translation(), logSO3(T_true.linear() * T_est.linear().transpose()),
        scene.truth.inertial.states.back().v_world_mps - est.v_world_mps;
    nees_sum += e.dot(est.covariance.ldlt().solve(e));
    sq_sum += e.cwiseAbs2();
    var_sum += est.covariance.diagonal();
    Eigen::Matrix<double, 6, 1> eb;
    eb << scene.truth.inertial.states.back().bias.gyro_radps - est.bias.gyro_radps,
        scene.truth.inertial.states.back().bias.accel_mps2 - est.bias.accel_mps2;
    bias_nees_sum += eb.dot(est.bias_covariance.ldlt().solve(eb));
  }
  const double nees = nees_sum / kDraws, bias_nees = bias_nees_sum / kDraws;
  std::printf(
      "  NEES of the newest keyframe: mean %.2f over %d draws (9 dof); error RMS / predicted sigma: "
      "position %.2f, attitude %.2f, velocity %.2f; covariance %.1f ms per solve\n",
      nees, kDraws, std::sqrt(sq_sum.head<3>().sum() / var_sum.head<3>().sum()),
      std::sqrt(sq_sum.segment<3>(3).sum() / var_sum.segment<3>(3).sum()),
      std::sqrt(sq_sum.tail<3>().sum() / var_sum.tail<3>().sum()), covariance_ms);
  EXPECT_GT(nees, 6.0);
  EXPECT_LT(nees, 12.5);
  // The biases' covariance (the prior the next windows carry, Pipeline::addInertialFactors): 6 dof.
  std::printf("  NEES of the newest keyframe's biases: mean %.2f (6 dof)\n", bias_nees);
  EXPECT_GT(bias_nees, 3.5);
  EXPECT_LT(bias_nees, 9.0);
  for (int block = 0; block < 3; ++block) {
    const double ratio = std::sqrt(sq_sum.segment<3>(3 * block).sum() / var_sum.segment<3>(3 * block).sum());
    EXPECT_GT(ratio, 0.6) << "block " << block;
    EXPECT_LT(ratio, 1.6) << "block " << block;
  }
}

// Why the oldest state's velocity is solved under a prior rather than held (Pipeline::addInertialFactors):
// a held velocity that is off (here by 0.1 m/s, what earlier windows may leave) cannot be corrected, so the
// window explains the IMU with wrong biases instead, every window anew: the walk of the biases along a
// descent (docs/fusion/README.md, session 32). Under a prior of its own uncertainty (0.1 m/s) the window
// corrects the velocity from the later states, and the biases stay near the truth (zero: an exact IMU).
TEST(AdjustBundle, AVelocityPriorOnTheOldestStateKeepsItsErrorOutOfTheBiases) {
  const InertialScene scene = makeInertialScene(0);
  const Eigen::Vector3d velocity_error(0.06, -0.05, 0.06);  // 0.098 m/s
  struct Outcome {
    double velocity_error_mps, gyro_bias_radps, accel_bias_mps2;
  };
  auto solve = [&](bool with_prior) {
    BaProblem problem = scene.truth;
    BaInertialState& oldest = problem.inertial.states.front();
    oldest.v_world_mps += velocity_error;
    oldest.velocity_fixed = !with_prior;
    oldest.has_velocity_prior = with_prior;
    oldest.velocity_prior_mps = oldest.v_world_mps;
    oldest.velocity_prior_covariance = Eigen::Matrix3d::Identity() * 0.1 * 0.1;
    const BaSummary s = adjustBundle(&problem, configWith(RobustLoss::kNone));
    EXPECT_TRUE(s.converged);
    Outcome o{(oldest.v_world_mps - scene.truth.inertial.states.front().v_world_mps).norm(), 0.0, 0.0};
    for (const BaInertialState& st : problem.inertial.states) {
      o.gyro_bias_radps = std::max(o.gyro_bias_radps, st.bias.gyro_radps.norm());
      o.accel_bias_mps2 = std::max(o.accel_bias_mps2, st.bias.accel_mps2.norm());
    }
    return o;
  };
  const Outcome held = solve(false), prior = solve(true);
  std::printf(
      "  oldest velocity off by %.3f m/s; held: velocity error %.4f m/s, biases up to %.2e rad/s, %.2e "
      "m/s^2; "
      "under a prior: %.4f m/s, %.2e rad/s, %.2e m/s^2\n",
      velocity_error.norm(), held.velocity_error_mps, held.gyro_bias_radps, held.accel_bias_mps2,
      prior.velocity_error_mps, prior.gyro_bias_radps, prior.accel_bias_mps2);
  EXPECT_NEAR(held.velocity_error_mps, velocity_error.norm(), 1e-9);
  EXPECT_LT(prior.velocity_error_mps, 0.2 * velocity_error.norm());
  EXPECT_LT(prior.accel_bias_mps2, 0.25 * held.accel_bias_mps2);
  // A covariance that is not positive definite is refused.
  BaProblem bad = scene.truth;
  bad.inertial.states.front().velocity_fixed = false;
  bad.inertial.states.front().has_velocity_prior = true;
  bad.inertial.states.front().velocity_prior_covariance = -Eigen::Matrix3d::Identity();
  EXPECT_THROW(adjustBundle(&bad, configWith(RobustLoss::kNone)), std::invalid_argument);
}

TEST(AdjustBundle, LargeWindowUsesTheSparseSolverAndStillConverges) {
  // 40 free-ish keyframes exceed the dense Schur limit (30), so this goes through SPARSE_SCHUR.
  const BaProblem truth = makeDescentScene(40, 300, 3);
  BaProblem problem = truth;
  perturb(&problem, 0.5, 0.02, 0.01, 4);
  // Converged to the exact truth: Ceres' own criteria, not the early stop on small pose changes (that one
  // can leave about its tolerance times the extent of this noise-free error).
  BundleAdjustmentConfig config = configWith(RobustLoss::kNone);
  config.pose_change_tolerance = 0.0;
  const BaSummary s = adjustBundle(&problem, config);
  const Errors after = errorsAgainst(problem, truth);
  printErrors("after", after);
  EXPECT_TRUE(s.converged);
  EXPECT_LT(s.final_rms_px, 1e-3);
  EXPECT_LT(after.max_rot_deg, 1e-3);
  EXPECT_LT(after.max_trans_rel, 1e-4);
}

TEST(AdjustBundle, GaussianNoiseGivesNoiseLevelRmsAndMuchBetterPoses) {
  const BaProblem truth = makeDescentScene(10, 300, 5);
  BaProblem problem = truth;
  addPixelNoise(&problem, 0.5, 6);
  perturb(&problem, 0.5, 0.02, 0.01, 7);
  const Errors before = errorsAgainst(problem, truth);
  const BaSummary s = adjustBundle(&problem, configWith(RobustLoss::kHuber));
  const Errors after = errorsAgainst(problem, truth);
  printErrors("before", before);
  printErrors("after", after);
  const double truth_rms = rmsAtTruth(truth, problem);
  std::printf("  rms %.3f -> %.3f px in %d iterations (truth: %.3f px)\n", s.initial_rms_px, s.final_rms_px,
              s.iterations, truth_rms);

  EXPECT_TRUE(s.converged);
  // 2D noise of 0.5 px per axis has an RMS norm of 0.5 * sqrt(2) = 0.71 px; the fit absorbs a few percent of
  // it (~950 unknowns for ~5000 residuals), so the optimum fits the data better than the truth does.
  EXPECT_GT(s.final_rms_px, 0.6);
  EXPECT_LT(s.final_rms_px, truth_rms);
  // What remains of the pose error is the noise seen through the weak narrow-FOV geometry (rotation and
  // sideways translation nearly trade off at 300-500 m depth), a fraction of the 0.5 deg / 2 % start.
  EXPECT_LT(after.mean_rot_deg, 0.2 * before.mean_rot_deg);
  EXPECT_LT(after.mean_trans_rel, 0.2 * before.mean_trans_rel);
  // 0.5 px noise never reaches 3 * 2 px.
  EXPECT_TRUE(s.outliers.empty()) << s.outliers.size() << " outliers";
}

// Session 33 (docs/visual_core.md step 22): on the benchmark renders a fifth of the adjustments ran to
// max_iterations while their poses had stopped moving (one point sliding along its ray lowered the cost by
// 0.01 % per iteration). pose_change_tolerance stops a solve once an iteration moves no free keyframe by more
// than 1e-5 (rad, and of the window's extent). Here, with pixel noise and gross outliers under the Huber loss,
// it must stop in fewer iterations than Ceres' own criteria and leave the poses where the full solve puts
// them, well within the error the noise leaves against the truth.
TEST(AdjustBundle, APoseChangeToleranceStopsEarlierWhereThePosesAlreadyAre) {
  const BaProblem truth = makeDescentScene(10, 300, 21);
  BaProblem noisy = truth;
  addPixelNoise(&noisy, 0.5, 22);
  addOutliers(&noisy, 0.03, 8.0, 23);
  perturb(&noisy, 0.5, 0.02, 0.01, 24);
  BundleAdjustmentConfig full = configWith(RobustLoss::kHuber, 200);
  full.pose_change_tolerance = 0.0;
  BundleAdjustmentConfig early = full;
  early.pose_change_tolerance = 1e-5;
  BaProblem a = noisy, b = noisy;
  const BaSummary sa = adjustBundle(&a, full);
  const BaSummary sb = adjustBundle(&b, early);
  const Errors full_err = errorsAgainst(a, truth);
  const Errors early_err = errorsAgainst(b, truth);
  const Errors between = errorsAgainst(b, a);
  std::printf("  full: %d iterations, rms %.4f px; stopped on the poses: %d iterations, rms %.4f px\n",
              sa.iterations, sa.final_rms_px, sb.iterations, sb.final_rms_px);
  printErrors("full vs truth", full_err);
  printErrors("early vs truth", early_err);
  printErrors("early vs full", between);
  ASSERT_TRUE(sa.converged);
  ASSERT_TRUE(sb.converged);
  EXPECT_LT(sb.iterations, sa.iterations);
  // The poses of the two solves differ by a small fraction of what the noise leaves against the truth
  // (measured: 8 against 16 iterations; at most 7e-4 deg and 8e-6 of the baseline between them, 0.072 deg and
  // 1.5e-3 on average against the truth).
  EXPECT_LT(between.max_rot_deg, 0.03 * full_err.mean_rot_deg);
  EXPECT_LT(between.max_trans_rel, 0.03 * full_err.mean_trans_rel);
}

// Issue 12: the same window 200 km from the origin (a descent far from the landing site; the soak's loops
// each continuing where the last ended) must be solved as near it. With T_cam_world blocks, a rotation step
// moves t_cam_world by the rotation times the distance to the origin: uncentred, Levenberg-Marquardt needed
// more iterations there (the optimiser's CPU grew loop after loop in the soak). adjustBundle() solves about
// the mean camera centre.
TEST(AdjustBundle, AWindowFarFromTheOriginIsSolvedAsNearIt) {
  const BaProblem truth = makeDescentScene(10, 300, 5);
  BaProblem near = truth;
  addPixelNoise(&near, 0.5, 6);
  perturb(&near, 0.5, 0.02, 0.01, 7);
  const Eigen::Vector3d far_away(2.0e5, -1.0e5, 5.0e4);
  BaProblem far = near;
  for (BaKeyframe& kf : far.keyframes) kf.T_cam_world.translation() -= kf.T_cam_world.linear() * far_away;
  for (BaPoint& p : far.points) p.p_world += far_away;

  const BaSummary s_near = adjustBundle(&near, configWith(RobustLoss::kHuber));
  const BaSummary s_far = adjustBundle(&far, configWith(RobustLoss::kHuber));
  std::printf("  near: %d iterations, rms %.4f px; far: %d iterations, rms %.4f px\n", s_near.iterations,
              s_near.final_rms_px, s_far.iterations, s_far.final_rms_px);
  ASSERT_TRUE(s_near.converged && s_far.converged);
  EXPECT_EQ(s_far.iterations, s_near.iterations);
  EXPECT_NEAR(s_far.final_rms_px, s_near.final_rms_px, 1e-6);
  double max_point_m = 0.0, max_centre_m = 0.0;
  for (size_t j = 0; j < near.points.size(); ++j)
    max_point_m = std::max(max_point_m, (far.points[j].p_world - far_away - near.points[j].p_world).norm());
  for (size_t k = 0; k < near.keyframes.size(); ++k) {
    const Pose& a = near.keyframes[k].T_cam_world;
    const Pose& b = far.keyframes[k].T_cam_world;
    const Eigen::Vector3d c_near = -a.linear().transpose() * a.translation();
    const Eigen::Vector3d c_far = -b.linear().transpose() * b.translation() - far_away;
    max_centre_m = std::max(max_centre_m, (c_far - c_near).norm());
  }
  // The scene is 300-500 m deep: a micrometre is the rounding of positions 2e5 m from the origin.
  EXPECT_LT(max_point_m, 1e-4) << "points";
  EXPECT_LT(max_centre_m, 1e-4) << "camera centres";
}

class AdjustBundleOutliers : public ::testing::TestWithParam<RobustLoss> {};

TEST_P(AdjustBundleOutliers, RobustLossRecoversAndReportsOutliersWhereSquaredErrorDoesNot) {
  const BaProblem truth = makeDescentScene(10, 300, 8);
  BaProblem noisy = truth;
  addPixelNoise(&noisy, 0.5, 9);
  // Reference: the least-squares solution of the same noisy data without the outliers.
  BaProblem reference = noisy;
  perturb(&reference, 0.5, 0.02, 0.01, 11);
  adjustBundle(&reference, configWith(RobustLoss::kNone));
  const std::set<ObsKey> injected = addOutliers(&noisy, 0.05, 30.0, 10);
  perturb(&noisy, 0.5, 0.02, 0.01, 11);
  ASSERT_GT(injected.size(), 100u);

  BaProblem robust = noisy;
  const BaSummary s = adjustBundle(&robust, configWith(GetParam()));
  BaProblem plain = noisy;
  const BaSummary s_plain = adjustBundle(&plain, configWith(RobustLoss::kNone));
  const Errors e_robust = errorsAgainst(robust, truth);
  const Errors e_plain = errorsAgainst(plain, truth);
  printErrors(toString(GetParam()), e_robust);
  printErrors("none", e_plain);
  const auto d_robust = meanPoseDifference(robust, reference);
  const auto d_plain = meanPoseDifference(plain, reference);
  std::printf("  mean difference to the outlier-free solution: %s %.4f deg %.2e, none %.4f deg %.2e\n",
              toString(GetParam()), d_robust.first, d_robust.second, d_plain.first, d_plain.second);

  const std::set<ObsKey> reported = keysOf(s.outliers);
  size_t found = 0;
  for (const ObsKey& k : injected) found += reported.count(k);
  const size_t false_alarms = reported.size() - found;
  std::printf("  %zu injected, %zu reported, %zu found, %zu false alarms\n", injected.size(), reported.size(),
              found, false_alarms);

  EXPECT_TRUE(s.converged);
  EXPECT_GE(found, static_cast<size_t>(0.9 * injected.size()));
  EXPECT_LE(false_alarms, 3u);
  // The robust solution stays within the noise-level error (~0.04 deg, see the noise test) of the
  // outlier-free least-squares one: it converges fully (tighter Ceres tolerances change nothing); what is
  // left is the bounded pull of each outlier, up to the loss scale for Huber, less for Cauchy ...
  EXPECT_LT(d_robust.first, 0.05);
  EXPECT_LT(d_robust.second, 2.5e-3);
  EXPECT_LT(e_robust.mean_rot_deg, 0.1);
  // ... while the squared error, pulled by the outliers, is visibly worse, against both references.
  EXPECT_GT(d_plain.first, 5.0 * d_robust.first);
  EXPECT_GT(d_plain.second, 5.0 * d_robust.second);
  EXPECT_GT(e_plain.mean_rot_deg, 3.0 * e_robust.mean_rot_deg);
  EXPECT_GT(e_plain.mean_trans_rel, 3.0 * e_robust.mean_trans_rel);
  EXPECT_GT(e_plain.max_point_rel, 3.0 * e_robust.max_point_rel);
  EXPECT_TRUE(s_plain.converged);
}

INSTANTIATE_TEST_SUITE_P(HuberAndCauchy, AdjustBundleOutliers,
                         ::testing::Values(RobustLoss::kHuber, RobustLoss::kCauchy),
                         [](const ::testing::TestParamInfo<RobustLoss>& info) {
                           return std::string(toString(info.param));
                         });

TEST(AdjustBundle, SolveTimeOfATenKeyframeFiveHundredPointWindow) {
  // Not a timing assert: prints the number for the report; checks only that the solve is right.
  const BaProblem truth = makeDescentScene(10, 500, 12);
  BaProblem problem = truth;
  addPixelNoise(&problem, 0.5, 13);
  perturb(&problem, 0.5, 0.02, 0.01, 14);
  const BaSummary s =
      adjustBundle(&problem, BundleAdjustmentConfig{});  // defaults: Huber 2 px, 20 iterations
  std::printf("  10 keyframes, 500 points, %zu observations: %d iterations, %.1f ms (single thread)\n",
              problem.observations.size(), s.iterations, s.solve_ms);
  EXPECT_TRUE(s.converged);
  EXPECT_LT(s.final_rms_px, 0.75);
}

TEST(AdjustBundle, EmptyProblemIsTriviallyConverged) {
  BaProblem problem;
  const BaSummary s = adjustBundle(&problem, BundleAdjustmentConfig{});
  EXPECT_TRUE(s.converged);
  EXPECT_EQ(s.iterations, 0);
  EXPECT_EQ(s.initial_rms_px, 0.0);
  EXPECT_EQ(s.final_rms_px, 0.0);
  EXPECT_TRUE(s.outliers.empty());
}

TEST(AdjustBundle, AllFixedIsANoOpThatStillReportsTheError) {
  BaProblem problem = makeDescentScene(5, 50, 15);
  addPixelNoise(&problem, 0.5, 16);
  for (BaKeyframe& kf : problem.keyframes) kf.fixed = true;
  for (BaPoint& p : problem.points) p.fixed = true;
  const BaProblem before = problem;
  const BaSummary s = adjustBundle(&problem, BundleAdjustmentConfig{});
  EXPECT_TRUE(s.converged);
  EXPECT_EQ(s.iterations, 0);
  EXPECT_GT(s.initial_rms_px, 0.3);
  EXPECT_EQ(s.initial_rms_px, s.final_rms_px);
  for (size_t j = 0; j < problem.points.size(); ++j) {
    EXPECT_TRUE(problem.points[j].p_world == before.points[j].p_world);
  }
}

TEST(AdjustBundle, StructureOnlyWithAllKeyframesFixedRecoversThePoints) {
  const BaProblem truth = makeDescentScene(6, 100, 17);
  BaProblem problem = truth;
  for (BaKeyframe& kf : problem.keyframes) kf.fixed = true;
  perturb(&problem, 0.0, 0.0, 0.01, 18);
  ASSERT_GT(errorsAgainst(problem, truth).max_point_rel, 0.005);
  const BaSummary s = adjustBundle(&problem, configWith(RobustLoss::kCauchy));
  EXPECT_TRUE(s.converged);
  EXPECT_LT(errorsAgainst(problem, truth).max_point_rel, 1e-6);
  EXPECT_LT(s.final_rms_px, 1e-4);
}

TEST(AdjustBundle, BadIdsThrowAndLeaveTheProblemUntouched) {
  const BaProblem scene = makeDescentScene(4, 30, 19);
  const auto expectThrowUntouched = [&](BaProblem problem, const char* what) {
    perturb(&problem, 0.5, 0.02, 0.01, 20);
    const BaProblem before = problem;
    EXPECT_THROW(adjustBundle(&problem, BundleAdjustmentConfig{}), std::invalid_argument) << what;
    for (size_t k = 0; k < problem.keyframes.size(); ++k) {
      EXPECT_TRUE(problem.keyframes[k].T_cam_world.matrix() == before.keyframes[k].T_cam_world.matrix())
          << what;
    }
  };
  BaProblem missing_kf = scene;
  missing_kf.observations.push_back(BaObservation{999, scene.points[0].id, Eigen::Vector2d(1, 1)});
  expectThrowUntouched(missing_kf, "missing keyframe");
  BaProblem missing_pt = scene;
  missing_pt.observations.push_back(BaObservation{scene.keyframes[0].id, 999, Eigen::Vector2d(1, 1)});
  expectThrowUntouched(missing_pt, "missing point");
  BaProblem dup_kf = scene;
  dup_kf.keyframes.push_back(scene.keyframes[2]);
  expectThrowUntouched(dup_kf, "duplicate keyframe");
  BaProblem dup_pt = scene;
  dup_pt.points.push_back(scene.points[3]);
  expectThrowUntouched(dup_pt, "duplicate point");

  BaProblem ok = scene;
  BundleAdjustmentConfig bad_scale;
  bad_scale.robust_loss_scale_px = 0.0;
  EXPECT_THROW(adjustBundle(&ok, bad_scale), std::invalid_argument);
  BaProblem no_focal = scene;
  no_focal.fx = 0.0;
  EXPECT_THROW(adjustBundle(&no_focal, BundleAdjustmentConfig{}), std::invalid_argument);
}

TEST(AdjustBundle, PointBehindCameraIsReportedAndSinglyObservedPointIsHeldConstant) {
  const BaProblem truth = makeDescentScene(8, 200, 21);
  BaProblem problem = truth;
  const BaKeyframe& kf5 = truth.keyframes[5];
  const BaKeyframe& kf6 = truth.keyframes[6];
  // 50 m behind keyframe 5 (above it: the camera looks down), so also behind the lower keyframe 6, yet
  // "observed" by both.
  const Eigen::Vector3d behind =
      cameraCentre(kf5.T_cam_world) - 50.0 * kf5.T_cam_world.linear().row(2).transpose();
  problem.points.push_back(BaPoint{1, behind, false});
  problem.observations.push_back(BaObservation{kf5.id, 1, Eigen::Vector2d(200, 200)});
  problem.observations.push_back(BaObservation{kf6.id, 1, Eigen::Vector2d(210, 200)});
  // A terrain point seen only by keyframe 6, exactly. Were it free, it would soak up part of keyframe 6's
  // perturbation in the first iterations and end off its true position.
  const Eigen::Vector3d single(150.0, 60.0, terrainHeight(150.0, 60.0));
  Eigen::Vector2d single_px;
  ASSERT_TRUE(project(kf6.T_cam_world, single, &single_px));
  problem.points.push_back(BaPoint{2, single, false});
  problem.observations.push_back(BaObservation{kf6.id, 2, single_px});

  perturb(&problem, 0.5, 0.02, 0.0, 22);
  problem.points[problem.points.size() - 1].p_world = single;  // perturb() moved neither (point_frac 0)
  const BaSummary s = adjustBundle(&problem, configWith(RobustLoss::kHuber));
  EXPECT_TRUE(s.converged);
  const std::set<ObsKey> reported = keysOf(s.outliers);
  EXPECT_EQ(reported.count({kf5.id, 1}), 1u) << "behind-camera observation not reported";
  EXPECT_EQ(reported.count({kf6.id, 1}), 1u) << "behind-camera observation not reported";
  EXPECT_EQ(reported.count({kf6.id, 2}), 0u);
  EXPECT_TRUE(problem.points[problem.points.size() - 2].p_world == behind);
  EXPECT_TRUE(problem.points.back().p_world == single);
  problem.points.resize(truth.points.size());
  const Errors after = errorsAgainst(problem, truth);
  // The unusable observations are left out, the rest is exact: the window still returns to the truth.
  EXPECT_LT(after.max_rot_deg, 1e-3);
  EXPECT_LT(after.max_trans_rel, 1e-4);
  EXPECT_LT(s.final_rms_px, 1e-3);
}

// ------------------------------------------------------------------------------------------------------------
// refinePose
// ------------------------------------------------------------------------------------------------------------

struct PoseFixture {
  Pose truth;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> px;
};

PoseFixture poseFixture(uint64_t seed) {
  const BaProblem scene = makeDescentScene(10, 300, seed);
  PoseFixture f;
  const BaKeyframe& kf = scene.keyframes[5];
  f.truth = kf.T_cam_world;
  for (const BaObservation& o : scene.observations) {
    if (o.keyframe_id != kf.id) continue;
    f.points.push_back(scene.points[o.point_id - 5000].p_world);
    f.px.push_back(o.px);
  }
  return f;
}

Pose perturbedPose(const Pose& T_cam_world, double rot_deg, double centre_m, uint64_t seed) {
  std::mt19937 rng(seed);
  const Eigen::Matrix3d R_world_cam =
      T_cam_world.linear().transpose() * Eigen::AngleAxisd(rot_deg * kDegToRad, randomUnit(&rng));
  const Eigen::Vector3d c = cameraCentre(T_cam_world) + centre_m * randomUnit(&rng);
  Pose T = Pose::Identity();
  T.linear() = R_world_cam.transpose();
  T.translation() = -R_world_cam.transpose() * c;
  return T;
}

TEST(RefinePose, RecoversAPerturbedPoseFromExactFixedPoints) {
  const PoseFixture f = poseFixture(23);
  ASSERT_GT(f.points.size(), 100u);
  Pose T = perturbedPose(f.truth, 2.0, 10.0, 24);
  const BaSummary s = refinePose(&T, f.points, f.px, kFx, kFy, kCx, kCy, configWith(RobustLoss::kHuber));
  EXPECT_TRUE(s.converged);
  EXPECT_GT(s.initial_rms_px, 5.0);
  EXPECT_LT(s.final_rms_px, 1e-6);
  EXPECT_LT(rotationAngleDeg(T.linear() * f.truth.linear().transpose()), 1e-6);
  EXPECT_LT((cameraCentre(T) - cameraCentre(f.truth)).norm(), 1e-5);  // metres, at ~390 m altitude
}

TEST(RefinePose, RobustLossRejectsOutliersAndReportsThemByIndex) {
  PoseFixture f = poseFixture(25);
  std::mt19937 rng(26);
  std::normal_distribution<double> noise(0.0, 0.5);
  std::set<uint64_t> injected;
  for (size_t i = 0; i < f.px.size(); ++i) {
    f.px[i] += Eigen::Vector2d(noise(rng), noise(rng));
    if (i % 10 == 3) {  // 10 % outliers
      f.px[i] += Eigen::Vector2d(30.0, 0.0);
      injected.insert(i);
    }
  }
  const Pose start = perturbedPose(f.truth, 2.0, 10.0, 27);
  // Reference: least squares over the inliers alone.
  std::vector<Eigen::Vector3d> inlier_points;
  std::vector<Eigen::Vector2d> inlier_px;
  for (size_t i = 0; i < f.px.size(); ++i) {
    if (injected.count(i)) continue;
    inlier_points.push_back(f.points[i]);
    inlier_px.push_back(f.px[i]);
  }
  Pose reference = start;
  ASSERT_TRUE(
      refinePose(&reference, inlier_points, inlier_px, kFx, kFy, kCx, kCy, configWith(RobustLoss::kNone))
          .converged);
  Pose plain = start;
  ASSERT_TRUE(
      refinePose(&plain, f.points, f.px, kFx, kFy, kCx, kCy, configWith(RobustLoss::kNone)).converged);
  Pose T = start;
  const BaSummary s = refinePose(&T, f.points, f.px, kFx, kFy, kCx, kCy, configWith(RobustLoss::kCauchy));
  EXPECT_TRUE(s.converged);
  const auto centreDiff = [](const Pose& a, const Pose& b) {
    return (cameraCentre(a) - cameraCentre(b)).norm();
  };
  const auto rotDiff = [](const Pose& a, const Pose& b) {
    return rotationAngleDeg(a.linear() * b.linear().transpose());
  };
  std::printf(
      "  vs truth: cauchy %.4f deg %.3f m, none %.4f deg %.3f m; vs inlier-only fit: cauchy %.4f deg "
      "%.3f m, none %.4f deg %.3f m\n",
      rotDiff(T, f.truth), centreDiff(T, f.truth), rotDiff(plain, f.truth), centreDiff(plain, f.truth),
      rotDiff(T, reference), centreDiff(T, reference), rotDiff(plain, reference),
      centreDiff(plain, reference));
  EXPECT_LT(rotDiff(T, reference), 0.04);
  EXPECT_LT(centreDiff(T, reference), 0.3);
  EXPECT_LT(rotDiff(T, f.truth), 0.15);
  EXPECT_LT(centreDiff(T, f.truth), 1.0);
  EXPECT_GT(rotDiff(plain, reference), 5.0 * rotDiff(T, reference));
  EXPECT_GT(centreDiff(plain, reference), 5.0 * centreDiff(T, reference));
  std::set<uint64_t> reported;
  for (const BaObservation& o : s.outliers) {
    EXPECT_EQ(o.keyframe_id, 0u);
    reported.insert(o.point_id);
  }
  EXPECT_EQ(reported, injected);
}

TEST(RefinePose, WithoutUsablePointsReportsFailureAndKeepsThePose) {
  const Pose start = perturbedPose(Pose::Identity(), 1.0, 1.0, 28);
  Pose T = start;
  const BaSummary empty = refinePose(&T, {}, {}, kFx, kFy, kCx, kCy, BundleAdjustmentConfig{});
  EXPECT_FALSE(empty.converged);
  // Every point behind the camera.
  const BaSummary behind =
      refinePose(&T, {cameraCentre(T) - 10.0 * T.linear().row(2).transpose()}, {Eigen::Vector2d(100, 100)},
                 kFx, kFy, kCx, kCy, BundleAdjustmentConfig{});
  EXPECT_FALSE(behind.converged);
  EXPECT_EQ(behind.outliers.size(), 1u);
  EXPECT_TRUE(T.matrix() == start.matrix());
  EXPECT_THROW(refinePose(&T, {Eigen::Vector3d::Zero()}, {}, kFx, kFy, kCx, kCy, BundleAdjustmentConfig{}),
               std::invalid_argument);
}

// ------------------------------------------------------------------------------------------------------------
// AsyncBundleAdjuster
// ------------------------------------------------------------------------------------------------------------

/// A window big enough that its solve takes a while (tens of keyframes, thousands of points).
BaProblem bigProblem(uint64_t seed) {
  BaProblem problem = makeDescentScene(20, 2000, seed);
  addPixelNoise(&problem, 0.5, seed + 1);
  perturb(&problem, 0.5, 0.02, 0.01, seed + 2);
  return problem;
}

TEST(AsyncBundleAdjuster, GivesTheSameResultAsTheSynchronousCall) {
  BaProblem problem = makeDescentScene(10, 300, 30);
  addPixelNoise(&problem, 0.5, 31);
  perturb(&problem, 0.5, 0.02, 0.01, 32);
  const BundleAdjustmentConfig config = configWith(RobustLoss::kHuber, 20);

  BaProblem sync = problem;
  const BaSummary s_sync = adjustBundle(&sync, config);

  AsyncBundleAdjuster async(config);
  EXPECT_FALSE(async.busy());
  EXPECT_FALSE(async.takeResult().has_value());  // nothing submitted yet
  async.submit(problem);
  async.waitIdle();
  EXPECT_FALSE(async.busy());
  auto result = async.takeResult();
  ASSERT_TRUE(result.has_value());
  EXPECT_FALSE(async.takeResult().has_value());  // consumed

  const BaProblem& out = result->first;
  const BaSummary& s = result->second;
  EXPECT_EQ(s.iterations, s_sync.iterations);
  EXPECT_DOUBLE_EQ(s.final_rms_px, s_sync.final_rms_px);
  EXPECT_EQ(s.outliers.size(), s_sync.outliers.size());
  ASSERT_EQ(out.keyframes.size(), sync.keyframes.size());
  for (size_t k = 0; k < sync.keyframes.size(); ++k) {
    EXPECT_TRUE(out.keyframes[k].T_cam_world.isApprox(sync.keyframes[k].T_cam_world, 1e-12)) << k;
  }
  for (size_t j = 0; j < sync.points.size(); ++j) {
    EXPECT_TRUE(out.points[j].p_world.isApprox(sync.points[j].p_world, 1e-12)) << j;
  }
}

TEST(AsyncBundleAdjuster, NoResultBeforeCompletionAndNewestQueuedProblemWins) {
  AsyncBundleAdjuster async(configWith(RobustLoss::kHuber, 20));
  async.submit(bigProblem(40));
  // Poll right after submitting: while the worker is still busy after takeResult() returned, that call cannot
  // have seen this solve finished, so it must have come back empty.
  const auto early = async.takeResult();
  const bool still_busy = async.busy();
  ASSERT_TRUE(still_busy) << "the big solve finished within microseconds?";
  EXPECT_FALSE(early.has_value());

  // Queue two more: the middle one is superseded before the worker gets to it.
  BaProblem middle = makeDescentScene(5, 50, 41);
  BaProblem newest = makeDescentScene(6, 60, 42);
  perturb(&newest, 0.5, 0.02, 0.01, 43);
  for (BaKeyframe& kf : newest.keyframes) kf.id += 1000;
  for (BaObservation& o : newest.observations) o.keyframe_id += 1000;
  async.submit(middle);
  async.submit(newest);
  EXPECT_TRUE(async.busy());
  async.waitIdle();
  auto result = async.takeResult();
  ASSERT_TRUE(result.has_value());
  EXPECT_EQ(result->first.keyframes.size(), 6u);
  EXPECT_EQ(result->first.keyframes.front().id, 1100u);
  EXPECT_LT(result->second.final_rms_px, 1e-3);
  EXPECT_FALSE(async.takeResult().has_value());
}

TEST(AsyncBundleAdjuster, BadProblemIsRethrownByTakeResultAndTheWorkerCarriesOn) {
  AsyncBundleAdjuster async(BundleAdjustmentConfig{});
  BaProblem bad = makeDescentScene(4, 30, 50);
  bad.observations.push_back(BaObservation{12345, bad.points[0].id, Eigen::Vector2d(1, 1)});
  async.submit(bad);
  async.waitIdle();
  EXPECT_THROW(async.takeResult(), std::invalid_argument);
  EXPECT_FALSE(async.takeResult().has_value());

  BaProblem good = makeDescentScene(4, 30, 51);
  perturb(&good, 0.5, 0.02, 0.01, 52);
  async.submit(good);
  async.waitIdle();
  const auto result = async.takeResult();
  ASSERT_TRUE(result.has_value());
  EXPECT_TRUE(result->second.converged);
}

TEST(AsyncBundleAdjuster, DestructorWhileBusyAbortsTheSolve) {
  // No timing assert (shared machine): the test fails by hanging if the destructor deadlocks. The times are
  // printed to show that destruction waits about one iteration, not the whole solve.
  const BaProblem problem = bigProblem(60);
  const BundleAdjustmentConfig config = configWith(RobustLoss::kCauchy, 100);
  BaProblem sync = problem;
  const BaSummary s = adjustBundle(&sync, config);

  auto async = std::make_unique<AsyncBundleAdjuster>(config);
  async->submit(problem);
  async->submit(problem);  // queued behind the running one: must be dropped, not solved
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_TRUE(async->busy());
  const auto t0 = std::chrono::steady_clock::now();
  async.reset();
  const double destroy_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("  full solve %.0f ms (%d iterations); destructor returned after %.0f ms\n", s.solve_ms,
              s.iterations, destroy_ms);
  EXPECT_TRUE(s.converged);
}

/// The nice values of this process's threads other than the calling one (Linux: /proc/self/task/TID/stat,
/// field 19).
std::vector<int> otherThreadsNice() {
  std::vector<int> out;
  const std::string self = std::to_string(syscall(SYS_gettid));
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/task")) {
    if (entry.path().filename() == self) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    const size_t paren = text.rfind(')');  // the command name may hold spaces
    if (paren == std::string::npos) continue;
    std::istringstream fields(text.substr(paren + 2));
    std::string field;
    for (int k = 3; k <= 19 && fields >> field; ++k)
      if (k == 19) out.push_back(std::stoi(field));
  }
  return out;
}

TEST(AsyncBundleAdjuster, TheWorkerRunsAtTheConfiguredNiceValue) {
  // The optimiser thread yields a shared core to the tracking: its nice value is
  // bundle_adjustment.thread_nice.
  for (const int nice : {7, 0}) {
    SCOPED_TRACE(nice);
    BundleAdjustmentConfig config;
    config.thread_nice = nice;
    AsyncBundleAdjuster async(config);
    BaProblem problem = bigProblem(10);
    async.submit(problem);
    async.waitIdle();  // the worker has started (and set its priority) once it has solved a problem
    const std::vector<int> others = otherThreadsNice();
    const int at_seven = static_cast<int>(std::count(others.begin(), others.end(), 7));
    EXPECT_EQ(at_seven, nice == 7 ? 1 : 0);
    EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))), 0)
        << "the caller's own priority";
  }
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
