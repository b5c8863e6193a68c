/// Tests of the altimeter stage of the vision + altimeter mode (altimeter_aiding.h): which reading belongs to
/// an image (causal, interpolated, gated) and the metric scale of a map from it.

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "planetary_vo/vo/altimeter_aiding.h"

namespace planetary_vo {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(AltimeterAiding, ReadingForAnImageIsCausalInterpolatedAndGated) {
  AltimeterAidingConfig config;  // max_time_offset_s 0.06, range gate [10, 2000] m
  AltimeterAiding aiding(config);
  EXPECT_FALSE(aiding.readingAt(0.0));  // nothing buffered
  aiding.add({0.00, 700.0});
  aiding.add({0.05, 690.0});
  // Exactly on a reading, between two (interpolated), after the newest within the offset, beyond it.
  EXPECT_DOUBLE_EQ(aiding.readingAt(0.05)->slant_range_m, 690.0);
  EXPECT_NEAR(aiding.readingAt(0.02)->slant_range_m, 696.0, 1e-9);
  EXPECT_DOUBLE_EQ(aiding.readingAt(0.09)->slant_range_m, 690.0);
  EXPECT_FALSE(aiding.readingAt(0.12));
  EXPECT_FALSE(aiding.readingAt(-0.01));  // before the first reading: nothing from the future
  // No return, or outside the range gate: no reading; a neighbour without return is not interpolated with.
  aiding.add({0.10, kInf});
  aiding.add({0.15, 5.0});
  aiding.add({0.20, 2500.0});
  EXPECT_FALSE(aiding.readingAt(0.10));
  EXPECT_FALSE(aiding.readingAt(0.16));
  EXPECT_FALSE(aiding.readingAt(0.20));
  EXPECT_DOUBLE_EQ(aiding.readingAt(0.07)->slant_range_m, 690.0);
  // Flat memory: readings older than kHistoryS before the newest are dropped.
  aiding.add({100.0, 700.0});
  EXPECT_EQ(aiding.size(), 1u);
}

TEST(AltimeterAiding, ScaleOfAMapFromTheRangeAlongTheBeam) {
  AltimeterAidingConfig config;
  AltimeterAiding aiding(config);
  // A map at 1/50 of metres: ground points on the plane z = -10 map units below a nadir camera at the origin
  // looking along world -z, i.e. the true height is 500 m.
  Pose T_world_cam = Pose::Identity();
  T_world_cam.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::vector<Eigen::Vector3d> points;
  for (int i = -6; i <= 6; ++i)
    for (int j = -6; j <= 6; ++j)
      points.emplace_back(0.4 * i, 0.4 * j, -10.0 + 0.001 * ((i * 7 + j * 3) % 5));
  AltimeterScaleFix fix = aiding.scaleAt(1.0, points, T_world_cam);
  EXPECT_FALSE(fix.valid);  // no reading yet
  EXPECT_NE(fix.reason.find("no altimeter reading"), std::string::npos);
  aiding.add({1.0, 500.0});
  fix = aiding.scaleAt(1.0, points, T_world_cam);
  ASSERT_TRUE(fix.valid) << fix.reason;
  EXPECT_NEAR(fix.metres_per_map_unit, 50.0, 0.05);
  EXPECT_GT(fix.relative_sigma, 0.0);
  EXPECT_LT(fix.relative_sigma, 0.01);
  // A map with nothing under the beam gives no scale, with the prediction's reason.
  std::vector<Eigen::Vector3d> off_beam;
  for (const Eigen::Vector3d& p : points) off_beam.push_back(p + Eigen::Vector3d(30.0, 0.0, 0.0));
  fix = aiding.scaleAt(1.0, off_beam, T_world_cam);
  EXPECT_FALSE(fix.valid);
  EXPECT_NE(fix.reason.find("no range prediction"), std::string::npos);
}

TEST(AltimeterAiding, BadReadingsThrowAndLeaveTheBufferUnchanged) {
  AltimeterAiding aiding{AltimeterAidingConfig()};
  aiding.add({1.0, 500.0});
  EXPECT_THROW(aiding.add({0.9, 500.0}), std::invalid_argument);
  EXPECT_THROW(aiding.add({std::nan(""), 500.0}), std::invalid_argument);
  EXPECT_THROW(aiding.add({1.1, std::nan("")}), std::invalid_argument);
  EXPECT_THROW(aiding.add({1.1, -3.0}), std::invalid_argument);
  EXPECT_EQ(aiding.size(), 1u);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
