/// Tests of twoViewConditioning (geometry/two_view_conditioning.h): its sigmas are the marginal covariance of
/// a two-view adjustment computed the long way (a numerical Jacobian of both views' pixels over the motion
/// and every point, the whole normal matrix inverted), they grow when the same number of points covers a
/// small part of the view, scale with the pixel noise, and an undetermined motion is reported as such.

#include <cmath>
#include <iostream>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "planetary_vo/geometry/synthetic_scene.h"
#include "planetary_vo/geometry/two_view_conditioning.h"

namespace planetary_vo {
namespace {

SyntheticTwoViewScene sceneOf(int num_points, double xy_half_extent, std::uint32_t seed = 3) {
  SyntheticSceneConfig cfg;
  cfg.num_points = num_points;
  cfg.xy_half_extent = xy_half_extent;
  cfg.depth_min = 1500.0;
  cfg.depth_spread = 300.0;
  cfg.baseline = 60.0;
  cfg.centre_direction_c1 = Eigen::Vector3d(0.6, -0.3, 0.75);
  cfg.rotation_deg = 1.5;
  cfg.seed = seed;
  return makeSyntheticScene(cfg);
}

double largestSigmaDeg(const Eigen::MatrixXd& covariance_block) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(covariance_block);
  return std::sqrt(eig.eigenvalues().maxCoeff()) * 180.0 / M_PI;
}

TEST(TwoViewConditioning, TheSigmasAreTheMarginalCovarianceOfAWholeTwoViewAdjustment) {
  const SyntheticTwoViewScene s = sceneOf(25, 1000.0);
  const double fx = s.camera.fx(), fy = s.camera.fy(), sigma_px = 0.7;
  const TwoViewConditioning c = twoViewConditioning(s.points_c1, s.T_c2_c1, fx, fy, sigma_px);
  ASSERT_TRUE(c.valid);

  // The long way: pixels of both views as a function of (rotation perturbation, direction perturbation in any
  // orthonormal basis of its tangent plane, every point), differentiated numerically; the whole normal matrix
  // is inverted and the motion's 5x5 block read off.
  const Eigen::Matrix3d R = s.T_c2_c1.linear();
  const Eigen::Vector3d t = s.T_c2_c1.translation();
  const Eigen::Vector3d dir = t.normalized();
  const Eigen::Vector3d e1 = dir.unitOrthogonal(), e2 = dir.cross(e1);
  const int n = static_cast<int>(s.points_c1.size()), num_params = 5 + 3 * n;
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(num_params);
  for (int i = 0; i < n; ++i) x0.segment<3>(5 + 3 * i) = s.points_c1[static_cast<size_t>(i)];
  const auto pixels = [&](const Eigen::VectorXd& x) {
    const Eigen::Vector3d w = x.head<3>();
    const Eigen::Matrix3d Rw =
        (w.norm() > 0.0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                        : Eigen::Matrix3d::Identity()) *
        R;
    const Eigen::Vector3d tw = t.norm() * (dir + x(3) * e1 + x(4) * e2).normalized();
    Eigen::VectorXd out(4 * n);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p1 = x.segment<3>(5 + 3 * i), p2 = Rw * p1 + tw;
      out.segment<4>(4 * i) << fx * p1.x() / p1.z(), fy * p1.y() / p1.z(), fx * p2.x() / p2.z(),
          fy * p2.y() / p2.z();
    }
    return out;
  };
  Eigen::MatrixXd J(4 * n, num_params);
  for (int k = 0; k < num_params; ++k) {
    const double h = k < 5 ? 1e-7 : 1e-4;
    Eigen::VectorXd plus = x0, minus = x0;
    plus(k) += h;
    minus(k) -= h;
    J.col(k) = (pixels(plus) - pixels(minus)) / (2.0 * h);
  }
  const Eigen::MatrixXd covariance = sigma_px * sigma_px * (J.transpose() * J).inverse();
  const double rotation_deg = largestSigmaDeg(covariance.topLeftCorner(3, 3));
  const double direction_deg = largestSigmaDeg(covariance.block(3, 3, 2, 2));
  EXPECT_NEAR(c.rotation_sigma_deg, rotation_deg, 1e-3 * rotation_deg);
  EXPECT_NEAR(c.direction_sigma_deg, direction_deg, 1e-3 * direction_deg);
}

