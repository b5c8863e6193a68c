// The shading relief on ray-cast images of Lambertian ground: level on one half, on the other a washboard of
// known slope (a sinusoid along the Sun's azimuth, 4 m wavelength, inside the 0.5-2 m band) that no plane
// fit over the 4 m footprint would see. The washboard reads its RMS slope times the band's transfer at
// 4 m (about 0.73) and the same at two Sun elevations (the tan(e) normalisation); the level half reads
// near zero; the hazard mask marks the washboard a hazard only with the layer; no Sun (or one below
// min_sun_elevation_deg), no layer. On ground tilted toward or away from the Sun, the same washboard reads
// the same with the Sun's azimuth given (the Sun over the map's ground), and tan(e) / tan(e over the ground)
// of it without.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "level_ground_views.h"
#include "planetary_vo/terrain/hazard.h"
#include "planetary_vo/terrain/shading_relief.h"

using namespace planetary_vo;
using namespace planetary_vo::terrain;

namespace {

constexpr int kSize = 640;
constexpr double kHeight = 40.0;            // camera above the level ground (z = 0): 0.1 m per pixel
constexpr double kWavelength = 4.0;         // washboard along x
constexpr double kSlopeAmplitudeDeg = 8.5;  // RMS slope 6.0 deg
constexpr double kEdgeX = 0.0;              // washboard where x < kEdgeX

double rmsSlopeDeg() {
  return std::atan(std::tan(kSlopeAmplitudeDeg * M_PI / 180.0) / std::sqrt(2.0)) * 180.0 / M_PI;
}

/// Surface gradient dz/dx of the washboard at x (0 on the level half).
double gradientX(double x) {
  if (x >= kEdgeX) return 0.0;
  return std::tan(kSlopeAmplitudeDeg * M_PI / 180.0) * std::cos(2.0 * M_PI * x / kWavelength);
}

/// Lambertian ground lit by a Sun at `sun_elevation_deg` toward +x (azimuth along the washboard), exposed so
/// that level ground is 120 DN; the relief's height (< 0.1 m) is neglected for the ray, not for the normal.
cv::Mat render(const PinholeCamera& camera, const Pose& T_world_cam, double sun_elevation_deg) {
  const double e = sun_elevation_deg * M_PI / 180.0;
  const Eigen::Vector3d sun(std::cos(e), 0.0, std::sin(e));
  return test::renderLevelGround(camera, T_world_cam, 0.0, [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d n = Eigen::Vector3d(-gradientX(p.x()), 0.0, 1.0).normalized();
    const double value = 120.0 * std::max(0.0, n.dot(sun)) / std::sin(e);
    return static_cast<uint8_t>(std::clamp(std::lround(value), 0L, 255L));
  });
}

using test::nadirAt;

/// The same washboard on ground tilted by `tilt_deg` about the y axis, toward the Sun (at azimuth 90 deg, +x)
/// when positive: the plane z = -tan(tilt) x, the washboard's gradient added to the plane's. Level ground
/// under the Sun at `sun_elevation_deg` would be 90 DN (headroom for the brighter side).
cv::Mat renderTilted(const PinholeCamera& camera, const Pose& T_world_cam, double sun_elevation_deg,
                     double tilt_deg) {
  const double e = sun_elevation_deg * M_PI / 180.0, tan_tilt = std::tan(tilt_deg * M_PI / 180.0);
  const Eigen::Vector3d sun(std::cos(e), 0.0, std::sin(e));
  cv::Mat image(camera.height(), camera.width(), CV_8U);
  const Eigen::Vector3d o = T_world_cam.translation();
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c) {
      const Eigen::Vector3d d = T_world_cam.linear() * camera.distortedPixelToBearing({double(c), double(r)});
      // o + l d on z = -tan_tilt x.
      const double l = -(o.z() + tan_tilt * o.x()) / (d.z() + tan_tilt * d.x());
      const Eigen::Vector3d p = o + l * d;
      const Eigen::Vector3d n = Eigen::Vector3d(tan_tilt - gradientX(p.x()), 0.0, 1.0).normalized();
      const double value = 90.0 * std::max(0.0, n.dot(sun)) / std::sin(e);
      image.at<uint8_t>(r, c) = static_cast<uint8_t>(std::clamp(std::lround(value), 0L, 255L));
    }
  return image;
}

PinholeCamera camera() { return PinholeCamera(kSize, kSize, 400.0, 400.0, kSize / 2.0, kSize / 2.0); }

