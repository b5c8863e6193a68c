/// Planarity detection: the H-vs-F score says planar for planar scenes and non-planar for spread depths.

#include <gtest/gtest.h>
#include "unit/geometry/geometry_test_scene.h"

#include "planetary_vo/geometry/model_selection.h"
#include "planetary_vo/geometry/synthetic_scene.h"

namespace planetary_vo {
namespace {

using test::scene;

TEST(ModelSelection, PlanarSceneChoosesHomography) {
  for (double baseline : {30.0, 100.0})
    for (double rot : {0.0, 30.0})
      for (double noise : {0.0, 1.0}) {
        const auto s = scene(baseline, 0, rot, noise, 11);
        const ModelSelection sel = selectTwoViewModel(s.px1, s.px2, s.camera.K());
        EXPECT_TRUE(sel.planarity.planar)
            << "R_H " << sel.planarity.ratio_h << " b " << baseline << " n " << noise;
        EXPECT_TRUE(sel.homography_chosen);
        EXPECT_GT(sel.planarity.ratio_h, 0.40);
      }
}

TEST(ModelSelection, DepthSpreadChoosesEssential) {
  for (double rot : {0.0, 30.0})
    for (double noise : {0.0, 1.0}) {
      const auto s = scene(100, 500, rot, noise, 12);
      const ModelSelection sel = selectTwoViewModel(s.px1, s.px2, s.camera.K());
      EXPECT_FALSE(sel.planarity.planar) << "R_H " << sel.planarity.ratio_h << " n " << noise;
      EXPECT_FALSE(sel.homography_chosen);
      EXPECT_LT(sel.planarity.ratio_h, 0.3);
      EXPECT_TRUE(sel.chosen().valid) << sel.chosen().reason;
    }
}

TEST(ModelSelection, MedianParallaxMatchesGeometry) {
  // Sideways baseline b at depth z: parallax ~ b / z rad at the image centre.
  const auto s = scene(30, 0, 30, 0.0, 13);
  const double par = medianParallaxDeg(s.px1, s.px2, s.camera.K(), s.T_c2_c1.linear());
  EXPECT_NEAR(par, 30.0 / 1500.0 * 180.0 / M_PI, 0.25);
  // With the wrong rotation (identity) the 30 deg rotation shows up as fake "parallax".
  EXPECT_GT(medianParallaxDeg(s.px1, s.px2, s.camera.K(), Eigen::Matrix3d::Identity()), 20.0);
}

TEST(ModelSelection, ScoresAreSymmetricInTheModels) {
  const auto s = scene(100, 0, 0, 0.0, 14);
  const ModelSelection sel = selectTwoViewModel(s.px1, s.px2, s.camera.K());
  // Noise-free plane: both models explain every point with zero error, so S_H == S_F and R_H = 0.5.
  EXPECT_NEAR(sel.planarity.ratio_h, 0.5, 0.01);
  EXPECT_GT(sel.planarity.score_h, 0.0);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
