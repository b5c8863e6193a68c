// The terrain model from map events: points kept across events (retired ones too), rejected ones dropped;
// the elevation, slope and roughness it rasterises against a known surface; holes reported, not filled.
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "planetary_vo/terrain/terrain_map.h"

using namespace planetary_vo;
using namespace planetary_vo::terrain;

namespace {

constexpr double kSlopeDeg = 8.0;
const double kGradient = std::tan(kSlopeDeg * M_PI / 180.0);

/// A plane rising along +x at 8 deg, with a 1 m high, 2 m wide block at (20, 20) and nothing measured in
/// the square x, y in [-40, -20] (a hole).
double surface(double x, double y) {
  const bool block = std::abs(x - 20.0) <= 1.0 && std::abs(y - 20.0) <= 1.0;
  return kGradient * x + (block ? 1.0 : 0.0);
}
bool inHole(double x, double y) { return x >= -40.0 && x <= -20.0 && y >= -40.0 && y <= -20.0; }

TerrainMapConfig smallArea() {
  TerrainMapConfig config;
  config.area.half_extent_m = 48.0;
  config.area.cell_size_m = 1.0;
  config.area.footprint_diameter_m = 4.0;
  config.support_radius_m = 1.0;
  return config;
}

/// A map point at p_world with a tight horizontal and the given vertical sigma, seen by 3 keyframes.
MapPointState groundPoint(uint64_t id, const Eigen::Vector3d& p_world, double sigma_z_m) {
  MapPointState p;
  p.id = id;
  p.p_world = p_world;
  p.covariance_world = Eigen::Vector3d(1e-4, 1e-4, sigma_z_m * sigma_z_m).asDiagonal();
  p.num_observations = 3;
  return p;
}

/// Points every `spacing_m` (jittered) with vertical noise `noise_m` and a matching covariance.
MapEvents pointsOnSurface(double spacing_m, double noise_m, uint64_t first_id, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  std::uniform_real_distribution<double> jitter(-0.3 * spacing_m, 0.3 * spacing_m);
  MapEvents events;
  uint64_t id = first_id;
  for (double y = -56.0; y <= 56.0; y += spacing_m) {
    for (double x = -56.0; x <= 56.0; x += spacing_m) {
      const double px = x + jitter(rng), py = y + jitter(rng);
      if (inHole(px, py)) continue;
      events.points_added.push_back(
          groundPoint(id++, Eigen::Vector3d(px, py, surface(px, py) + noise(rng)), noise_m));
    }
  }
  return events;
}

float at(const TerrainProducts& products, const std::string& layer, double x, double y) {
  int col = 0, row = 0;
  EXPECT_TRUE(products.grids.geometry.cellAt(x, y, &col, &row));
  return products.grids.layers.at(layer).at<float>(row, col);
}

}  // namespace

TEST(TerrainMap, ElevationSlopeAndRoughnessOfAKnownSurface) {
  TerrainMap map(smallArea());
  map.apply(pointsOnSurface(0.5, 0.05, 1, 7), true);
  const TerrainProducts products = map.products();
  EXPECT_TRUE(products.metric);
  EXPECT_GT(products.num_used, 30000u);
  const GridGeometry& g = products.grids.geometry;
  const cv::Mat& elevation = products.grids.layers.at("elevation_m");
  const cv::Mat& slope = products.grids.layers.at("slope_deg");
  const cv::Mat& roughness = products.grids.layers.at("roughness_m");
  const cv::Mat& sigma = products.grids.layers.at("elevation_sigma_m");
  double sq = 0.0, slope_sq = 0.0, z_sq = 0.0;
  int n = 0, n_slope = 0, normalised = 0;
  for (int row = 0; row < g.rows; ++row) {
    for (int col = 0; col < g.cols; ++col) {
      const double x = g.x_m(col), y = g.y_m(row);
      // Away from the block and the hole (footprint + support radius) and the edge.
      if (std::hypot(std::max(0.0, std::abs(x - 20.0) - 1.0), std::max(0.0, std::abs(y - 20.0) - 1.0)) < 5.0)
        continue;
      if (x > -45.0 && x < -15.0 && y > -45.0 && y < -15.0) continue;
      const float z = elevation.at<float>(row, col);
      ASSERT_TRUE(std::isfinite(z)) << x << " " << y;
      const double e = z - surface(x, y);
      sq += e * e;
      z_sq += (e / sigma.at<float>(row, col)) * (e / sigma.at<float>(row, col));
      normalised += 1;
      ++n;
      if (std::isfinite(slope.at<float>(row, col))) {
        slope_sq += std::pow(slope.at<float>(row, col) - kSlopeDeg, 2);
        ++n_slope;
        EXPECT_LT(roughness.at<float>(row, col), 0.3) << x << " " << y;
      }
    }
  }
  const double rmse = std::sqrt(sq / n), slope_rmse = std::sqrt(slope_sq / n_slope);
  std::printf("  elevation RMSE %.3f m (points 0.05 m), normalised %.2f; slope RMSE %.2f deg over %d cells\n",
              rmse, std::sqrt(z_sq / normalised), slope_rmse, n_slope);
  EXPECT_LT(rmse, 0.03);
  EXPECT_LT(slope_rmse, 0.5);
  EXPECT_GT(n_slope, 5000);
  // The block is a roughness hazard where the footprint covers part of it.
  EXPECT_GT(at(products, "roughness_m", 20.0, 20.0), 0.3f);
  EXPECT_GT(at(products, "roughness_m", 22.0, 20.0), 0.3f);
  // The hole stays unknown, not interpolated.
  EXPECT_TRUE(std::isnan(at(products, "elevation_m", -30.0, -30.0)));
  EXPECT_TRUE(std::isnan(at(products, "slope_deg", -30.0, -30.0)));
}