struct Reading {
  double washboard_median = 0.0, level_max = 0.0;
  int washboard = 0, level = 0;
};

/// Cells at least 6 m from the edge (the footprint disc and the 2 m blur), within 14 m of the centre.
Reading read(const GridGeometry& g, const cv::Mat& slope) {
  Reading out;
  std::vector<float> wash;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const double x = g.x_m(c);
      const float v = slope.at<float>(r, c);
      if (!std::isfinite(v)) continue;
      if (x < kEdgeX - 6.0) wash.push_back(v);
      if (x > kEdgeX + 6.0) {
        ++out.level;
        out.level_max = std::max(out.level_max, double(v));
      }
    }
  out.washboard = static_cast<int>(wash.size());
  if (!wash.empty()) {
    std::nth_element(wash.begin(), wash.begin() + wash.size() / 2, wash.end());
    out.washboard_median = wash[wash.size() / 2];
  }
  return out;
}

Reading measure(double sun_elevation_deg, cv::Mat* slope_out = nullptr) {
  ShadingReliefConfig config;
  config.sun_elevation_deg = sun_elevation_deg;
  ShadingRelief relief(camera(), config);
  for (const double y : {-1.0, 0.0, 1.0}) {
    const Pose T = nadirAt(0.0, y, kHeight);
    EXPECT_TRUE(relief.addKeyframe(T, render(camera(), T, sun_elevation_deg), 0.0));
  }
  const GridGeometry g = GridGeometry::centeredOnOrigin(14.0, 0.5);
  const cv::Mat slope = relief.slopeRms(g, g.newLayer(0.0f), 4.0);
  if (slope_out) *slope_out = slope;
  return read(g, slope);
}

TEST(ShadingRelief, WashboardReadsItsSlopeThroughTheBandAndLevelGroundReadsNearZero) {
  const Reading r = measure(30.0);
  ASSERT_GT(r.washboard, 300);
  ASSERT_GT(r.level, 300);
  // Band transfer of a 4 m sinusoid: exp(-2 pi^2 0.5^2 / 16) - exp(-2 pi^2 2^2 / 16) = 0.728.
  const double expected = 0.728 * rmsSlopeDeg();
  EXPECT_NEAR(r.washboard_median, expected, 0.2 * expected) << "RMS slope " << rmsSlopeDeg();
  std::printf("washboard RMS slope %.2f deg: read %.2f deg (expected %.2f); level ground at most %.2f deg\n",
              rmsSlopeDeg(), r.washboard_median, expected, r.level_max);
  EXPECT_LT(r.level_max, 0.5);
}

TEST(ShadingRelief, TheSunElevationNormalisationGivesTheSameSlopeAtLowAndHighSun) {
  const Reading low = measure(20.0), high = measure(45.0);
  ASSERT_GT(low.washboard_median, 1.0);
  std::printf("washboard at Sun 20 deg %.2f deg, at Sun 45 deg %.2f deg\n", low.washboard_median,
              high.washboard_median);
  EXPECT_NEAR(high.washboard_median / low.washboard_median, 1.0, 0.2)
      << "Sun 20 deg " << low.washboard_median << ", Sun 45 deg " << high.washboard_median;
}

/// The washboard's median on ground tilted by tilt_deg (toward the Sun when positive) under a Sun at 20 deg,
/// with or without the Sun's azimuth, the map's elevation being the tilted plane.
double measureTilted(double tilt_deg, bool azimuth_given, bool normalise_turned_away = true) {
  const double sun_elevation_deg = 20.0;
  ShadingReliefConfig config;
  config.sun_elevation_deg = sun_elevation_deg;
  if (azimuth_given) config.sun_azimuth_deg = 90.0;  // toward +x
  config.normalise_turned_away = normalise_turned_away;
  ShadingRelief relief(camera(), config);
  for (const double y : {-1.0, 0.0, 1.0}) {
    const Pose T = nadirAt(0.0, y, kHeight);
    EXPECT_TRUE(relief.addKeyframe(T, renderTilted(camera(), T, sun_elevation_deg, tilt_deg), 0.0));
  }
  const GridGeometry g = GridGeometry::centeredOnOrigin(14.0, 0.5);
  cv::Mat elevation = g.newLayer();
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c)
      elevation.at<float>(r, c) = static_cast<float>(-std::tan(tilt_deg * M_PI / 180.0) * g.x_m(c));
  const cv::Mat sun = relief.localSunElevationDeg(g, elevation, 2.0);
  EXPECT_NEAR(sun.at<float>(g.rows / 2, g.cols / 2),
              azimuth_given ? sun_elevation_deg + tilt_deg : sun_elevation_deg, 1e-3);
  const Reading r = read(g, relief.slopeRms(g, elevation, 4.0));
  EXPECT_GT(r.washboard, 300);
  EXPECT_LT(r.level_max, 0.5);
  return r.washboard_median;
}

