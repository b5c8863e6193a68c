// The ranked safe landing sites: exact answers on synthetic hazard maps (a safe disc in hazards, two equal
// discs, unknown cells, the uncertainty margin, the separation, the empty result and its reason), the slope
// sigma model against the plane fit it bounds, and a rough 513 x 513 terrain written to and read back from
// grid files, whose sites are checked against an independent brute-force plane fit (and timed).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "planetary_vo/terrain/landing_sites.h"
#include "planetary_vo/terrain/surface_analysis.h"

using namespace planetary_vo::terrain;

namespace {

const float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kRad2Deg = 180.0 / M_PI;

/// cols x rows cells of 0.5 m, world x from x0, y from y0; every cell a hazard (20 deg, 0.05 m); elevation
/// 0.01 * col + 100 m.
GridSet hazardField(int cols, int rows, double x0, double y0) {
  GridSet g;
  g.geometry.cols = cols;
  g.geometry.rows = rows;
  g.geometry.cell_size_m = 0.5;
  g.geometry.x0_m = x0;
  g.geometry.y0_m = y0;
  cv::Mat z = g.geometry.newLayer();
  for (int row = 0; row < rows; ++row)
    for (int col = 0; col < cols; ++col) z.at<float>(row, col) = static_cast<float>(100.0 + 0.01 * col);
  g.layers = {{"elevation_m", z},
              {"slope_deg", g.geometry.newLayer(20.0f)},
              {"roughness_m", g.geometry.newLayer(0.05f)}};
  g.parameters["footprint_diameter_m"] = 4.0;
  return g;
}

/// Sets slope and roughness of the cells whose centres lie within radius_m of world (cx, cy).
void paintDisc(GridSet* g, double cx, double cy, double radius_m, float slope_deg, float roughness_m) {
  const GridGeometry& geo = g->geometry;
  for (int row = 0; row < geo.rows; ++row)
    for (int col = 0; col < geo.cols; ++col)
      if (std::hypot(geo.x_m(col) - cx, geo.y_m(row) - cy) <= radius_m + 1e-9) {
        g->layers["slope_deg"].at<float>(row, col) = slope_deg;
        g->layers["roughness_m"].at<float>(row, col) = roughness_m;
      }
}

/// Two identical safe discs (radius 5 m, 2 deg, 0.05 m) centred at (-10, 0) and (20, 0) in hazards; x from
/// -30 m, y from -15 m.
GridSet twoEqualDiscs() {
  GridSet g = hazardField(121, 61, -30.0, -15.0);
  paintDisc(&g, -10.0, 0.0, 5.0, 2.0f, 0.05f);
  paintDisc(&g, 20.0, 0.0, 5.0, 2.0f, 0.05f);
  return g;
}

/// Distance (m) from a cell centre to the nearest cell centre that is not safe under `thresholds` (slope and
/// roughness raised by the given per-cell amounts), the cells just outside the grid included.
double bruteForceClearance(const GridGeometry& geo, const cv::Mat& slope_up, const cv::Mat& rough_up,
                           const HazardThresholds& t, int col0, int row0) {
  double best2 = std::numeric_limits<double>::infinity();
  for (int row = -1; row <= geo.rows; ++row)
    for (int col = -1; col <= geo.cols; ++col) {
      bool unsafe = !geo.contains(col, row);
      if (!unsafe) {
        const float s = slope_up.at<float>(row, col), r = rough_up.at<float>(row, col);
        unsafe = !(s <= t.max_slope_deg && r <= t.max_roughness_m);  // NaN: unsafe
      }
      if (unsafe)
        best2 = std::min(best2, double(col - col0) * (col - col0) + double(row - row0) * (row - row0));
    }
  return std::sqrt(best2) * geo.cell_size_m;
}

double siteDistance(const LandingSite& a, const LandingSite& b) {
  return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m);
}

}  // namespace

TEST(LandingSites, CentreOfASafeDiscInHazardsIsTheBestSite) {
  // 61 x 61 cells, x and y from -15 to 15 m; a disc of radius 5 m (10 cells) centred at (4, -3), 2 deg and
  // 0.05 m, in 20 deg terrain. Target: the origin, 5 m from the centre.
  GridSet g = hazardField(61, 61, -15.0, -15.0);
  paintDisc(&g, 4.0, -3.0, 5.0, 2.0f, 0.05f);
  LandingSiteParams params;
  params.max_distance_from_target_m = 50.0;
  const LandingSiteResult r = findLandingSites(g, HazardThresholds(), params);
  ASSERT_EQ(r.sites.size(), 1u) << r.reason;  // every other qualifying cell is within 10 m of the centre
  const LandingSite& s = r.sites[0];
  EXPECT_EQ(s.col, 38);
  EXPECT_EQ(s.row, 24);
  EXPECT_DOUBLE_EQ(s.x_m, 4.0);
  EXPECT_DOUBLE_EQ(s.y_m, -3.0);
  // The nearest cell outside the disc: offset (10, 1) cells.
  EXPECT_NEAR(s.clearance_m, std::sqrt(101.0) * 0.5, 1e-4);
  EXPECT_NEAR(s.distance_to_target_m, 5.0, 1e-12);
  EXPECT_NEAR(s.elevation_m, 100.0 + 0.01 * 38, 1e-4);
  EXPECT_FLOAT_EQ(s.slope_deg, 2.0f);
  EXPECT_FLOAT_EQ(s.roughness_m, 0.05f);
  EXPECT_NEAR(s.slope_margin_deg, 8.0, 1e-5);
  EXPECT_NEAR(s.roughness_margin_m, 0.25, 1e-6);
  EXPECT_EQ(s.slope_sigma_deg, 0.0);
  EXPECT_FALSE(r.uncertainty_applied);
  // Tightest margin: the clearance's (5.025 - 3) / 3; divert cost 5 / 50.
  EXPECT_NEAR(s.score, (std::sqrt(101.0) * 0.5 - 3.0) / 3.0 - 0.1, 1e-5);
  EXPECT_TRUE(r.reason.empty());
  // The disc's cells with >= 3 m clearance: offsets with the nearest outside cell >= 6 cells away.
  EXPECT_GT(r.cells_qualifying, 1);
  EXPECT_EQ(r.cells_safe, 317);  // cells of a radius-10 disc (Gauss circle count)
}

