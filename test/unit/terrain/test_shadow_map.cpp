// The shadow map on ray-cast images of level ground with a black rectangle (a cast shadow) at a known place:
// the cells under it read shadow, the cells around it lit, from a nadir and from an oblique view; views whose
// pixels are coarser than the limit, and cells of unknown elevation, read nothing.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "planetary_vo/terrain/shadow_map.h"

using namespace planetary_vo;
using namespace planetary_vo::terrain;

namespace {

constexpr int kSize = 640;
constexpr double kGroundZ = 5.0;
// The shadow: world x in [kX0, kX1], y in [kY0, kY1].
constexpr double kX0 = -3.0, kX1 = 2.0, kY0 = 1.0, kY1 = 4.0;

bool inShadow(double x, double y) { return x >= kX0 && x <= kX1 && y >= kY0 && y <= kY1; }

/// Level ground at kGroundZ, lit (a checker of 90 and 150 by the metre, so the median is lit) except the
/// shadow (value 3: the black level); sky (0) where a ray misses the ground.
cv::Mat render(const PinholeCamera& camera, const Pose& T_world_cam) {
  cv::Mat image(camera.height(), camera.width(), CV_8U);
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c) {
      const Eigen::Vector3d d = T_world_cam.linear() * camera.distortedPixelToBearing({double(c), double(r)});
      const Eigen::Vector3d o = T_world_cam.translation();
      if (!(d.z() < 0.0)) {
        image.at<uint8_t>(r, c) = 0;
        continue;
      }
      const Eigen::Vector3d p = o + (kGroundZ - o.z()) / d.z() * d;
      const bool odd = (static_cast<int>(std::floor(p.x())) + static_cast<int>(std::floor(p.y()))) % 2 != 0;
      image.at<uint8_t>(r, c) = inShadow(p.x(), p.y()) ? 3 : (odd ? 150 : 90);
    }
  return image;
}

/// Camera at (x, y, z) looking down, pitched forward (toward +y) by `pitch_deg` from nadir.
Pose lookingDown(double x, double y, double z, double pitch_deg) {
  Pose T = Pose::Identity();
  T.linear().col(0) = Eigen::Vector3d::UnitX();
  T.linear().col(1) = -Eigen::Vector3d::UnitY();
  T.linear().col(2) = -Eigen::Vector3d::UnitZ();
  T.linear() =
      Eigen::AngleAxisd(pitch_deg * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix() * T.linear();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

GridGeometry smallArea() { return GridGeometry::centeredOnOrigin(10.0, 0.5); }

struct Tally {
  int inside = 0, inside_dark = 0, outside = 0, outside_dark = 0, unseen = 0;
};

/// Cells at least `margin_m` inside the shadow, and at least `margin_m` outside it.
Tally tally(const GridGeometry& g, const cv::Mat& fraction, double margin_m) {
  Tally t;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const double x = g.x_m(c), y = g.y_m(r);
      const float f = fraction.at<float>(r, c);
      const bool deep_inside = inShadow(x - margin_m, y - margin_m) && inShadow(x + margin_m, y + margin_m);
      const bool far_outside = !inShadow(x, y) && !inShadow(x - margin_m, y) && !inShadow(x + margin_m, y) &&
                               !inShadow(x, y - margin_m) && !inShadow(x, y + margin_m) &&
                               !inShadow(x - margin_m, y - margin_m) &&
                               !inShadow(x + margin_m, y + margin_m) &&
                               !inShadow(x - margin_m, y + margin_m) && !inShadow(x + margin_m, y - margin_m);
      if (!std::isfinite(f)) {
        ++t.unseen;
        continue;
      }
      if (deep_inside) {
        ++t.inside;
        t.inside_dark += f > 0.5f;
      } else if (far_outside) {
        ++t.outside;
        t.outside_dark += f > 0.5f;
      }
    }
  return t;
}

}  // namespace

TEST(ShadowMap, TheCellsUnderAShadowReadDarkAndTheirNeighboursLit) {
  const PinholeCamera camera = PinholeCamera::fromFieldOfView(kSize, kSize, 60.0);
  ShadowMap shadows(camera);
  // 40 m above the ground: a pixel covers 0.072 m (nadir) to 0.11 m (the 30 deg view).
  shadows.addKeyframe(lookingDown(0.5, -3.0, kGroundZ + 40.0, 0.0),
                      render(camera, lookingDown(0.5, -3.0, kGroundZ + 40.0, 0.0)));
  shadows.addKeyframe(lookingDown(0.0, -20.0, kGroundZ + 35.0, 30.0),
                      render(camera, lookingDown(0.0, -20.0, kGroundZ + 35.0, 30.0)));
  const GridGeometry g = smallArea();
  cv::Mat elevation = g.newLayer(static_cast<float>(kGroundZ));
  ShadowStats stats;
  cv::Mat views;
  const cv::Mat fraction = shadows.shadowFraction(g, elevation, &stats, &views);
  const Tally t = tally(g, fraction, 0.3);
  EXPECT_GT(t.inside, 40);  // 10 x 6 cells deep inside the 5 m x 3 m shadow
  EXPECT_EQ(t.inside_dark, t.inside);
  EXPECT_GT(t.outside, 1000);
  EXPECT_EQ(t.outside_dark, 0);
  EXPECT_EQ(stats.cells_seen, g.rows * g.cols - t.unseen);
  // Both views see the shadow's centre.
  int c = 0, r = 0;
  ASSERT_TRUE(g.cellAt(-0.5, 2.5, &c, &r));
  EXPECT_EQ(views.at<float>(r, c), 2.0f);
  EXPECT_EQ(fraction.at<float>(r, c), 1.0f);
}

