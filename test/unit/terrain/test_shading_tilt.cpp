// Signed photoclinometry (shading_tilt.h) on ray-cast images of Lambertian ground: long swells along the
// Sun's azimuth (16 m wavelength, 12 deg slope amplitude), and a map that sees them halved (its elevation the
// truth smoothed by a 3 m Gaussian, as a plane fit flattens them). The corrected slope must be much closer
// to the true one than the map's, with the Sun on either side (a wrong sign makes it worse); level ground
// reads no relative brightness; without the weight or the Sun's azimuth nothing is kept or changed.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "level_ground_views.h"
#include "planetary_vo/terrain/shading_tilt.h"
#include "planetary_vo/terrain/surface_analysis.h"

using namespace planetary_vo;
using namespace planetary_vo::terrain;

namespace {

constexpr int kSize = 640;
constexpr double kHeight = 40.0;  // 0.1 m per pixel
constexpr double kWavelength = 16.0;
constexpr double kSlopeAmplitudeDeg = 12.0;
constexpr double kSunElevationDeg = 30.0;

double amplitude_m() { return std::tan(kSlopeAmplitudeDeg * M_PI / 180.0) * kWavelength / (2.0 * M_PI); }
double height(double x) { return amplitude_m() * std::sin(2.0 * M_PI * x / kWavelength); }
double gradientX(double x) {
  return std::tan(kSlopeAmplitudeDeg * M_PI / 180.0) * std::cos(2.0 * M_PI * x / kWavelength);
}

PinholeCamera camera() { return PinholeCamera(kSize, kSize, 400.0, 400.0, kSize / 2.0, kSize / 2.0); }

/// Sun at azimuth 90 deg (toward +x) or 270 deg (toward -x); level ground is 120 DN. The relief's height
/// (< 0.6 m from 40 m) is neglected for the ray, not for the normal. `swells` false: level ground.
cv::Mat render(const Pose& T, double sun_azimuth_deg, bool swells) {
  const double e = kSunElevationDeg * M_PI / 180.0, a = sun_azimuth_deg * M_PI / 180.0;
  const Eigen::Vector3d sun(std::cos(e) * std::sin(a), std::cos(e) * std::cos(a), std::sin(e));
  return test::renderLevelGround(camera(), T, 0.0, [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d n = Eigen::Vector3d(swells ? -gradientX(p.x()) : 0.0, 0.0, 1.0).normalized();
    const double value = 120.0 * std::max(0.0, n.dot(sun)) / std::sin(e);
    return static_cast<uint8_t>(std::clamp(std::lround(value), 0L, 255L));
  });
}

struct Swells {
  GridGeometry g = GridGeometry::centeredOnOrigin(24.0, 0.5);
  cv::Mat true_z, map_z;
};

Swells grids() {
  Swells s;
  s.true_z = s.g.newLayer();
  for (int r = 0; r < s.g.rows; ++r)
    for (int c = 0; c < s.g.cols; ++c) s.true_z.at<float>(r, c) = static_cast<float>(height(s.g.x_m(c)));
  cv::GaussianBlur(s.true_z, s.map_z, cv::Size(), 3.0 / s.g.cell_size_m, 0.0, cv::BORDER_REFLECT);
  return s;
}

/// RMS of a - b over the cells within 14 m of the centre where both are known.
double rmsDifference(const GridGeometry& g, const cv::Mat& a, const cv::Mat& b) {
  double sum = 0.0;
  int n = 0;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      if (std::hypot(g.x_m(c), g.y_m(r)) > 14.0) continue;
      const float u = a.at<float>(r, c), v = b.at<float>(r, c);
      if (!std::isfinite(u) || !std::isfinite(v)) continue;
      sum += (u - v) * (u - v);
      ++n;
    }
  EXPECT_GT(n, 2000);
  return n > 0 ? std::sqrt(sum / n) : NAN;
}

ShadingTilt tiltWith(double weight, double sun_azimuth_deg) {
  ShadingTiltConfig config;
  config.weight = weight;
  return ShadingTilt(camera(), config, kSunElevationDeg, sun_azimuth_deg, 5.0);
}

}  // namespace