TEST(LandingSites, OfTwoEqualSitesTheNearerToTheTargetComesFirst) {
  GridSet g = twoEqualDiscs();
  LandingSiteParams params;
  params.max_distance_from_target_m = 50.0;
  LandingSiteResult r = findLandingSites(g, HazardThresholds(), params);
  ASSERT_EQ(r.sites.size(), 2u) << r.reason;
  EXPECT_DOUBLE_EQ(r.sites[0].x_m, -10.0);
  EXPECT_DOUBLE_EQ(r.sites[1].x_m, 20.0);
  EXPECT_NEAR(r.sites[0].score - r.sites[1].score, (20.0 - 10.0) / 50.0, 1e-9);
  // Same sites, the other order when the target moves nearer the second.
  params.target_x_m = 12.0;
  r = findLandingSites(g, HazardThresholds(), params);
  ASSERT_EQ(r.sites.size(), 2u) << r.reason;
  EXPECT_DOUBLE_EQ(r.sites[0].x_m, 20.0);
  EXPECT_DOUBLE_EQ(r.sites[1].x_m, -10.0);
  EXPECT_NEAR(r.sites[0].distance_to_target_m, 8.0, 1e-12);
  // Out of reach: a search radius of 15 m from (12, 0) keeps only the second.
  params.max_distance_from_target_m = 15.0;
  r = findLandingSites(g, HazardThresholds(), params);
  ASSERT_EQ(r.sites.size(), 1u);
  EXPECT_DOUBLE_EQ(r.sites[0].x_m, 20.0);
}

TEST(LandingSites, CellsSeenInShadowAreNotSafe) {
  // Two equal discs as above; a shadow (fraction 1) 2 m across at the centre of the nearer one: the
  // slope and roughness say nothing of it (a rock smaller than the map's support). The nearer disc then has
  // no cell with 3 m clearance, so the farther one is chosen; without the layer, or with shadows never a
  // hazard, the nearer one.
  GridSet g = twoEqualDiscs();
  LandingSiteParams params;
  params.max_distance_from_target_m = 50.0;
  LandingSiteResult r = findLandingSites(g, HazardThresholds(), params);
  ASSERT_FALSE(r.sites.empty()) << r.reason;
  EXPECT_DOUBLE_EQ(r.sites[0].x_m, -10.0);

  cv::Mat shadow = g.geometry.newLayer(0.0f);
  for (int row = 0; row < g.geometry.rows; ++row)
    for (int col = 0; col < g.geometry.cols; ++col) {
      if (std::hypot(g.geometry.x_m(col) - (-10.0), g.geometry.y_m(row)) <= 1.0)
        shadow.at<float>(row, col) = 1.0f;
      if (g.geometry.x_m(col) > 25.0) shadow.at<float>(row, col) = kNaN;  // not seen: no information
    }
  g.layers["shadow_fraction"] = shadow;
  r = findLandingSites(g, HazardThresholds(), params);
  ASSERT_EQ(r.sites.size(), 1u) << r.reason;
  EXPECT_DOUBLE_EQ(r.sites[0].x_m, 20.0);
  // A cell dark in half of its views is still safe (the default limit: more than half).
  shadow.setTo(0.5f, shadow == 1.0f);
  r = findLandingSites(g, HazardThresholds(), params);
  ASSERT_FALSE(r.sites.empty());
  EXPECT_DOUBLE_EQ(r.sites[0].x_m, -10.0);
  shadow.setTo(1.0f, shadow == 0.5f);
  HazardThresholds ignore_shadows;
  ignore_shadows.max_shadow_fraction = 1.0;
  r = findLandingSites(g, ignore_shadows, params);
  ASSERT_FALSE(r.sites.empty());
  EXPECT_DOUBLE_EQ(r.sites[0].x_m, -10.0);
  // The hazard mask has the shadow unknown.
  const cv::Mat mask =
      hazardMask(g.layers["slope_deg"], g.layers["roughness_m"], shadow, cv::Mat(), HazardThresholds());
  int col = 0, row = 0;
  ASSERT_TRUE(g.geometry.cellAt(-10.0, 0.5, &col, &row));
  EXPECT_EQ(mask.at<uint8_t>(row, col), kUnknown);
  ASSERT_TRUE(g.geometry.cellAt(-10.0, -3.0, &col, &row));
  EXPECT_EQ(mask.at<uint8_t>(row, col), kSafe);
  HazardThresholds bad;
  bad.max_shadow_fraction = 1.5;
  EXPECT_THROW(findLandingSites(g, bad, params), std::invalid_argument);
}

