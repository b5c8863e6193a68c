// The densifier on a rendered slope: two nadir views of a textured plane tilted 10 deg, taken 12 m apart
// from 120 m; the points it triangulates lie on the plane, and the terrain model built from them reads the
// slope.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "level_ground_views.h"
#include "octave_texture.h"
#include "planetary_vo/terrain/densifier.h"
#include "planetary_vo/terrain/terrain_map.h"

using namespace planetary_vo;
using namespace planetary_vo::terrain;

namespace {

constexpr int kSize = 640;
constexpr double kTiltDeg = 10.0;
constexpr double kTextureMPerPx = 0.125;
constexpr int kTexturePx = 2048;  // 256 m of ground

/// Smooth multi-octave noise: features from 1 m to 32 m.
cv::Mat texture() { return test::octaveNoiseTexture(kTexturePx, 99, 8, 256, 0.85); }

/// The plane through the origin rising along +x at kTiltDeg: world = u e1 + v e2.
const Eigen::Vector3d kE1(std::cos(kTiltDeg* M_PI / 180.0), 0.0, std::sin(kTiltDeg* M_PI / 180.0));
const Eigen::Vector3d kE2(0.0, 1.0, 0.0);

cv::Mat render(const cv::Mat& tex, const PinholeCamera& camera, const Pose& T_world_cam) {
  const Pose T_cam_world = T_world_cam.inverse();
  Eigen::Matrix3d M;  // (u, v, 1) -> camera
  M.col(0) = T_cam_world.linear() * kE1;
  M.col(1) = T_cam_world.linear() * kE2;
  M.col(2) = T_cam_world.translation();
  Eigen::Matrix3d plane_from_texture;  // texture pixel -> (u, v, 1), texture centred on the origin
  const double half = kTexturePx / 2.0;
  plane_from_texture << kTextureMPerPx, 0, -half * kTextureMPerPx, 0, kTextureMPerPx, -half * kTextureMPerPx,
      0, 0, 1;
  const Eigen::Matrix3d H = camera.K() * M * plane_from_texture;
  cv::Mat Hcv(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Hcv.at<double>(r, c) = H(r, c);
  cv::Mat image;
  cv::warpPerspective(tex, image, Hcv, cv::Size(kSize, kSize), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return image;
}

using test::nadirAt;

}  // namespace

TEST(Densifier, TriangulatesASlopeThatTheTerrainModelReads) {
  const cv::Mat tex = texture();
  const PinholeCamera camera = PinholeCamera::fromFieldOfView(kSize, kSize, 60.0);
  DensifierConfig config;
  config.area.half_extent_m = 30.0;
  config.area.cell_size_m = 0.5;
  config.max_window_footprint_m =
      0.0;  // the window covers ~4.5 m of ground from 120 m here (the gate has its own test)
  Densifier densifier(camera, config);
  const Pose a = nadirAt(-6.0, 0.0, 120.0);
  Pose b = nadirAt(6.0, 0.0, 118.0);  // turned 1 deg about the vertical and pitched 0.5 deg
  b.linear() = Eigen::AngleAxisd(1.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
               Eigen::AngleAxisd(0.5 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix() *
               b.linear();
  DensifierStats stats;
  EXPECT_TRUE(densifier.addKeyframe(0.0, a, render(tex, camera, a), 0.0, &stats).empty());  // no partner yet
  const std::vector<MapPointState> points =
      densifier.addKeyframe(1.0, b, render(tex, camera, b), 0.0, &stats);
  std::printf("  %d corners, %d tracked, %d triangulated (partner gap %d)\n", stats.seeds, stats.tracked,
              stats.triangulated, stats.partner_gap);
  EXPECT_EQ(stats.partner_gap, 1);
  ASSERT_GT(points.size(), 1000u);
  int on_plane = 0;
  double sq = 0.0;
  for (const MapPointState& p : points) {
    const double e = p.p_world.z() - std::tan(kTiltDeg * M_PI / 180.0) * p.p_world.x();
    sq += e * e;
    on_plane += std::abs(e) < 3.0 * std::sqrt(p.covariance_world(2, 2)) + 0.05 ? 1 : 0;
    EXPECT_GE(p.id, uint64_t{1} << 63);
  }
  const double rms = std::sqrt(sq / points.size());
  std::printf("  height error RMS %.3f m, %d of %zu within 3 sigma\n", rms, on_plane, points.size());
  EXPECT_LT(rms, 0.3);
  EXPECT_GE(on_plane, static_cast<int>(0.95 * points.size()));

  TerrainMapConfig map_config;
  map_config.area = config.area;
  TerrainMap map(map_config);
  MapEvents events;
  events.points_added = points;
  map.apply(events, true);
  const TerrainProducts products = map.products();
  const cv::Mat& slope = products.grids.layers.at("slope_deg");
  double slope_sq = 0.0;
  int n = 0;
  for (int row = 0; row < slope.rows; ++row)
    for (int col = 0; col < slope.cols; ++col)
      if (std::isfinite(slope.at<float>(row, col))) {
        slope_sq += std::pow(slope.at<float>(row, col) - kTiltDeg, 2);
        ++n;
      }
  std::printf("  slope RMSE %.2f deg over %d cells\n", std::sqrt(slope_sq / std::max(1, n)), n);
  EXPECT_GT(n, 1000);
  EXPECT_LT(std::sqrt(slope_sq / n), 1.5);
}

// Views 4 deg apart in yaw, 2 deg in pitch and 12 % apart in range: a translation-only track window is
// biased by the rotation and the scale change; tracking from the old image warped onto the new view by the
// ground plane's homography is not.
TEST(Densifier, WarpingThePartnerRemovesTheBiasOfRotatedAndScaledViews) {
  const cv::Mat tex = texture();
  const PinholeCamera camera = PinholeCamera::fromFieldOfView(kSize, kSize, 60.0);
  const Pose a = nadirAt(-6.0, 0.0, 120.0);
  Pose b = nadirAt(6.0, 0.0, 105.0);
  b.linear() = Eigen::AngleAxisd(4.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
               Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix() *
               b.linear();
  auto heightRms = [&](bool warp) {
    DensifierConfig config;
    config.area.half_extent_m = 30.0;
    config.max_window_footprint_m = 0.0;
    config.warp_partner = warp;
    Densifier densifier(camera, config);
    densifier.addKeyframe(0.0, a, render(tex, camera, a), 0.0);
    const std::vector<MapPointState> points = densifier.addKeyframe(1.0, b, render(tex, camera, b), 0.0);
    double sq = 0.0;
    for (const MapPointState& p : points)
      sq += std::pow(p.p_world.z() - std::tan(kTiltDeg * M_PI / 180.0) * p.p_world.x(), 2);
    std::printf("  warp %s: %zu points, height error RMS %.3f m\n", warp ? "on " : "off", points.size(),
                std::sqrt(sq / std::max<size_t>(1, points.size())));
    EXPECT_GT(points.size(), 500u);
    return std::sqrt(sq / std::max<size_t>(1, points.size()));
  };
  const double warped = heightRms(true), plain = heightRms(false);
  EXPECT_LT(warped, 0.12);
  EXPECT_GT(plain, 1.5 * warped);
}

// The window-footprint gate: from 118-120 m with this camera a 21 px window covers 120 x 21 / fx (fx 554 px)
// of nadir ground (4.5 m), a little more towards the image edges; a limit below that keeps no point, one well
// above it keeps them all.
TEST(Densifier, PointsWhoseWindowCoversMoreGroundThanTheLimitAreDropped) {
  const cv::Mat tex = texture();
  const PinholeCamera camera = PinholeCamera::fromFieldOfView(kSize, kSize, 60.0);
  const double nadir_window_m = 120.0 * 21.0 / camera.fx();
  const Pose a = nadirAt(-6.0, 0.0, 120.0), b = nadirAt(6.0, 0.0, 118.0);
  auto count = [&](double limit_m) {
    DensifierConfig config;
    config.area.half_extent_m = 30.0;
    config.max_window_footprint_m = limit_m;
    Densifier densifier(camera, config);
    densifier.addKeyframe(0.0, a, render(tex, camera, a), 0.0);
    return densifier.addKeyframe(1.0, b, render(tex, camera, b), 0.0).size();
  };
  const size_t unlimited = count(0.0);
  ASSERT_GT(unlimited, 1000u);
  EXPECT_EQ(count(0.8 * nadir_window_m), 0u);
  EXPECT_EQ(count(2.0 * nadir_window_m), unlimited);
  const size_t between = count(1.01 * nadir_window_m);  // the centre of the image only
  EXPECT_GT(between, 0u);
  EXPECT_LT(between, unlimited);
  std::printf("  window footprint at nadir %.2f m: %zu points unlimited, %zu within 1.01x\n", nadir_window_m,
              unlimited, between);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