TEST(ShadowMap, TheCellsAreProjectedAtTheirElevation) {
  // The oblique view alone, with the elevation layer 3 m off: the shadow lands on the wrong cells.
  const PinholeCamera camera = PinholeCamera::fromFieldOfView(kSize, kSize, 60.0);
  ShadowMap shadows(camera);
  const Pose view = lookingDown(0.0, -20.0, kGroundZ + 35.0, 30.0);
  shadows.addKeyframe(view, render(camera, view));
  const GridGeometry g = smallArea();
  const Tally right = tally(g, shadows.shadowFraction(g, g.newLayer(static_cast<float>(kGroundZ))), 0.3);
  const Tally wrong =
      tally(g, shadows.shadowFraction(g, g.newLayer(static_cast<float>(kGroundZ + 3.0))), 0.3);
  EXPECT_EQ(right.inside_dark, right.inside);
  EXPECT_EQ(right.outside_dark, 0);
  EXPECT_LT(wrong.inside_dark, wrong.inside * 0.7);
  EXPECT_GT(wrong.outside_dark, 10);
}

TEST(ShadowMap, CoarseViewsAndUnknownCellsReadNothing) {
  const PinholeCamera camera = PinholeCamera::fromFieldOfView(kSize, kSize, 60.0);
  ShadowMapConfig config;
  config.max_pixel_footprint_m = 0.05;  // finer than the 0.072 m of the view below
  ShadowMap coarse(camera, config);
  const Pose view = lookingDown(0.5, -3.0, kGroundZ + 40.0, 0.0);
  coarse.addKeyframe(view, render(camera, view));
  const GridGeometry g = smallArea();
  cv::Mat elevation = g.newLayer(static_cast<float>(kGroundZ));
  ShadowStats stats;
  (void)coarse.shadowFraction(g, elevation, &stats);
  EXPECT_EQ(stats.cells_seen, 0);

  ShadowMap fine(camera);
  fine.addKeyframe(view, render(camera, view));
  elevation(cv::Rect(0, 0, g.cols, g.rows / 2)).setTo(std::numeric_limits<float>::quiet_NaN());
  const cv::Mat fraction = fine.shadowFraction(g, elevation, &stats);
  EXPECT_GT(stats.cells_seen, 0);
  for (int r = 0; r < g.rows / 2; ++r)
    for (int c = 0; c < g.cols; ++c) ASSERT_TRUE(std::isnan(fraction.at<float>(r, c)));
}

TEST(ShadowMap, DarkIsRelativeToTheImageAndOnlyTheLastKeyframesAreKept) {
  const PinholeCamera camera = PinholeCamera::fromFieldOfView(64, 48, 60.0);
  ShadowMapConfig config;
  config.max_keyframes = 2;
  ShadowMap shadows(camera, config);
  // Most of the image in shadow (4: the black level), a fifth dim lit ground (30), a fifth bright (100): the
  // 90th percentile is lit ground even so, and the limit is 0.1 x 100.
  cv::Mat image(48, 64, CV_8U, cv::Scalar(4));
  image.rowRange(0, 10).setTo(100);
  image.rowRange(10, 20).setTo(30);
  image(cv::Rect(0, 20, 10, 10)).setTo(9);    // below 0.1 x 100
  image(cv::Rect(10, 20, 10, 10)).setTo(10);  // not below
  const cv::Mat mask = shadows.darkMask(image);
  EXPECT_EQ(cv::countNonZero(mask), 28 * 64 - 100);
  EXPECT_EQ(mask.at<uint8_t>(25, 5), 255);
  EXPECT_EQ(mask.at<uint8_t>(25, 15), 0);
  EXPECT_EQ(cv::countNonZero(mask.rowRange(0, 20)), 0);
  // Twice as bright, the same shadows.
  EXPECT_EQ(cv::countNonZero(shadows.darkMask(image * 2)), 28 * 64 - 100);
  // A black image has no shadow to tell.
  EXPECT_EQ(cv::countNonZero(shadows.darkMask(cv::Mat::zeros(48, 64, CV_8U))), 0);
  for (int i = 0; i < 3; ++i) shadows.addKeyframe(Pose::Identity(), image);
  EXPECT_EQ(shadows.numKeyframes(), 2u);
  EXPECT_THROW(shadows.addKeyframe(Pose::Identity(), cv::Mat(10, 10, CV_8U)), std::invalid_argument);
  config.dark_fraction_of_bright = 1.0;
  EXPECT_THROW(ShadowMap(camera, config), std::invalid_argument);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