TEST(LandingSites, TheShadingReliefRaisesTheSlopeByItsWeight) {
  // Two equal discs at 7 deg (a plane fit that flattened a steeper wall, say); over the nearer one the
  // shading reads 2 deg of relief under the plane (below max_shading_slope_deg, 2.7), over the farther one 0.5
  // deg. The target at x = 4 m: the nearer disc's edge is 9 m from it, the farther one's 11 m. Weight 0:
  // the shading is only a threshold, both discs qualify, the nearer first (slope margin 3 deg, 0.3 of the
  // limit, the tightest). Weight 1: the nearer disc's slope is 9 deg (margin 1), the farther one's 7.5
  // (margin 2.5), so the farther comes first (0.25 - 11 / 50 against 0.1 - 9 / 50); weight 2: the nearer
  // one is 11 deg, a hazard, and only the farther qualifies.
  GridSet g = twoEqualDiscs();
  paintDisc(&g, -10.0, 0.0, 5.0, 7.0f, 0.05f);
  paintDisc(&g, 20.0, 0.0, 5.0, 7.0f, 0.05f);
  cv::Mat shading = g.geometry.newLayer(0.5f);
  for (int row = 0; row < g.geometry.rows; ++row)
    for (int col = 0; col < g.geometry.cols; ++col) {
      if (g.geometry.x_m(col) < 5.0) shading.at<float>(row, col) = 2.0f;
      if (g.geometry.x_m(col) > 27.0) shading.at<float>(row, col) = kNaN;  // not measured: the slope alone
    }
  g.layers["shading_slope_deg"] = shading;
  LandingSiteParams params;
  params.target_x_m = 4.0;
  params.max_distance_from_target_m = 50.0;
  params.min_separation_m = 1.0;  // every qualifying cell may come back: the cells of both discs
  params.max_sites = 1000;
  HazardThresholds t;
  auto sitesAt = [](const LandingSiteResult& r, double x) {
    int n = 0;
    for (const LandingSite& s : r.sites) n += std::abs(s.x_m - x) <= 5.0;
    return n;
  };
  t.shading_slope_weight = 0.0;  // the shading as a threshold only
  LandingSiteResult r = findLandingSites(g, t, params);
  ASSERT_FALSE(r.sites.empty()) << r.reason;
  EXPECT_LE(std::abs(r.sites[0].x_m + 10.0), 5.0);
  EXPECT_NEAR(r.sites[0].slope_margin_deg, 3.0, 1e-5);
  EXPECT_GT(sitesAt(r, -10.0), 0);
  EXPECT_GT(sitesAt(r, 20.0), 0);
  t.shading_slope_weight = 1.0;
  r = findLandingSites(g, t, params);
  ASSERT_FALSE(r.sites.empty()) << r.reason;
  EXPECT_LE(std::abs(r.sites[0].x_m - 20.0), 5.0);
  EXPECT_NEAR(r.sites[0].slope_margin_deg, 2.5, 1e-5);
  EXPECT_FLOAT_EQ(r.sites[0].slope_deg, 7.0f);  // the plane's slope, as estimated
  EXPECT_GT(sitesAt(r, -10.0), 0);
  for (const LandingSite& s : r.sites) {
    if (s.x_m < 0.0) {
      EXPECT_NEAR(s.slope_margin_deg, 1.0, 1e-5);
    }
  }
  t.shading_slope_weight = 2.0;
  r = findLandingSites(g, t, params);
  ASSERT_FALSE(r.sites.empty()) << r.reason;
  EXPECT_EQ(sitesAt(r, -10.0), 0);
  EXPECT_GT(sitesAt(r, 20.0), 0);
  // The hazard mask applies the same sum: 7 + 2 * 2 > 10 over the nearer disc, 7 + 2 * 0.5 <= 10 beyond.
  const cv::Mat mask = hazardMask(g.layers["slope_deg"], g.layers["roughness_m"], cv::Mat(), shading, t);
  int col = 0, row = 0;
  ASSERT_TRUE(g.geometry.cellAt(-10.0, 0.0, &col, &row));
  EXPECT_EQ(mask.at<uint8_t>(row, col), kHazard);
  ASSERT_TRUE(g.geometry.cellAt(20.0, 0.0, &col, &row));
  EXPECT_EQ(mask.at<uint8_t>(row, col), kSafe);
  t.shading_slope_weight = -1.0;
  EXPECT_THROW(findLandingSites(g, t, params), std::invalid_argument);
  EXPECT_THROW(slopeWithShading(g.layers["slope_deg"], shading, -1.0), std::invalid_argument);
  EXPECT_THROW(slopeWithShading(g.layers["slope_deg"], shading(cv::Rect(0, 0, 10, 10)), 1.0),
               std::invalid_argument);
}