TEST(TerrainMap, KeepsRetiredPointsDropsRejectedOnesAndUnusablePoints) {
  TerrainMap map(smallArea());
  MapEvents first = pointsOnSurface(2.0, 0.05, 1, 3);
  const size_t n = first.points_added.size();
  map.apply(first, true);
  EXPECT_EQ(map.numPoints(), n);
  // Half leave the VO's window (retired: kept), a tenth are rejected (dropped), one moves.
  MapEvents second;
  for (size_t i = 0; i < n; i += 2) second.points_retired.push_back(first.points_added[i]);
  for (size_t i = 1; i < n; i += 10) second.points_removed.push_back(first.points_added[i].id);
  MapPointState moved = first.points_added[3];
  moved.p_world.z() += 100.0;
  second.points_updated.push_back(moved);
  map.apply(second, true);
  EXPECT_EQ(map.numPoints(), n - second.points_removed.size());

  // Points with a vertical sigma above the limit are not used; a line of points gives no plane.
  TerrainMap unusable(smallArea());
  MapEvents bad = pointsOnSurface(1.0, 0.05, 1, 4);
  for (MapPointState& p : bad.points_added) p.covariance_world(2, 2) = 9.0;  // 3 m > 2 m
  unusable.apply(bad, true);
  EXPECT_EQ(unusable.products().num_used, 0u);
  TerrainMap line(smallArea());
  MapEvents on_a_line;
  for (int i = 0; i < 200; ++i) {
    MapPointState p;
    p.id = static_cast<uint64_t>(i + 1);
    p.p_world = Eigen::Vector3d(-10.0 + 0.1 * i, 5.0, 0.0);
    p.covariance_world = 1e-4 * Eigen::Matrix3d::Identity();
    on_a_line.points_added.push_back(p);
  }
  line.apply(on_a_line, true);
  const TerrainProducts products = line.products();
  EXPECT_EQ(products.cells_known, 0);
  EXPECT_TRUE(std::isnan(at(products, "elevation_m", 0.0, 5.0)));

  // Becoming metric rescales the VO's map: the points retired in the old unit are dropped.
  map.apply(MapEvents(), false);
  EXPECT_EQ(map.numPoints(), n - second.points_removed.size() - second.points_retired.size());
  EXPECT_FALSE(map.products().metric);
  EXPECT_THROW(TerrainMap(TerrainMapConfig{LandingAreaParams(), -1.0}), std::invalid_argument);
}

