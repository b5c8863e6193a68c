// The shading relief on ray-cast images of Lambertian ground: level on one half, on the other a washboard of
// known slope (a sinusoid along the Sun's azimuth, 4 m wavelength, inside the 0.5-2 m band) that no plane
// fit over the 4 m footprint would see. The washboard reads its RMS slope times the band's transfer at
// 4 m (about 0.73) and the same at two Sun elevations (the tan(e) normalisation); the level half reads
// near zero; the hazard mask marks the washboard a hazard only with the layer; no Sun (or one below
// min_sun_elevation_deg), no layer.
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