TEST(LandingSites, NoFootprintReachesReliefTheShadingShows) {
  // A plain (8 deg, 0.05 m: safe, the slope the tightest margin) whose shading reads 0.5 deg of relief
  // everywhere but at one cell 4 m east of the target, 4 deg (above max_shading_slope_deg, 2.7): a rock or a
  // pit the plane fit smooths away, whose RMS over the footprints of the cells around it is diluted below
  // the limit. With shading_margin_m 0 only that cell is a hazard, so the target itself (4 m from it,
  // clearance 3 m) is the site, although its footprint (2 m) plus the dispersion (3 m) reaches the relief.
  // With 2 m every cell within 2 m of it is a hazard too, and the site keeps the dispersion clear of them:
  // at least 2 + 3 m from the relief.
  GridSet g = hazardField(81, 81, -20.0, -20.0);
  paintDisc(&g, 0.0, 0.0, 100.0, 8.0f, 0.05f);
  cv::Mat shading = g.geometry.newLayer(0.5f);
  int col = 0, row = 0;
  ASSERT_TRUE(g.geometry.cellAt(4.0, 0.0, &col, &row));
  shading.at<float>(row, col) = 4.0f;
  for (int r = 0; r < g.geometry.rows; ++r) shading.at<float>(r, 0) = kNaN;  // not measured: no information
  g.layers["shading_slope_deg"] = shading;
  LandingSiteParams params;
  params.max_distance_from_target_m = 15.0;
  HazardThresholds t;
  EXPECT_EQ(t.shading_margin_m, 2.0);  // the default: the footprint's radius
  t.shading_margin_m = 0.0;
  LandingSiteResult r = findLandingSites(g, t, params);
  ASSERT_FALSE(r.sites.empty()) << r.reason;
  EXPECT_DOUBLE_EQ(r.sites[0].x_m, 0.0);
  EXPECT_DOUBLE_EQ(r.sites[0].y_m, 0.0);
  EXPECT_NEAR(r.sites[0].clearance_m, 4.0, 1e-4);
  EXPECT_NEAR(r.sites[0].slope_margin_deg, 10.0 - 8.0 - 0.5 * 0.5, 1e-5);  // the weight on its own shading

  t.shading_margin_m = 2.0;
  r = findLandingSites(g, t, params);
  ASSERT_FALSE(r.sites.empty()) << r.reason;
  EXPECT_GE(std::hypot(r.sites[0].x_m - 4.0, r.sites[0].y_m), 2.0 + 3.0 - 1e-9);
  EXPECT_LE(r.sites[0].distance_to_target_m, 3.0);  // west of the target, a clearance margin to spare
  EXPECT_GE(r.sites[0].clearance_m, 3.0);
  // The weight still applies to each cell's own shading, not to the largest one near it.
  EXPECT_NEAR(r.sites[0].slope_margin_deg, 10.0 - 8.0 - 0.5 * 0.5, 1e-5);

  // The layer the threshold is applied to: the largest shading within the margin (centre to centre), NaN
  // not winning; and the hazard mask of the grid's layers with it.
  const cv::Mat near = shadingWithinMargin(g, t);
  const cv::Mat mask =
      hazardMask(g.layers["slope_deg"], g.layers["roughness_m"], cv::Mat(), shading, near, t);
  auto at = [&](const cv::Mat& m, double x, double y) {
    EXPECT_TRUE(g.geometry.cellAt(x, y, &col, &row));
    return m.type() == CV_32F ? m.at<float>(row, col) : float(m.at<uint8_t>(row, col));
  };
  EXPECT_EQ(at(near, 4.0, 0.0), 4.0f);
  EXPECT_EQ(at(near, 2.0, 0.0), 4.0f);   // 2 m: in
  EXPECT_EQ(at(near, 4.0, -2.0), 4.0f);  // in
  EXPECT_EQ(at(near, 2.0, 0.5), 0.5f);   // 2.06 m: out
  EXPECT_EQ(at(near, -20.0, 0.0), 0.5f);  // an unmeasured cell with measured cells within the margin
  EXPECT_EQ(at(mask, 2.0, 0.0), float(kHazard));
  EXPECT_EQ(at(mask, 2.0, 0.5), float(kSafe));
  EXPECT_EQ(at(hazardMask(g.layers["slope_deg"], g.layers["roughness_m"], cv::Mat(), shading, t), 2.0, 0.0),
            float(kSafe));  // the cell's own shading alone
  EXPECT_THROW(hazardMask(g.layers["slope_deg"], g.layers["roughness_m"], cv::Mat(), shading, cv::Mat(), t),
               std::invalid_argument);
  t.shading_margin_m = 0.4;  // less than a cell: the layer as it is
  {
    cv::Mat a = shadingWithinMargin(g, t), b = shading.clone();
    cv::patchNaNs(a, -7.0);
    cv::patchNaNs(b, -7.0);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  }
  t.shading_margin_m = 2.0;
  GridSet unmeasured = g;
  unmeasured.layers["shading_slope_deg"] = g.geometry.newLayer();
  const cv::Mat none_near = shadingWithinMargin(unmeasured, t);
  EXPECT_EQ(cv::countNonZero(none_near == none_near), 0);  // all NaN
  GridSet without = g;
  without.layers.erase("shading_slope_deg");
  EXPECT_TRUE(shadingWithinMargin(without, t).empty());
  t.shading_margin_m = -1.0;
  EXPECT_THROW(findLandingSites(g, t, params), std::invalid_argument);
  EXPECT_THROW(shadingWithinMargin(g, t), std::invalid_argument);
  t.shading_margin_m = std::numeric_limits<double>::infinity();
  EXPECT_THROW(findLandingSites(g, t, params), std::invalid_argument);
}

TEST(LandingSites, UnknownCellsAreNeverSafe) {
  const HazardThresholds t;
  // An unknown slope 1.5 m from the disc centre: the centre's clearance drops to 1.5 m, so it is out.
  for (const char* layer : {"slope_deg", "roughness_m"}) {
    GridSet g = hazardField(61, 61, -15.0, -15.0);
    paintDisc(&g, 4.0, -3.0, 5.0, 2.0f, 0.05f);
    g.layers[layer].at<float>(24, 41) = kNaN;
    const LandingSiteResult r = findLandingSites(g, t, LandingSiteParams());
    ASSERT_FALSE(r.sites.empty()) << layer << ": " << r.reason;
    for (const LandingSite& s : r.sites) {
      EXPECT_GE(std::hypot(s.x_m - 5.5, s.y_m + 3.0), 3.0) << layer;
      EXPECT_NEAR(
          s.clearance_m,
          bruteForceClearance(g.geometry, g.layers["slope_deg"], g.layers["roughness_m"], t, s.col, s.row),
          1e-4)
          << layer;
    }
    EXPECT_EQ(r.cells_safe, 316) << layer;  // the disc less the unknown cell
  }
  // A grid safe everywhere: its outside counts as unknown. 21 x 21 cells, the centre is 11 cells from the
  // first cell outside.
  GridSet g = hazardField(21, 21, -5.0, -5.0);
  g.layers["slope_deg"].setTo(1.0f);
  const LandingSiteResult r = findLandingSites(g, t, LandingSiteParams());
  ASSERT_FALSE(r.sites.empty()) << r.reason;
  EXPECT_EQ(r.sites[0].col, 10);
  EXPECT_EQ(r.sites[0].row, 10);
  EXPECT_NEAR(r.sites[0].clearance_m, 5.5, 1e-4);
}

