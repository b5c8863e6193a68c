// The hazard mask and the score of an estimated terrain map against the truth.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "planetary_vo/terrain/resolution.h"
#include "planetary_vo/terrain/terrain_score.h"

using namespace planetary_vo::terrain;

namespace {

const float kNaN = std::numeric_limits<float>::quiet_NaN();

/// 10 x 10 cells: elevation = col, slope 5 deg except a 12 deg column 2, roughness 0.1 m except 0.5 m in
/// row 7.
GridSet truthGrids() {
  GridSet g;
  g.geometry.cols = g.geometry.rows = 10;
  g.geometry.cell_size_m = 1.0;
  cv::Mat z = g.geometry.newLayer(), s = g.geometry.newLayer(5.0f), r = g.geometry.newLayer(0.1f);
  for (int row = 0; row < 10; ++row)
    for (int col = 0; col < 10; ++col) z.at<float>(row, col) = static_cast<float>(col);
  s.col(2).setTo(12.0f);
  r.row(7).setTo(0.5f);
  g.layers = {{"elevation_m", z}, {"slope_deg", s}, {"roughness_m", r}};
  return g;
}

}  // namespace

TEST(Hazard, MaskMarksSlopeRoughnessAndUnknownCells) {
  const GridSet g = truthGrids();
  cv::Mat slope = g.layers.at("slope_deg").clone();
  slope.at<float>(0, 0) = kNaN;
  const cv::Mat mask = hazardMask(slope, g.layers.at("roughness_m"), HazardThresholds());
  EXPECT_EQ(mask.at<uint8_t>(0, 0), kUnknown);
  EXPECT_EQ(mask.at<uint8_t>(1, 1), kSafe);
  EXPECT_EQ(mask.at<uint8_t>(1, 2), kHazard);  // 12 deg
  EXPECT_EQ(mask.at<uint8_t>(7, 5), kHazard);  // 0.5 m
  EXPECT_THROW(hazardMask(slope, cv::Mat(3, 3, CV_32F), HazardThresholds()), std::invalid_argument);
}

TEST(TerrainScore, ErrorsCoverageAndHazardPrecisionRecall) {
  const GridSet truth = truthGrids();
  const TerrainScore perfect = scoreTerrain(truth, truth, HazardThresholds());
  EXPECT_EQ(perfect.cells, 100);
  EXPECT_EQ(perfect.elevation_rmse_m, 0.0);
  EXPECT_EQ(perfect.elevation_coverage, 1.0);
  EXPECT_EQ(perfect.hazard_tp, 19);  // column 2 and row 7
  EXPECT_EQ(perfect.hazard_precision, 1.0);
  EXPECT_EQ(perfect.hazard_recall, 1.0);

  // An estimate 0.5 m high, with half the area unknown, that misses the slope hazard and invents one.
  GridSet estimate = truthGrids();
  estimate.layers["elevation_m"] += 0.5;
  estimate.layers["slope_deg"].col(2).setTo(5.0f);
  estimate.layers["slope_deg"].at<float>(0, 0) = 20.0f;
  for (const char* name : {"elevation_m", "slope_deg", "roughness_m"})
    estimate.layers[name].rowRange(0, 5).colRange(5, 10).setTo(kNaN);
  const TerrainScore s = scoreTerrain(truth, estimate, HazardThresholds());
  EXPECT_EQ(s.cells_elevation, 75);
  EXPECT_DOUBLE_EQ(s.elevation_coverage, 0.75);
  EXPECT_NEAR(s.elevation_rmse_m, 0.5, 1e-6);
  EXPECT_NEAR(s.elevation_mean_error_m, 0.5, 1e-6);
  // Known cells: 75. True hazards among them: column 2 (10) + row 7 (10) - overlap 1 = 19; found: row 7 (10).
  EXPECT_EQ(s.hazard_tp, 10);
  EXPECT_EQ(s.hazard_fn, 9);
  EXPECT_EQ(s.hazard_fp, 1);  // (0, 0) was safe
  EXPECT_NEAR(s.hazard_recall, 10.0 / 19.0, 1e-12);
  EXPECT_NEAR(s.hazard_precision, 10.0 / 11.0, 1e-12);
  EXPECT_NE(toJson(s).find("\"hazard_tp\": 10"), std::string::npos);
  // Slope errors: the 10 cells of column 2 at -7 deg (12 -> 5), (0, 0) at +15 deg, the rest exact.
  EXPECT_NEAR(s.slope_mean_error_deg, (-7.0 * 10 + 15.0) / 75.0, 1e-6);
  EXPECT_EQ(s.slope_error_median_deg, 0.0);
  EXPECT_NEAR(s.slope_error_p90_deg, 7.0, 1e-6);

  GridSet other = truthGrids();
  other.geometry.cell_size_m = 0.5;
  EXPECT_THROW(scoreTerrain(truth, other, HazardThresholds()), std::invalid_argument);
}

