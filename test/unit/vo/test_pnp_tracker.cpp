/// Tests of the PnpTracker on synthetic terrain points seen from a known pose: accuracy with pixel noise,
/// outliers found and flagged, and failure (not a guess) when too few points are in view; the pose from the
/// motion model's prediction without RANSAC, and the fall-back to RANSAC when the prediction is wrong.

#include <iostream>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose_gauss_newton.h"
#include "planetary_vo/vo/bundle_adjuster.h"
#include "planetary_vo/vo/pnp_tracker.h"

namespace planetary_vo {
namespace {

struct Scene {
  PinholeCamera camera = PinholeCamera::fromFieldOfView(640, 480, 60.0);
  Pose T_world_cam = Pose::Identity();
  std::vector<Eigen::Vector3d> p_world;
  std::vector<Eigen::Vector2d> px;
  std::vector<bool> is_outlier;
};

/// Rolling terrain (z up, heights +-30 m) under a camera 400 m up, looking down and slightly tilted.
Scene makeScene(int num_points, double noise_px, double outlier_ratio, unsigned seed) {
  Scene s;
  Eigen::Matrix3d R_world_cam;
  R_world_cam.col(0) = Eigen::Vector3d::UnitX();
  R_world_cam.col(1) = -Eigen::Vector3d::UnitY();
  R_world_cam.col(2) = -Eigen::Vector3d::UnitZ();
  s.T_world_cam.linear() =
      Eigen::AngleAxisd(0.1, Eigen::Vector3d(1, 2, 0).normalized()).toRotationMatrix() * R_world_cam;
  s.T_world_cam.translation() = Eigen::Vector3d(20.0, -35.0, 400.0);
  const Pose T_cam_world = s.T_world_cam.inverse();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  while (static_cast<int>(s.p_world.size()) < num_points) {
    const Eigen::Vector2d px_true(u(rng) * 639.0, u(rng) * 479.0);
    const Eigen::Vector3d ray_world = s.T_world_cam.linear() * s.camera.pixelToBearing(px_true);
    const double lambda = -s.T_world_cam.translation().z() / ray_world.z();  // hit z = 0 ...
    Eigen::Vector3d p = s.T_world_cam.translation() + lambda * ray_world;
    p.z() = 30.0 * std::sin(p.x() / 40.0) * std::cos(p.y() / 55.0);  // ... then move onto the relief
    const Eigen::Vector3d p_cam = T_cam_world * p;
    Eigen::Vector2d px = s.camera.project(p_cam) + Eigen::Vector2d(noise(rng), noise(rng));
    const bool outlier = u(rng) < outlier_ratio;
    if (outlier) px += Eigen::Vector2d(20.0 + 40.0 * u(rng), -20.0 - 40.0 * u(rng));
    s.p_world.push_back(p);
    s.px.push_back(px);
    s.is_outlier.push_back(outlier);
  }
  return s;
}

TEST(PnpTracker, RecoversThePoseAndFlagsOutliers) {
  const Scene s = makeScene(200, 0.5, 0.2, 3);
  PnpTracker tracker{PnpConfig(), BundleAdjustmentConfig()};
  const PnpTrackResult r = tracker.track(s.p_world, s.px, s.camera.K());
  ASSERT_TRUE(r.valid) << r.reason;
  EXPECT_LT((r.T_world_cam.translation() - s.T_world_cam.translation()).norm(), 0.5);  // m at 400 m altitude
  EXPECT_LT(rotationAngleDeg(r.T_world_cam.linear().transpose() * s.T_world_cam.linear()), 0.05);
  int flagged_outliers = 0, outliers = 0, lost_inliers = 0;
  for (size_t i = 0; i < s.is_outlier.size(); ++i) {
    outliers += s.is_outlier[i] ? 1 : 0;
    if (s.is_outlier[i] && !r.inlier_mask[i]) ++flagged_outliers;
    if (!s.is_outlier[i] && !r.inlier_mask[i]) ++lost_inliers;
  }
  EXPECT_EQ(flagged_outliers, outliers);
  EXPECT_LE(lost_inliers, 3);
  EXPECT_LT(r.reprojection_rms_px, 1.0);
  EXPECT_EQ(r.num_points, 200);
}

TEST(PnpTracker, WithoutRefinementStillAccurate) {
  const Scene s = makeScene(150, 0.3, 0.0, 5);
  PnpConfig cfg;
  cfg.refine = false;
  PnpTracker tracker{cfg, BundleAdjustmentConfig()};
  const PnpTrackResult r = tracker.track(s.p_world, s.px, s.camera.K());
  ASSERT_TRUE(r.valid) << r.reason;
  EXPECT_LT((r.T_world_cam.translation() - s.T_world_cam.translation()).norm(), 1.0);
}

TEST(PnpTracker, TooFewPointsFail) {
  const Scene s = makeScene(10, 0.3, 0.0, 7);
  PnpTracker tracker{PnpConfig(), BundleAdjustmentConfig()};  // min_inliers 15
  const PnpTrackResult r = tracker.track(s.p_world, s.px, s.camera.K());
  EXPECT_FALSE(r.valid);
  EXPECT_NE(r.reason.find("too few"), std::string::npos);
}

TEST(PnpTracker, MostlyOutliersFail) {
  const Scene s = makeScene(60, 0.3, 0.9, 11);
  PnpTracker tracker{PnpConfig(), BundleAdjustmentConfig()};
  EXPECT_FALSE(tracker.track(s.p_world, s.px, s.camera.K()).valid);
}

/// The pose within 0.5 m (at 400 m altitude) and 0.05 deg of the truth.
void expectTruePose(const PnpTrackResult& r, const Scene& s) {
  EXPECT_LT((r.T_world_cam.translation() - s.T_world_cam.translation()).norm(), 0.5);
  EXPECT_LT(rotationAngleDeg(r.T_world_cam.linear().transpose() * s.T_world_cam.linear()), 0.05);
}

/// The true pose turned by `deg` about a tilted axis and moved by `m` metres: a motion model's prediction.
Pose predictionOff(const Pose& T_world_cam, double deg, double m) {
  Pose T = T_world_cam;
  T.linear() =
      Eigen::AngleAxisd(deg * M_PI / 180.0, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix() *
      T_world_cam.linear();
  T.translation() += m * Eigen::Vector3d(0.6, 0.8, 0.0);
  return T;
}

TEST(PnpTracker, APredictionCloseEnoughNeedsNoRansac) {
  // 1 deg and 8 m off at 400 m (about 10-20 px): the refinement from the prediction finds the pose, flags the
  // same outliers as RANSAC would and is as accurate.
  const Scene s = makeScene(200, 0.5, 0.2, 3);
  PnpTracker tracker{PnpConfig(), BundleAdjustmentConfig()};
  const Pose predicted = predictionOff(s.T_world_cam, 1.0, 8.0);
  const PnpTrackResult r = tracker.track(s.p_world, s.px, s.camera.K(), &predicted);
  ASSERT_TRUE(r.valid) << r.reason;
  EXPECT_TRUE(r.from_prediction);
  const PnpTrackResult ransac = tracker.track(s.p_world, s.px, s.camera.K());
  ASSERT_TRUE(ransac.valid);
  EXPECT_FALSE(ransac.from_prediction);
  expectTruePose(r, s);
  // The same optimum as from RANSAC's start.
  EXPECT_LT((r.T_world_cam.translation() - ransac.T_world_cam.translation()).norm(), 1e-3);
  EXPECT_EQ(r.inlier_mask, ransac.inlier_mask);
  for (size_t i = 0; i < s.is_outlier.size(); ++i) {
    if (s.is_outlier[i]) {
      EXPECT_FALSE(r.inlier_mask[i]) << i;
    }
  }
}

TEST(PnpTracker, AWrongPredictionFallsBackToRansac) {
  // Turned 150 deg away (a motion model gone wrong): the refinement from there cannot see the points (few
  // inliers); RANSAC finds the pose.
  const Scene s = makeScene(200, 0.5, 0.2, 3);
  PnpTracker tracker{PnpConfig(), BundleAdjustmentConfig()};
  const Pose predicted = predictionOff(s.T_world_cam, 150.0, 150.0);
  const PnpTrackResult r = tracker.track(s.p_world, s.px, s.camera.K(), &predicted);
  ASSERT_TRUE(r.valid) << r.reason;
  EXPECT_FALSE(r.from_prediction);
  expectTruePose(r, s);
}

TEST(PnpTracker, WithoutFromPredictionEveryFrameIsRansac) {
  const Scene s = makeScene(200, 0.5, 0.2, 3);
  PnpConfig config;
  config.from_prediction = false;
  PnpTracker tracker{config, BundleAdjustmentConfig()};
  const Pose predicted = s.T_world_cam;  // even a perfect prediction
  const PnpTrackResult r = tracker.track(s.p_world, s.px, s.camera.K(), &predicted);
  ASSERT_TRUE(r.valid) << r.reason;
  EXPECT_FALSE(r.from_prediction);
}

TEST(PnpTracker, TheRefinementIsCeresMotionOnlyProblem) {
  // pose_gauss_newton.h solves the problem of bundle_adjuster.h's refinePose (Ceres): same residual, same
  // Huber loss. From the same start both reach the same pose.
  const Scene s = makeScene(200, 0.5, 0.2, 13);
  const Pose start = predictionOff(s.T_world_cam, 0.5, 3.0).inverse();
  const BundleAdjustmentConfig ba;
  Pose T_ceres = start;
  const Eigen::Matrix3d K = s.camera.K();
  ASSERT_TRUE(refinePose(&T_ceres, s.p_world, s.px, K(0, 0), K(1, 1), K(0, 2), K(1, 2), ba).converged);
  Pose T_gn = start;
  PoseGaussNewtonOptions options;
  options.loss_scale_px = ba.robust_loss_scale_px;
  ASSERT_TRUE(refinePoseGaussNewton(&T_gn, s.p_world, s.px, K, options).converged);
  EXPECT_LT((T_gn.inverse().translation() - T_ceres.inverse().translation()).norm(), 1e-3);  // m at 400 m
  EXPECT_LT(rotationAngleDeg(T_gn.linear() * T_ceres.linear().transpose()), 1e-4);
}

TEST(PnpTracker, ASmallerLossScaleKeepsSlippedTracksOfPreciseTracking) {
  // Anchor-aligned tracks: 0.1 px noise; a sixth of them slipped 1.5-4 px the same way (along a shadow edge,
  // a patch drifting on its anchor), within RANSAC's 2 px threshold or just over it. The Huber loss at 0.5 px
  // (robust_loss_scale_aligned_px) down-weights them to about a quarter of what 2 px (the LK scale) leaves
  // them, so the pose they pull is at least 2x closer to the truth. Measured: 0.56 / 0.18 m and 0.035 / 0.013
  // deg (2 px / 0.5 px); with a fifth or a quarter slipped, 2.5-3.2x.
  Scene s = makeScene(300, 0.1, 0.0, 21);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int slipped = 0;
  for (size_t i = 0; i < s.px.size(); ++i) {
    if (u(rng) >= 1.0 / 6.0) continue;
    s.px[i] += (1.5 + 2.5 * u(rng)) * Eigen::Vector2d(0.8, 0.6);
    ++slipped;
  }
  ASSERT_GT(slipped, 40);
  auto errors = [&s](double loss_scale_px) {
    PnpTracker tracker{PnpConfig(), BundleAdjustmentConfig()};
    tracker.setRobustLossScale(loss_scale_px);
    const Pose predicted = s.T_world_cam;
    const PnpTrackResult r = tracker.track(s.p_world, s.px, s.camera.K(), &predicted);
    EXPECT_TRUE(r.valid) << r.reason;
    return std::make_pair((r.T_world_cam.translation() - s.T_world_cam.translation()).norm(),
                          rotationAngleDeg(r.T_world_cam.linear().transpose() * s.T_world_cam.linear()));
  };
  const auto lk_scale = errors(BundleAdjustmentConfig().robust_loss_scale_px);
  const auto aligned_scale = errors(BundleAdjustmentConfig().robust_loss_scale_aligned_px);
  std::cout << "slipped tracks: loss scale 2 px: " << lk_scale.first << " m, " << lk_scale.second
            << " deg; 0.5 px: " << aligned_scale.first << " m, " << aligned_scale.second << " deg\n";
  EXPECT_LT(aligned_scale.first, 0.5 * lk_scale.first);
  EXPECT_LT(aligned_scale.second, 0.5 * lk_scale.second);
  EXPECT_THROW(PnpTracker(PnpConfig(), BundleAdjustmentConfig()).setRobustLossScale(0.0),
               std::invalid_argument);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