TEST(LandingSites, SlopeSigmaIsTheTiltOfTheWorstCorrelatedElevationError) {
  // The 4 m disc of 0.5 m cells: sum |dx| = 80, sum dx^2 = 192 (cells).
  const double c = slopeSigmaPerElevationSigma(0.5, 4.0);
  EXPECT_NEAR(c, 80.0 / 192.0 / 0.5, 1e-12);
  EXPECT_NEAR(c * 4.0, 3.333, 1e-3);  // the header's "3.33 / footprint diameter"
  // Independent errors would give 1 / sqrt(sum dx^2) (in metres): the header's ratio.
  EXPECT_NEAR(c * std::sqrt(192.0 * 0.25), 5.77, 0.01);
  EXPECT_THROW(slopeSigmaPerElevationSigma(0.5, 0.5), std::invalid_argument);
  // The error pattern that reaches the bound (sigma_z sign(dx) on a flat surface) gives, through the plane
  // fit of surface_analysis, exactly that slope.
  GridGeometry geo;
  geo.cols = geo.rows = 21;
  geo.cell_size_m = 0.5;
  const double sigma_z = 0.07;
  cv::Mat z = geo.newLayer(0.0f);
  for (int row = 0; row < 21; ++row)
    for (int col = 0; col < 21; ++col)
      z.at<float>(row, col) = static_cast<float>(sigma_z * ((col > 10) - (col < 10)));
  const SurfaceMaps s = analyzeSurface(geo, z, 4.0);
  EXPECT_NEAR(s.slope_deg.at<float>(10, 10), std::atan(c * sigma_z) * kRad2Deg, 1e-4);
}

TEST(LandingSites, UncertaintyMarginRejectsAMarginalCell) {
  // Three safe discs in hazards: A, 9 deg, radius 5 m at (-8, 0); B, 3 deg, radius 9 m at (15, 0); C, 2 deg
  // and 0.27 m (roughness marginal), radius 5 m at (-8, 15). Each disc's best cell is not its centre: the
  // tightest margin stops growing once the clearance's exceeds the slope's, and nearer cells then win.
  GridSet g = hazardField(121, 121, -30.0, -30.0);
  paintDisc(&g, -8.0, 0.0, 5.0, 9.0f, 0.05f);
  paintDisc(&g, 15.0, 0.0, 9.0, 3.0f, 0.05f);
  paintDisc(&g, -8.0, 15.0, 5.0, 2.0f, 0.27f);
  const HazardThresholds t;
  LandingSiteParams params;
  params.confidence_k = 2.0;  // the figures below
  const auto sitesIn = [](const LandingSiteResult& r, double x, double y, double radius) {
    int n = 0;
    for (const LandingSite& s : r.sites) n += std::hypot(s.x_m - x, s.y_m - y) <= radius;
    return n;
  };
  // No sigma layer: a site in each disc.
  LandingSiteResult r = findLandingSites(g, t, params);
  EXPECT_EQ(sitesIn(r, -8.0, 0.0, 5.0), 1);
  EXPECT_GE(sitesIn(r, 15.0, 0.0, 9.0), 1);
  EXPECT_EQ(sitesIn(r, -8.0, 15.0, 5.0), 1);

  // sigma_z = 0.02 m: sigma_slope = atan(0.833 * 0.02) = 0.955 deg, k = 2 raises A to 10.9 deg and C to
  // 0.31 m; B keeps 10 - 3 - 1.91 deg and 0.3 - 0.05 - 0.04 m.
  g.layers["elevation_sigma_m"] = g.geometry.newLayer(0.02f);
  r = findLandingSites(g, t, params);
  EXPECT_TRUE(r.uncertainty_applied);
  ASSERT_FALSE(r.sites.empty()) << r.reason;
  EXPECT_EQ(sitesIn(r, -8.0, 0.0, 5.0), 0);
  EXPECT_EQ(sitesIn(r, -8.0, 15.0, 5.0), 0);
  EXPECT_EQ(sitesIn(r, 15.0, 0.0, 9.0), static_cast<int>(r.sites.size()));
  const double sigma_slope_deg = std::atan(slopeSigmaPerElevationSigma(0.5, 4.0) * 0.02) * kRad2Deg;
  EXPECT_NEAR(sigma_slope_deg, 0.955, 1e-3);
  const LandingSite b = r.sites[0];
  EXPECT_NEAR(b.slope_sigma_deg, sigma_slope_deg, 1e-5);
  EXPECT_NEAR(b.roughness_sigma_m, 0.02, 1e-7);
  EXPECT_NEAR(b.slope_margin_deg, 10.0 - 3.0 - 2.0 * sigma_slope_deg, 1e-5);
  EXPECT_NEAR(b.roughness_margin_m, 0.3 - 0.05 - 0.04, 1e-6);
  // k = 0: no margin, a site in each disc again.
  params.confidence_k = 0.0;
  EXPECT_EQ(sitesIn(findLandingSites(g, t, params), -8.0, 0.0, 5.0), 1);
  EXPECT_EQ(sitesIn(findLandingSites(g, t, params), -8.0, 15.0, 5.0), 1);
  params.confidence_k = 2.0;

  // sigma_z is the largest over the footprint: one poor cell 1.5 m from the best site (inside its 2 m
  // footprint radius) moves the sites to where no footprint holds it.
  const int poor_col = b.col + 3, poor_row = b.row;
  g.layers["elevation_sigma_m"].at<float>(poor_row, poor_col) = 1.0f;
  r = findLandingSites(g, t, params);
  ASSERT_FALSE(r.sites.empty()) << r.reason;
  EXPECT_FALSE(r.sites[0].col == b.col && r.sites[0].row == b.row);
  for (const LandingSite& s : r.sites) {
    const double from_poor_m = std::hypot(s.x_m - g.geometry.x_m(poor_col), s.y_m - g.geometry.y_m(poor_row));
    EXPECT_GT(from_poor_m, 2.0 + 1e-9);
    // The cells whose footprint holds the poor cell are unsafe: the clearance reaches no farther.
    double to_unsafe_m = std::numeric_limits<double>::infinity();
    for (int dj = -4; dj <= 4; ++dj)
      for (int di = -4; di <= 4; ++di)
        if (di * di + dj * dj <= 16)
          to_unsafe_m = std::min(to_unsafe_m, std::hypot(s.x_m - g.geometry.x_m(poor_col + di),
                                                         s.y_m - g.geometry.y_m(poor_row + dj)));
    EXPECT_LE(s.clearance_m, to_unsafe_m + 1e-4);
    EXPECT_GE(to_unsafe_m, params.min_clearance_m - 1e-4);
    EXPECT_NEAR(s.roughness_sigma_m, 0.02, 1e-7);
  }
  // An unknown sigma in the footprint leaves the cell unknown, whatever k.
  g.layers["elevation_sigma_m"].setTo(kNaN);
  params.confidence_k = 0.0;
  r = findLandingSites(g, t, params);
  EXPECT_TRUE(r.sites.empty());
  EXPECT_EQ(r.cells_known, 0);
}