TEST(ShadingRelief, OnTiltedGroundTheSunOverTheMapsGroundReadsTheSameSlopeAsOnLevelGround) {
  const double expected = 0.728 * rmsSlopeDeg();  // as on level ground (the first test)
  for (const double tilt_deg : {10.0, -8.0}) {
    const double with = measureTilted(tilt_deg, true), without = measureTilted(tilt_deg, false);
    // Without the azimuth the relative brightness is read against the Sun over level ground (20 deg): too
    // low on ground turned toward it (tan 20 / tan 30 = 0.63), too high away from it (tan 20 / tan 12 =
    // 1.71).
    const double level_ratio = std::tan(20.0 * M_PI / 180.0) / std::tan((20.0 + tilt_deg) * M_PI / 180.0);
    std::printf(
        "ground tilted %+.0f deg toward the Sun (20 deg): washboard read %.2f deg with the azimuth, %.2f "
        "without (expected %.2f, without x %.2f)\n",
        tilt_deg, with, without, expected, level_ratio);
    EXPECT_NEAR(with, expected, 0.15 * expected) << "tilt " << tilt_deg;
    EXPECT_NEAR(without / with, level_ratio, 0.1 * level_ratio) << "tilt " << tilt_deg;
  }
}

TEST(ShadingRelief, WithoutNormalisingGroundTurnedAwayEachCellReadsTheLargerOfTheTwoReadings) {
  // Toward the Sun the map's ground raises the reading (as with normalise_turned_away); away from it the
  // level-ground reading, the larger one there, is kept.
  for (const double tilt_deg : {10.0, -8.0}) {
    const double larger = measureTilted(tilt_deg, true, false);
    const double local = measureTilted(tilt_deg, true), level = measureTilted(tilt_deg, false);
    std::printf(
        "ground tilted %+.0f deg toward the Sun (20 deg): larger of the two %.2f deg (map's ground %.2f, "
        "level %.2f)\n",
        tilt_deg, larger, local, level);
    EXPECT_NEAR(larger, std::max(local, level), 1e-4) << "tilt " << tilt_deg;
    EXPECT_GT(std::abs(local - level), 0.2 * std::max(local, level)) << "tilt " << tilt_deg;
  }
}

TEST(ShadingRelief, TheSunOverTheGroundAtTheEdgeOfTheKnownGroundAndAroundIsolatedCells) {
  ShadingReliefConfig config;
  config.sun_elevation_deg = 15.0;
  config.sun_azimuth_deg = 0.0;  // toward +y
  const ShadingRelief relief(camera(), config);
  const GridGeometry g = GridGeometry::centeredOnOrigin(5.0, 0.5);  // 21 x 21 cells
  // Ground rising toward +y at 10 deg (facing -y: turned away from the Sun), known only for rows 5..15.
  cv::Mat elevation = g.newLayer();
  for (int r = 5; r <= 15; ++r)
    for (int c = 0; c < g.cols; ++c)
      elevation.at<float>(r, c) = static_cast<float>(std::tan(10.0 * M_PI / 180.0) * g.y_m(r));
  const cv::Mat sun = relief.localSunElevationDeg(g, elevation, 2.0);  // +-4 cells
  // One-sided at rows 5, 6, 14 and 15.
  for (const int r : {5, 6, 10, 14, 15})
    for (const int c : {0, 3, 10, 20}) EXPECT_NEAR(sun.at<float>(r, c), 5.0, 1e-3) << r << " " << c;
  EXPECT_FALSE(std::isfinite(sun.at<float>(4, 10)));  // unknown elevation: no value
  // An isolated known cell: no gradient, level ground.
  cv::Mat lone = g.newLayer();
  lone.at<float>(10, 10) = 3.0f;
  EXPECT_NEAR(relief.localSunElevationDeg(g, lone, 2.0).at<float>(10, 10), 15.0, 1e-4);
  // Turned away by more than the Sun: below the horizon, where slopeRms holds min_sun_elevation_deg.
  cv::Mat steep = elevation * (std::tan(20.0 * M_PI / 180.0) / std::tan(10.0 * M_PI / 180.0));
  EXPECT_NEAR(relief.localSunElevationDeg(g, steep, 2.0).at<float>(10, 10), -5.0, 1e-3);
}