// The truth at a map's resolution: a plane stays the same plane (a local plane fit reproduces it), a one-cell
// spike is spread over the support, cells whose support leaves the grid or meets an unknown are unknown.
TEST(Resolution, PlaneFitSupportKeepsPlanesAndSpreadsSpikes) {
  GridGeometry g;
  g.cols = g.rows = 41;
  g.cell_size_m = 0.5;
  cv::Mat plane = g.newLayer();
  for (int row = 0; row < g.rows; ++row)
    for (int col = 0; col < g.cols; ++col)
      plane.at<float>(row, col) = static_cast<float>(0.2 * g.x_m(col) - 0.1 * g.y_m(row) + 3.0);
  const cv::Mat seen = elevationAtSupport(g, plane, 2.0);
  EXPECT_TRUE(std::isnan(seen.at<float>(0, 0)));
  EXPECT_TRUE(std::isnan(seen.at<float>(20, 3)));  // support leaves the grid (reach 4 cells)
  for (int row = 4; row < g.rows - 4; ++row)
    for (int col = 4; col < g.cols - 4; ++col)
      ASSERT_NEAR(seen.at<float>(row, col), plane.at<float>(row, col), 1e-4) << row << " " << col;

  cv::Mat spike = g.newLayer(0.0f);
  spike.at<float>(20, 20) = 1.0f;
  spike.at<float>(5, 30) = kNaN;
  const cv::Mat spread = elevationAtSupport(g, spike, 2.0);
  EXPECT_GT(spread.at<float>(20, 20), 0.0f);
  EXPECT_LT(spread.at<float>(20, 20), 0.2f);
  EXPECT_GT(spread.at<float>(20, 22), 0.0f);
  EXPECT_TRUE(std::isnan(spread.at<float>(6, 30)));

  GridSet truth;
  truth.geometry = g;
  truth.layers["elevation_m"] = plane;
  const GridSet at = truthAtSupport(truth, 2.0, 2.0);
  EXPECT_NEAR(at.layers.at("slope_deg").at<float>(20, 20), std::atan(std::hypot(0.2, 0.1)) * 180.0 / M_PI,
              1e-3);
  EXPECT_THROW(elevationAtSupport(g, plane, 0.25), std::invalid_argument);
}

// A chosen site is truly safe only when every true cell within its clearance is known and safe.
TEST(TerrainScore, SiteCheckLooksAtEveryTrueCellWithinTheClearance) {
  GridSet truth;
  truth.geometry = GridGeometry::centeredOnOrigin(10.0, 0.5);
  truth.layers["slope_deg"] = truth.geometry.newLayer(2.0f);
  truth.layers["roughness_m"] = truth.geometry.newLayer(0.05f);
  LandingSiteParams params;
  params.min_clearance_m = 3.0;
  LandingSite site;  // at the origin
  int col = 0, row = 0;
  ASSERT_TRUE(truth.geometry.cellAt(0.0, 0.0, &col, &row));
  SiteCheck check = checkSite(truth, site, HazardThresholds(), params);
  EXPECT_TRUE(check.truly_safe);
  EXPECT_EQ(check.cells_hazard, 0);
  EXPECT_GT(check.cells_checked, 100);
  EXPECT_NEAR(check.true_slope_deg, 2.0, 1e-6);
  EXPECT_TRUE(std::isnan(check.nearest_unsafe_m));
  // A rock 4 m away: outside the clearance, found as the nearest unsafe cell.
  truth.layers["roughness_m"].at<float>(row, col + 8) = 0.5f;
  check = checkSite(truth, site, HazardThresholds(), params);
  EXPECT_TRUE(check.truly_safe);
  EXPECT_NEAR(check.nearest_unsafe_m, 4.0, 1e-9);
  // 2.5 m away: inside. An unknown cell inside is not safe either.
  truth.layers["roughness_m"].at<float>(row + 5, col) = 0.5f;
  check = checkSite(truth, site, HazardThresholds(), params);
  EXPECT_FALSE(check.truly_safe);
  EXPECT_EQ(check.cells_hazard, 1);
  truth.layers["roughness_m"].at<float>(row + 5, col) = 0.05f;
  truth.layers["slope_deg"].at<float>(row - 1, col - 1) = kNaN;
  check = checkSite(truth, site, HazardThresholds(), params);
  EXPECT_FALSE(check.truly_safe);
  EXPECT_EQ(check.cells_unknown, 1);
}