TEST(LandingSites, ReturnedSitesKeepTheirSeparation) {
  // 121 x 121 cells, all known; slope 1 deg + 0.1 deg per metre of |x|: the scores vary smoothly.
  GridSet g = hazardField(121, 121, -30.0, -30.0);
  for (int col = 0; col < 121; ++col)
    g.layers["slope_deg"].col(col).setTo(static_cast<float>(1.0 + 0.1 * std::abs(g.geometry.x_m(col))));
  LandingSiteParams params;
  params.max_sites = 8;
  const LandingSiteResult r = findLandingSites(g, HazardThresholds(), params);
  ASSERT_EQ(r.sites.size(), 8u) << r.reason;
  for (size_t i = 0; i < r.sites.size(); ++i) {
    if (i > 0) {
      EXPECT_LE(r.sites[i].score, r.sites[i - 1].score);
    }
    for (size_t j = 0; j < i; ++j) EXPECT_GE(siteDistance(r.sites[i], r.sites[j]), params.min_separation_m);
  }
  // The first site is the best cell overall.
  params.max_sites = 1;
  params.min_separation_m = 0.0;
  const LandingSiteResult best = findLandingSites(g, HazardThresholds(), params);
  ASSERT_EQ(best.sites.size(), 1u);
  EXPECT_EQ(best.sites[0].col, r.sites[0].col);
  EXPECT_EQ(best.sites[0].row, r.sites[0].row);
  // Without a separation the next sites are the neighbouring cells of the best one.
  params.max_sites = 8;
  const LandingSiteResult packed = findLandingSites(g, HazardThresholds(), params);
  ASSERT_EQ(packed.sites.size(), 8u);
  for (const LandingSite& s : packed.sites) EXPECT_LT(siteDistance(s, packed.sites[0]), 2.0);
}