// The slope and relief sigmas come from the points' actual scatter about the fitted plane, not from the
// sigmas they declare (the VO's triangulation sigmas are measured ~2.5x the scatter, docs/terrain): points on
// a plane with 0.05 m noise declared as 0.25 m must give sigmas that the fitted gradient and the elevation
// errors meet like a Gaussian's (about 68 % within 1 sigma), where the declared sigmas would put ~100 %
// within 1 sigma.
TEST(TerrainMap, SlopeAndReliefSigmasFollowTheScatterNotTheDeclaredSigmas) {
  TerrainMapConfig config = smallArea();
  config.area.half_extent_m = 30.0;
  config.support_radius_m = 2.0;
  config.point_sigma_floor_m = 0.0;
  TerrainMap map(config);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::uniform_real_distribution<double> jitter(-0.15, 0.15);
  MapEvents events;
  uint64_t id = 1;
  for (double y = -34.0; y <= 34.0; y += 0.5)
    for (double x = -34.0; x <= 34.0; x += 0.5) {
      const double px = x + jitter(rng), py = y + jitter(rng);
      // Declared sigma 0.25 m: 5x the real noise.
      events.points_added.push_back(
          groundPoint(id++, Eigen::Vector3d(px, py, kGradient * px + noise(rng)), 0.25));
    }
  map.apply(events, true);
  const TerrainProducts products = map.products();
  const GridGeometry& g = products.grids.geometry;
  const cv::Mat& elevation = products.grids.layers.at("elevation_m");
  const cv::Mat& relief_sigma = products.grids.layers.at("relief_sigma_m");
  const cv::Mat& slope_sigma = products.grids.layers.at("slope_sigma_deg");
  // Along one row, the gradient of the fitted elevations between cells 4 support radii apart (independent
  // fits) differs from the truth by sqrt(2) times one fit's intercept error over that distance; compare the
  // elevation errors directly with relief_sigma, and the slope sigma with the spread of the fits' own
  // elevation errors turned into a gradient over the support.
  int n = 0, within_1 = 0, within_2 = 0;
  double sum_slope_sigma = 0.0;
  for (int row = 8; row < g.rows - 8; row += 4)
    for (int col = 8; col < g.cols - 8; col += 4) {
      const double e = elevation.at<float>(row, col) - kGradient * g.x_m(col);
      const double s = relief_sigma.at<float>(row, col);
      ASSERT_TRUE(std::isfinite(s));
      ++n;
      within_1 += std::abs(e) <= s;
      within_2 += std::abs(e) <= 2.0 * s;
      sum_slope_sigma += slope_sigma.at<float>(row, col);
    }
  ASSERT_GT(n, 100);
  EXPECT_GT(double(within_1) / n, 0.5);
  EXPECT_LT(double(within_1) / n, 0.85) << "relief sigma not from the scatter (declared sigmas are 5x)";
  EXPECT_GT(double(within_2) / n, 0.85);
  // The gradient of a ~2 m support fit to points with 0.05 m noise is a few hundredths of a degree to a
  // degree; the declared 0.25 m would give 5x that.
  const double mean_slope_sigma = sum_slope_sigma / n;
  EXPECT_GT(mean_slope_sigma, 0.05);
  EXPECT_LT(mean_slope_sigma, 0.6);
}

// The edge of the seen ground: points only on x <= 0 of a curved surface (z = 0.1 x^2, a crater's floor).
// A cell beyond the edge would get a plane extrapolated from points on one side of it (measured: 0.18 m
// worse than the plane fit's curvature bias of 0.1 m inside, with a 2 m support); with max_support_offset
// it stays unknown, while the cells inside keep their elevation.
TEST(TerrainMap, CellsBeyondTheEdgeOfTheSeenGroundStayUnknownNotExtrapolated) {
  auto curved = [](double x) { return 0.1 * x * x; };
  MapEvents events;
  uint64_t id = 1;
  for (double y = -24.0; y <= 24.0; y += 0.25)
    for (double x = -24.0; x <= 0.0; x += 0.25) {
      events.points_added.push_back(groundPoint(id++, Eigen::Vector3d(x, y, curved(x)), 0.05));
    }
  auto worstBeyondTheEdge = [&](double max_support_offset, int* known_beyond, int* known_inside) {
    TerrainMapConfig config = smallArea();
    config.area.half_extent_m = 8.0;
    config.area.cell_size_m = 0.5;
    config.support_radius_m = 2.0;
    config.max_support_offset = max_support_offset;
    TerrainMap map(config);
    map.apply(events, true);
    const TerrainProducts products = map.products();
    const GridGeometry& g = products.grids.geometry;
    const cv::Mat& elevation = products.grids.layers.at("elevation_m");
    double worst = 0.0;
    *known_beyond = *known_inside = 0;
    for (int row = 0; row < g.rows; ++row)
      for (int col = 0; col < g.cols; ++col) {
        const float z = elevation.at<float>(row, col);
        if (!std::isfinite(z)) continue;
        const double x = g.x_m(col);
        if (x >= 1.0) ++*known_beyond;
        if (x <= -2.0) ++*known_inside;
        worst = std::max(worst, std::abs(z - curved(x)) - 0.1 * 1.0);  // minus the curvature bias inside
      }
    return worst;
  };
  int beyond = 0, inside = 0;
  const double worst_off = worstBeyondTheEdge(1.0, &beyond, &inside);
  std::printf("  without the test: %d cells known 1 m or more beyond the edge, worst excess error %.2f m\n",
              beyond, worst_off);
  EXPECT_GT(beyond, 0) << "the scene must tempt an extrapolation";
  EXPECT_GT(worst_off, 0.15);
  const double worst_on = worstBeyondTheEdge(TerrainMapConfig().max_support_offset, &beyond, &inside);
  std::printf("  with the default test: %d cells known beyond, %d inside, worst excess error %.2f m\n",
              beyond, inside, worst_on);
  EXPECT_EQ(beyond, 0);
  EXPECT_EQ(inside, 33 * 13);  // every cell with x <= -2 m (13 columns of 33 rows)
  EXPECT_LT(worst_on, 0.05);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