// The truth in the navigation's frame: a navigation error e = (1.2, -0.7, 0.5) m moves the ground to
// (x + e_x, y + e_y), rounded to whole 0.5 m cells (+2, -1), and raises it by e_z; a site the map put on the
// moved rock is unsafe there, and safe at the world's coordinates of that rock's image.
TEST(TerrainScore, TruthInTheNavigationFrameIsTheGroundMovedByTheNavigationError) {
  GridSet truth;
  truth.geometry = GridGeometry::centeredOnOrigin(10.0, 0.5);
  truth.layers["elevation_m"] = truth.geometry.newLayer(1.0f);
  truth.layers["slope_deg"] = truth.geometry.newLayer(2.0f);
  truth.layers["roughness_m"] = truth.geometry.newLayer(0.05f);
  int col = 0, row = 0;
  ASSERT_TRUE(truth.geometry.cellAt(0.0, 0.0, &col, &row));
  truth.layers["roughness_m"].at<float>(row, col) = 0.5f;  // a rock at the world's origin
  truth.layers["elevation_m"].at<float>(row, col) = 1.5f;
  const GridSet moved = truthInNavigationFrame(truth, 1.2, -0.7, 0.5);
  const cv::Mat& r = moved.layers.at("roughness_m");
  const cv::Mat& z = moved.layers.at("elevation_m");
  EXPECT_FLOAT_EQ(r.at<float>(row - 1, col + 2), 0.5f);
  EXPECT_FLOAT_EQ(r.at<float>(row, col), 0.05f);
  EXPECT_FLOAT_EQ(z.at<float>(row - 1, col + 2), 2.0f);
  EXPECT_FLOAT_EQ(z.at<float>(row, col), 1.5f);
  // Brought in from outside: unknown along the low-x edge (2 columns) and the high-y edge (1 row).
  EXPECT_TRUE(std::isnan(r.at<float>(5, 0)) && std::isnan(r.at<float>(5, 1)));
  EXPECT_FALSE(std::isnan(r.at<float>(5, 2)));
  EXPECT_TRUE(std::isnan(r.at<float>(truth.geometry.rows - 1, 5)));
  EXPECT_FALSE(std::isnan(r.at<float>(truth.geometry.rows - 2, 5)));
  EXPECT_DOUBLE_EQ(moved.parameters.at("navigation_error_x_m"), 1.2);
  // A site on the map's image of the rock, (1.0, -0.5): unsafe where the lander touches down, safe at the
  // world's (1.0, -0.5), 1.1 m from the rock; one 2.5 m from the image is safe either way.
  LandingSiteParams params;
  params.min_clearance_m = 0.5;
  LandingSite site;
  site.x_m = 1.0;
  site.y_m = -0.5;
  EXPECT_TRUE(checkSite(truth, site, HazardThresholds(), params).truly_safe);
  EXPECT_FALSE(checkSite(moved, site, HazardThresholds(), params).truly_safe);
  site.x_m = 3.5;
  EXPECT_TRUE(checkSite(truth, site, HazardThresholds(), params).truly_safe);
  EXPECT_TRUE(checkSite(moved, site, HazardThresholds(), params).truly_safe);
  EXPECT_THROW(truthInNavigationFrame(truth, std::nan(""), 0.0, 0.0), std::invalid_argument);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