TEST(LandingSites, NoQualifyingSiteGivesAnEmptyListAndTheReason) {
  const HazardThresholds t;
  GridSet g = hazardField(61, 61, -15.0, -15.0);
  LandingSiteResult r = findLandingSites(g, t, LandingSiteParams());
  EXPECT_TRUE(r.sites.empty());
  EXPECT_NE(r.reason.find("none is safe with confidence"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("20.00 deg"), std::string::npos) << r.reason;  // the smallest slope
  EXPECT_GT(r.cells_known, 0);
  EXPECT_EQ(r.cells_safe, 0);

  paintDisc(&g, 0.0, 0.0, 2.0, 2.0f, 0.05f);  // safe, but at most 2.06 m from a hazard
  r = findLandingSites(g, t, LandingSiteParams());
  EXPECT_TRUE(r.sites.empty());
  EXPECT_NE(r.reason.find("clearance"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("2.06 m"), std::string::npos) << r.reason;
  EXPECT_GT(r.cells_safe, 0);

  g.layers["slope_deg"].setTo(kNaN);
  LandingSiteParams reach_50;
  reach_50.max_distance_from_target_m = 50.0;
  r = findLandingSites(g, t, reach_50);
  EXPECT_TRUE(r.sites.empty());
  EXPECT_NE(r.reason.find("no cell within 50.0 m of the target (0.0, 0.0) has a known"), std::string::npos)
      << r.reason;

  LandingSiteParams far;
  far.target_x_m = 1000.0;
  r = findLandingSites(hazardField(61, 61, -15.0, -15.0), t, far);
  EXPECT_TRUE(r.sites.empty());
  EXPECT_NE(r.reason.find("no cell of the grid lies"), std::string::npos) << r.reason;
  EXPECT_EQ(r.cells_in_reach, 0);
}

TEST(LandingSites, InvalidInputsThrow) {
  const HazardThresholds t;
  const GridSet good = hazardField(21, 21, 0.0, 0.0);
  EXPECT_NO_THROW(findLandingSites(good, t));
  GridSet g = good;
  g.layers.erase("roughness_m");
  EXPECT_THROW(findLandingSites(g, t), std::invalid_argument);
  g = good;
  g.layers["slope_deg"] = cv::Mat(21, 20, CV_32FC1, cv::Scalar(1.0));
  EXPECT_THROW(findLandingSites(g, t), std::invalid_argument);
  g = good;
  g.layers["elevation_sigma_m"] = cv::Mat(21, 21, CV_64FC1, cv::Scalar(0.1));
  EXPECT_THROW(findLandingSites(g, t), std::invalid_argument);
  g = good;
  g.layers["elevation_sigma_m"] = g.geometry.newLayer(0.1f);
  g.parameters.clear();  // no footprint to turn the elevation sigma into a slope sigma
  EXPECT_THROW(findLandingSites(g, t), std::invalid_argument);
  HazardThresholds zero;
  zero.max_roughness_m = 0.0;
  EXPECT_THROW(findLandingSites(good, zero), std::invalid_argument);
  const auto bad = [&](auto change) {
    LandingSiteParams p;
    change(p);
    EXPECT_THROW(findLandingSites(good, t, p), std::invalid_argument);
  };
  bad([](LandingSiteParams& p) { p.max_sites = 0; });
  bad([](LandingSiteParams& p) { p.min_clearance_m = 0.0; });
  bad([](LandingSiteParams& p) { p.confidence_k = -1.0; });
  bad([](LandingSiteParams& p) { p.min_separation_m = -1.0; });
  bad([](LandingSiteParams& p) { p.distance_weight = -0.5; });
  bad([](LandingSiteParams& p) { p.max_distance_from_target_m = std::numeric_limits<double>::infinity(); });
  bad([](LandingSiteParams& p) { p.target_x_m = std::nan(""); });
}

namespace {

/// Deterministic uniform [0, 1) (a 64-bit LCG, the same on every platform).
struct Uniform {
  uint64_t state;
  double operator()() {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return double(state >> 11) * (1.0 / 9007199254740992.0);
  }
};

/// Slope (deg) and roughness (m) at one cell by an independent least-squares plane fit (Eigen) over the
/// cells within footprint / 2.
void bruteForceSurface(const GridGeometry& geo, const cv::Mat& z, double footprint_m, int col0, int row0,
                       double* slope_deg, double* roughness_m) {
  std::vector<Eigen::Vector3d> pts;
  const double r = 0.5 * footprint_m;
  const int R = static_cast<int>(std::ceil(r / geo.cell_size_m));
  for (int dj = -R; dj <= R; ++dj)
    for (int di = -R; di <= R; ++di) {
      const double dx = di * geo.cell_size_m, dy = dj * geo.cell_size_m;
      if (dx * dx + dy * dy <= r * r + 1e-9) pts.emplace_back(dx, dy, z.at<float>(row0 + dj, col0 + di));
    }
  Eigen::MatrixXd A(pts.size(), 3);
  Eigen::VectorXd b(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    A.row(i) << 1.0, pts[i].x(), pts[i].y();
    b(i) = pts[i].z();
  }
  const Eigen::Vector3d p = A.colPivHouseholderQr().solve(b);
  *slope_deg = std::atan(std::hypot(p(1), p(2))) * kRad2Deg;
  *roughness_m = (A * p - b).cwiseAbs().maxCoeff();
}

}  // namespace

TEST(LandingSites, SitesOnARoughTerrainAreSafeAcrossTheirClearance) {
  // The landing area of the renderer's grids (513 x 513 cells of 0.5 m, landing_area.h) over a synthetic
  // terrain: a 3 deg regional tilt, 60 craters (bowls 4-30 m across with a raised rim) and 3000 boulders
  // (0.1-1 m high, 0.35 height-to-diameter), its slope and roughness by surface_analysis; elevation sigma
  // 0.01 m, 0.2 m in a 20 m square south-west of the site.
  GridGeometry geo = GridGeometry::centeredOnOrigin(128.0, 0.5);
  ASSERT_EQ(geo.cols, 513);
  Uniform u{12345};
  struct Bump {
    double x, y, radius, height;
  };
  std::vector<Bump> craters, boulders;
  for (int i = 0; i < 60; ++i) craters.push_back({-128 + 256 * u(), -128 + 256 * u(), 2.0 + 13.0 * u(), 0.0});
  for (int i = 0; i < 3000; ++i) {
    const double h = 0.1 + 0.9 * u();
    boulders.push_back({-128 + 256 * u(), -128 + 256 * u(), 0.5 * h / 0.35, h});
  }
  cv::Mat z = geo.newLayer(0.0f);
  for (int row = 0; row < geo.rows; ++row)
    for (int col = 0; col < geo.cols; ++col)
      z.at<float>(row, col) =
          static_cast<float>(std::tan(3.0 / kRad2Deg) * (0.6 * geo.x_m(col) + 0.8 * geo.y_m(row)));
  const auto addBump = [&](const Bump& b, double extent, auto shape) {  // shape(distance / radius) in m
    int c0 = 0, r0 = 0, c1 = 0, r1 = 0;
    geo.cellAt(std::max(geo.x_m(0), b.x - extent * b.radius), std::max(geo.y_m(0), b.y - extent * b.radius),
               &c0, &r0);
    geo.cellAt(std::min(geo.x_m(geo.cols - 1), b.x + extent * b.radius),
               std::min(geo.y_m(geo.rows - 1), b.y + extent * b.radius), &c1, &r1);
    for (int row = r0; row <= r1; ++row)
      for (int col = c0; col <= c1; ++col) {
        const double d = std::hypot(geo.x_m(col) - b.x, geo.y_m(row) - b.y) / b.radius;
        if (d < extent) z.at<float>(row, col) += static_cast<float>(shape(d));
      }
  };
  for (const Bump& c : craters)  // a bowl of depth 0.2 R and a rim 0.04 R high falling off to 1.5 R
    addBump(c, 1.5, [&](double d) {
      return d < 1.0 ? 0.2 * c.radius * (d * d - 1.0) + 0.04 * c.radius : 0.04 * c.radius * (1.5 - d) / 0.5;
    });
  for (const Bump& b : boulders)  // a half ellipsoid
    addBump(b, 1.0, [&](double d) { return b.height * std::sqrt(1.0 - d * d); });
  const double footprint_m = 4.0;
  const SurfaceMaps surface = analyzeSurface(geo, z, footprint_m);
  cv::Mat sigma = geo.newLayer(0.01f);
  sigma(cv::Rect(geo.cols / 2 - 40, geo.rows / 2 - 40, 40, 40)).setTo(0.2f);
  GridSet written;
  written.geometry = geo;
  written.layers = {{"elevation_m", z},
                    {"elevation_sigma_m", sigma},
                    {"slope_deg", surface.slope_deg},
                    {"roughness_m", surface.roughness_m}};
  written.parameters["footprint_diameter_m"] = footprint_m;
  const std::string dir = std::string(PLANETARY_VO_TEST_OUTPUT_DIR) + "/terrain_landing_sites";
  std::filesystem::create_directories(dir);
  writeGridSet(dir, "synthetic_terrain", written);
  const GridSet grids = readGridSet(dir, "synthetic_terrain");

  const HazardThresholds t;
  const LandingSiteParams params;
  LandingSiteResult r;
  std::vector<double> ms;
  for (int i = 0; i < 20; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    r = findLandingSites(grids, t, params);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  std::printf("findLandingSites on %dx%d cells: median %.2f ms, min %.2f ms, max %.2f ms (20 calls)\n",
              geo.cols, geo.rows, ms[ms.size() / 2], ms.front(), ms.back());
  std::printf("cells in reach %d, known %d, safe with confidence %d, qualifying %d\n", r.cells_in_reach,
              r.cells_known, r.cells_safe, r.cells_qualifying);
  for (const LandingSite& s : r.sites)
    std::printf(
        "  site (%.1f, %.1f) z %.2f m: slope %.2f deg (margin %.2f), roughness %.3f m (margin %.3f), "
        "clearance %.2f m, %.1f m from the target, score %.3f\n",
        s.x_m, s.y_m, s.elevation_m, s.slope_deg, s.slope_margin_deg, s.roughness_m, s.roughness_margin_m,
        s.clearance_m, s.distance_to_target_m, s.score);
  ASSERT_EQ(static_cast<int>(r.sites.size()), params.max_sites) << r.reason;
  // The terrain has hazards near the target, so the clearance and the uncertainty matter.
  EXPECT_LT(r.cells_safe, r.cells_known);
  EXPECT_LT(r.cells_qualifying, r.cells_safe);

  const double c = slopeSigmaPerElevationSigma(0.5, footprint_m);
  const int reach = static_cast<int>(std::ceil(params.min_clearance_m / geo.cell_size_m));
  for (size_t i = 0; i < r.sites.size(); ++i) {
    const LandingSite& s = r.sites[i];
    EXPECT_LE(s.distance_to_target_m, params.max_distance_from_target_m);
    EXPECT_GE(s.clearance_m, params.min_clearance_m);
    for (size_t j = 0; j < i; ++j) EXPECT_GE(siteDistance(s, r.sites[j]), params.min_separation_m);
    // Every touchdown cell within the clearance: safe with confidence by an independent plane fit and a
    // brute-force largest sigma over its footprint.
    for (int dj = -reach; dj <= reach; ++dj)
      for (int di = -reach; di <= reach; ++di) {
        if (std::hypot(di, dj) * geo.cell_size_m >= params.min_clearance_m) continue;
        const int col = s.col + di, row = s.row + dj;
        double slope_deg = 0, roughness_m = 0, sigma_z = 0;
        bruteForceSurface(geo, z, footprint_m, col, row, &slope_deg, &roughness_m);
        for (int fj = -4; fj <= 4; ++fj)
          for (int fi = -4; fi <= 4; ++fi)
            if (fi * fi + fj * fj <= 16)
              sigma_z = std::max(sigma_z, double(sigma.at<float>(row + fj, col + fi)));
        EXPECT_LE(slope_deg + params.confidence_k * std::atan(c * sigma_z) * kRad2Deg, t.max_slope_deg + 1e-3)
            << "site " << i << " cell " << col << "," << row;
        EXPECT_LE(roughness_m + params.confidence_k * sigma_z, t.max_roughness_m + 1e-4)
            << "site " << i << " cell " << col << "," << row;
      }
  }
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