TEST(TwoViewConditioning, PointsInASmallPartOfTheViewLeaveTheRotationUndetermined) {
  // 200 points over the whole 60-degree view, and 200 over a patch of 1/100 of it (a lit strip of ground in a
  // shadowed view): the same motion, the same pixel noise.
  const SyntheticTwoViewScene whole = sceneOf(200, 1000.0), patch = sceneOf(200, 100.0);
  const double fx = whole.camera.fx(), fy = whole.camera.fy();
  const TwoViewConditioning w = twoViewConditioning(whole.points_c1, whole.T_c2_c1, fx, fy, 1.0);
  const TwoViewConditioning p = twoViewConditioning(patch.points_c1, patch.T_c2_c1, fx, fy, 1.0);
  ASSERT_TRUE(w.valid && p.valid);
  std::cout << "rotation 1-sigma at 1 px: whole view " << w.rotation_sigma_deg << " deg, patch "
            << p.rotation_sigma_deg << " deg; direction of travel " << w.direction_sigma_deg << " / "
            << p.direction_sigma_deg << " deg\n";
  EXPECT_LT(w.rotation_sigma_deg, 0.2);
  EXPECT_GT(p.rotation_sigma_deg, 1.0);
  EXPECT_GT(p.rotation_sigma_deg, 10.0 * w.rotation_sigma_deg);
  EXPECT_GT(p.direction_sigma_deg, 5.0 * w.direction_sigma_deg);
}

TEST(TwoViewConditioning, SigmasScaleWithThePixelNoiseAndTheNumberOfPoints) {
  const SyntheticTwoViewScene s = sceneOf(100, 1000.0);
  const double fx = s.camera.fx(), fy = s.camera.fy();
  const TwoViewConditioning one = twoViewConditioning(s.points_c1, s.T_c2_c1, fx, fy, 1.0);
  const TwoViewConditioning half = twoViewConditioning(s.points_c1, s.T_c2_c1, fx, fy, 0.5);
  EXPECT_NEAR(half.rotation_sigma_deg, 0.5 * one.rotation_sigma_deg, 1e-9);
  EXPECT_NEAR(half.direction_sigma_deg, 0.5 * one.direction_sigma_deg, 1e-9);
  std::vector<Eigen::Vector3d> twice = s.points_c1;
  twice.insert(twice.end(), s.points_c1.begin(), s.points_c1.end());
  const TwoViewConditioning doubled = twoViewConditioning(twice, s.T_c2_c1, fx, fy, 1.0);
  EXPECT_NEAR(doubled.rotation_sigma_deg, one.rotation_sigma_deg / std::sqrt(2.0), 1e-6);
}

TEST(TwoViewConditioning, AnUndeterminedMotionIsReportedNotGuessed) {
  const SyntheticTwoViewScene s = sceneOf(50, 1000.0);
  const double fx = s.camera.fx(), fy = s.camera.fy();
  EXPECT_FALSE(twoViewConditioning({}, s.T_c2_c1, fx, fy, 1.0).valid);
  Pose no_translation = s.T_c2_c1;
  no_translation.translation().setZero();
  EXPECT_FALSE(twoViewConditioning(s.points_c1, no_translation, fx, fy, 1.0).valid);
  // Two points cannot determine five degrees of freedom.
  const std::vector<Eigen::Vector3d> two(s.points_c1.begin(), s.points_c1.begin() + 2);
  const TwoViewConditioning c = twoViewConditioning(two, s.T_c2_c1, fx, fy, 1.0);
  EXPECT_FALSE(c.valid);
  EXPECT_FALSE(c.rotation_sigma_deg <= 180.0);
  // Points behind camera 1 are not counted.
  std::vector<Eigen::Vector3d> behind = s.points_c1;
  for (Eigen::Vector3d& p : behind) p.z() = -p.z();
  EXPECT_FALSE(twoViewConditioning(behind, s.T_c2_c1, fx, fy, 1.0).valid);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