TEST(ShadingTilt, CorrectsTheSlopeThePlaneFitFlattensWithTheSunOnEitherSide) {
  const Swells s = grids();
  const cv::Mat true_slope = analyzeSurface(s.g, s.true_z, 4.0).slope_deg;
  const cv::Mat map_slope = analyzeSurface(s.g, s.map_z, 4.0).slope_deg;
  const double before = rmsDifference(s.g, map_slope, true_slope);
  EXPECT_GT(before, 3.0);  // the map sees about half of the 12 deg swells
  for (const double azimuth : {90.0, 270.0}) {
    SCOPED_TRACE(azimuth);
    ShadingTilt tilt = tiltWith(1.0, azimuth), half = tiltWith(0.5, azimuth);
    for (const double y : {-1.0, 0.0, 1.0}) {
      const Pose T = test::nadirAt(0.0, y, kHeight);
      ASSERT_TRUE(tilt.addKeyframe(T, render(T, azimuth, true), 0.0));
      ASSERT_TRUE(half.addKeyframe(T, render(T, azimuth, true), 0.0));
    }
    cv::Mat delta;
    const cv::Mat corrected = tilt.correctedSlope(s.g, s.map_z, map_slope, &delta);
    const double after = rmsDifference(s.g, corrected, true_slope);
    // Half the weight: half the map's gradient and half the shading's, which must add (the sign: with it
    // wrong they would cancel and the slope read flatter than the map's).
    const double after_half = rmsDifference(s.g, half.correctedSlope(s.g, s.map_z, map_slope), true_slope);
    std::printf(
        "sun azimuth %.0f: slope RMSE against the truth %.2f deg (map) -> %.2f deg (corrected, weight 1), "
        "%.2f deg (weight 0.5)\n",
        azimuth, before, after, after_half);
    EXPECT_LT(after, 0.35 * before);
    EXPECT_LT(after_half, 0.7 * before);
    // The correction raises the slope where the swells are steepest (x = 0, 8 m: cos = +-1) ...
    int col = 0, row = 0;
    ASSERT_TRUE(s.g.cellAt(0.0, 0.0, &col, &row));
    EXPECT_GT(delta.at<float>(row, col), 2.0f);
    ASSERT_TRUE(s.g.cellAt(8.0, 0.0, &col, &row));
    EXPECT_GT(delta.at<float>(row, col), 2.0f);
    // ... and leaves the crests (x = 4 m) about level.
    ASSERT_TRUE(s.g.cellAt(4.0, 0.0, &col, &row));
    EXPECT_LT(corrected.at<float>(row, col), 2.0f);
  }
}

TEST(ShadingTilt, HalfTheWeightHalvesTheStepAndLevelGroundReadsNoRelativeBrightness) {
  const Swells s = grids();
  const cv::Mat map_slope = analyzeSurface(s.g, s.map_z, 4.0).slope_deg;
  ShadingTilt full = tiltWith(1.0, 90.0), half = tiltWith(0.5, 90.0), level = tiltWith(1.0, 90.0);
  for (const double y : {-1.0, 0.0, 1.0}) {
    const Pose T = test::nadirAt(0.0, y, kHeight);
    const cv::Mat image = render(T, 90.0, true);
    ASSERT_TRUE(full.addKeyframe(T, image, 0.0));
    ASSERT_TRUE(half.addKeyframe(T, image, 0.0));
    ASSERT_TRUE(level.addKeyframe(T, render(T, 90.0, false), 0.0));
  }
  int col = 0, row = 0;
  ASSERT_TRUE(s.g.cellAt(0.0, 0.0, &col, &row));
  cv::Mat d_full, d_half;
  full.correctedSlope(s.g, s.map_z, map_slope, &d_full);
  half.correctedSlope(s.g, s.map_z, map_slope, &d_half);
  EXPECT_GT(d_half.at<float>(row, col), 0.3f * d_full.at<float>(row, col));
  EXPECT_LT(d_half.at<float>(row, col), 0.7f * d_full.at<float>(row, col));
  const cv::Mat rel = level.cellRelativeBrightness(s.g, s.g.newLayer(0.0f));
  double max_abs = 0.0;
  int known = 0;
  for (int r = 0; r < s.g.rows; ++r)
    for (int c = 0; c < s.g.cols; ++c)
      if (std::isfinite(rel.at<float>(r, c))) {
        max_abs = std::max(max_abs, double(std::abs(rel.at<float>(r, c))));
        ++known;
      }
  EXPECT_GT(known, 3000);
  EXPECT_LT(max_abs, 0.01);
}

TEST(ShadingTilt, WithoutTheWeightOrTheSunsAzimuthNothingIsKeptOrChanged) {
  const Swells s = grids();
  const cv::Mat map_slope = analyzeSurface(s.g, s.map_z, 4.0).slope_deg;
  const Pose T = test::nadirAt(0.0, 0.0, kHeight);
  const cv::Mat image = render(T, 90.0, true);
  for (ShadingTilt tilt : {tiltWith(0.0, 90.0), tiltWith(1.0, -1.0)}) {
    EXPECT_FALSE(tilt.active());
    EXPECT_FALSE(tilt.addKeyframe(T, image, 0.0));
    const cv::Mat out = tilt.correctedSlope(s.g, s.map_z, map_slope);
    EXPECT_EQ(cv::norm(out, map_slope, cv::NORM_INF), 0.0);
  }
  ShadingTiltConfig config;
  config.weight = 1.0;
  EXPECT_FALSE(ShadingTilt(camera(), config, 4.0, 90.0, 5.0).active());  // below min_sun_elevation_deg
  ShadingTilt from_too_high = tiltWith(1.0, 90.0);
  EXPECT_FALSE(from_too_high.addKeyframe(test::nadirAt(0.0, 0.0, 200.0), render(T, 90.0, true), 0.0));
  config.surround_sigma_m = 0.5;  // not above the footprint's sigma
  EXPECT_THROW(ShadingTilt(camera(), config, 30.0, 90.0, 5.0), std::invalid_argument);
  config = ShadingTiltConfig();
  config.weight = 1.5;
  EXPECT_THROW(ShadingTilt(camera(), config, 30.0, 90.0, 5.0), std::invalid_argument);
  EXPECT_THROW(tiltWith(1.0, 90.0).addKeyframe(T, cv::Mat(10, 10, CV_8U, cv::Scalar(1)), 0.0),
               std::invalid_argument);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