TEST(ShadingRelief, TheWashboardIsAHazardOnlyWithTheShadingLayer) {
  cv::Mat shading;
  (void)measure(30.0, &shading);
  const GridGeometry g = GridGeometry::centeredOnOrigin(14.0, 0.5);
  // What the plane fit over the footprint sees of a 4 m washboard 0.09 m high: level and smooth.
  const cv::Mat slope = g.newLayer(1.0f), roughness = g.newLayer(0.05f);
  HazardThresholds t;
  const cv::Mat without = hazardMask(slope, roughness, cv::Mat(), cv::Mat(), t);
  const cv::Mat with = hazardMask(slope, roughness, cv::Mat(), shading, t);
  int wash_hazard_without = 0, wash_hazard_with = 0, wash = 0, level_hazard_with = 0;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      if (!std::isfinite(shading.at<float>(r, c))) continue;
      if (g.x_m(c) < kEdgeX - 6.0) {
        ++wash;
        wash_hazard_without += without.at<uint8_t>(r, c) == kHazard;
        wash_hazard_with += with.at<uint8_t>(r, c) == kHazard;
      }
      if (g.x_m(c) > kEdgeX + 6.0) level_hazard_with += with.at<uint8_t>(r, c) == kHazard;
    }
  ASSERT_GT(wash, 300);
  EXPECT_EQ(wash_hazard_without, 0);
  EXPECT_EQ(wash_hazard_with, wash);
  EXPECT_EQ(level_hazard_with, 0);
}

TEST(ShadingRelief, WithoutTheSunUnderALowSunOrFromTooHighNothingIsKeptAndNothingRead) {
  const Pose T = nadirAt(0.0, 0.0, kHeight);
  const cv::Mat image = render(camera(), T, 30.0);
  const GridGeometry g = GridGeometry::centeredOnOrigin(14.0, 0.5);
  ShadingRelief no_sun(camera());  // sun_elevation_deg 0: not given
  EXPECT_FALSE(no_sun.active());
  ShadingReliefConfig low;
  low.sun_elevation_deg = 4.0;  // below min_sun_elevation_deg (5): the shadows alone
  EXPECT_FALSE(ShadingRelief(camera(), low).active());
  EXPECT_FALSE(ShadingRelief(camera(), low).addKeyframe(T, image, 0.0));
  low.min_sun_elevation_deg = 3.0;
  EXPECT_TRUE(ShadingRelief(camera(), low).active());
  EXPECT_FALSE(no_sun.addKeyframe(T, image, 0.0));
  EXPECT_EQ(cv::countNonZero(no_sun.slopeRms(g, g.newLayer(0.0f), 4.0) ==
                             no_sun.slopeRms(g, g.newLayer(0.0f), 4.0)),
            0);

  ShadingReliefConfig config;
  config.sun_elevation_deg = 30.0;
  ShadingRelief relief(camera(), config);
  // 400 m up, a pixel covers 1 m: coarser than 0.25 m.
  EXPECT_FALSE(relief.addKeyframe(nadirAt(0.0, 0.0, 400.0), image, 0.0));
  EXPECT_EQ(relief.numKeyframes(), 0u);
  EXPECT_TRUE(relief.addKeyframe(T, image, 0.0));
  // Unknown elevation: no value.
  const cv::Mat out = relief.slopeRms(g, g.newLayer(), 4.0);
  EXPECT_EQ(cv::countNonZero(out == out), 0);
}

TEST(ShadingRelief, RejectsBadConfigAndImages) {
  ShadingReliefConfig bad;
  bad.band_max_m = bad.band_min_m;
  EXPECT_THROW(ShadingRelief(camera(), bad), std::invalid_argument);
  bad = ShadingReliefConfig();
  bad.sun_elevation_deg = 95.0;
  EXPECT_THROW(ShadingRelief(camera(), bad), std::invalid_argument);
  bad = ShadingReliefConfig();
  bad.sun_azimuth_deg = 361.0;
  EXPECT_THROW(ShadingRelief(camera(), bad), std::invalid_argument);
  bad.sun_azimuth_deg = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ShadingRelief(camera(), bad), std::invalid_argument);
  ShadingReliefConfig config;
  config.sun_elevation_deg = 30.0;
  ShadingRelief relief(camera(), config);
  EXPECT_THROW(relief.addKeyframe(nadirAt(0, 0, kHeight), cv::Mat(10, 10, CV_8U, cv::Scalar(5)), 0.0),
               std::invalid_argument);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
