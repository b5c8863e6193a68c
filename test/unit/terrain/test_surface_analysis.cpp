// Slope and roughness over a lander footprint on analytic surfaces (exact answers), against an independent
// brute-force plane fit on a rough surface, and the unknown / border / footprint-size cases.
#include <cmath>
#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "planetary_vo/terrain/surface_analysis.h"

using namespace planetary_vo::terrain;

namespace {

constexpr double kRad2Deg = 180.0 / M_PI;

GridGeometry makeGeometry(int cols, int rows, double cell) {
  GridGeometry g;
  g.x0_m = -7.25;
  g.y0_m = 3.5;
  g.cell_size_m = cell;
  g.cols = cols;
  g.rows = rows;
  return g;
}

template <class F>
cv::Mat fill(const GridGeometry& g, F z) {
  cv::Mat m = g.newLayer();
  for (int row = 0; row < g.rows; ++row)
    for (int col = 0; col < g.cols; ++col)
      m.at<float>(row, col) = static_cast<float>(z(g.x_m(col), g.y_m(row)));
  return m;
}

/// Radius of the footprint in whole cells (the disc's extent).
int radiusCells(double cell, double diameter) {
  return static_cast<int>(std::floor(0.5 * diameter / cell + 1e-9));
}

}  // namespace

TEST(SurfaceAnalysis, FootprintDiscSizes) {
  EXPECT_EQ(footprintOffsets(0.5, 4.0).size(), 49u);   // radius 4 cells
  EXPECT_EQ(footprintOffsets(1.0, 2.0).size(), 5u);    // radius 1: the centre and its 4 neighbours
  EXPECT_EQ(footprintOffsets(0.5, 3.0).size(), 29u);   // radius 3
  EXPECT_EQ(footprintOffsets(1.0, 10.0).size(), 81u);  // radius 5: (3, 4) lies on the circle and is in
  EXPECT_EQ(footprintOffsets(1.0, 9.98).size(), 69u);  // just inside 5: (3, 4), (5, 0) and their images out
  EXPECT_THROW(footprintOffsets(0.5, 0.99), std::invalid_argument);  // under two cells: no plane
  EXPECT_THROW(footprintOffsets(0.0, 4.0), std::invalid_argument);
  for (const cv::Point& o : footprintOffsets(0.5, 4.0)) EXPECT_LE(o.x * o.x + o.y * o.y, 16);
}

TEST(SurfaceAnalysis, TiltedPlaneGivesItsSlopeAndNoRoughness) {
  const GridGeometry g = makeGeometry(41, 33, 0.5);
  const double footprint = 4.0;
  const int R = radiusCells(g.cell_size_m, footprint);
  struct Case {
    double gx, gy;
  };
  // Along x only, along y only, both, steep: each axis must be weighted by its own offsets.
  for (const Case c : {Case{0.2, 0.0}, Case{0.0, -0.15}, Case{0.1, 0.25}, Case{1.5, -0.8}}) {
    const cv::Mat z = fill(g, [&](double x, double y) { return 12.0 + c.gx * x + c.gy * y; });
    const SurfaceMaps s = analyzeSurface(g, z, footprint);
    const double expected_deg = std::atan(std::hypot(c.gx, c.gy)) * kRad2Deg;
    int known = 0;
    for (int row = 0; row < g.rows; ++row)
      for (int col = 0; col < g.cols; ++col) {
        const bool inside = col >= R && row >= R && col + R < g.cols && row + R < g.rows;
        const float slope = s.slope_deg.at<float>(row, col), rough = s.roughness_m.at<float>(row, col);
        if (!inside) {
          EXPECT_TRUE(std::isnan(slope) && std::isnan(rough))
              << "footprint leaves the grid at " << col << "," << row;
          continue;
        }
        ++known;
        EXPECT_NEAR(slope, expected_deg, 1e-4) << "gx " << c.gx << " gy " << c.gy;
        EXPECT_NEAR(rough, 0.0, 1e-5);  // the float storage of z is all that departs from the plane
      }
    EXPECT_EQ(known, (g.cols - 2 * R) * (g.rows - 2 * R));
  }
}

TEST(SurfaceAnalysis, SpikeOnAPlaneGivesItsHeightLessThePlanesShare) {
  const GridGeometry g = makeGeometry(31, 31, 0.5);
  const double footprint = 4.0, h = 0.4;
  const std::vector<cv::Point> disc = footprintOffsets(g.cell_size_m, footprint);
  const double n = disc.size();
  double sum_dx2 = 0.0;
  for (const cv::Point& o : disc) sum_dx2 += o.x * o.x;
  cv::Mat z = fill(g, [](double x, double y) { return -3.0 + 0.05 * x + 0.08 * y; });
  const int sc = 15, sr = 15;  // the spike
  z.at<float>(sr, sc) += static_cast<float>(h);
  const SurfaceMaps s = analyzeSurface(g, z, footprint);
  const double plane_deg = std::atan(std::hypot(0.05, 0.08)) * kRad2Deg;

  // Centred on the spike: the plane rises by h / N and does not tilt.
  EXPECT_NEAR(s.roughness_m.at<float>(sr, sc), h * (1.0 - 1.0 / n), 1e-5);
  EXPECT_NEAR(s.slope_deg.at<float>(sr, sc), plane_deg, 1e-4);
  // Off centre by (dx, dy) cells: the plane also tilts toward the spike by h dx / sum(dx^2) per cell.
  for (const cv::Point& o : disc) {
    const double d2 = o.x * o.x + o.y * o.y;
    EXPECT_NEAR(s.roughness_m.at<float>(sr - o.y, sc - o.x), h * (1.0 - 1.0 / n - d2 / sum_dx2), 1e-5)
        << "spike at offset " << o.x << "," << o.y;
  }
  // Footprints that do not reach the spike see the bare plane.
  EXPECT_NEAR(s.roughness_m.at<float>(sr, sc + 5), 0.0, 1e-5);
  EXPECT_NEAR(s.slope_deg.at<float>(sr + 5, sc), plane_deg, 1e-4);

  // A footprint much larger than the spike: roughness -> its height.
  const GridGeometry wide = makeGeometry(81, 81, 0.5);
  cv::Mat zw = fill(wide, [](double x, double y) { return 0.3 * x; });
  zw.at<float>(40, 40) += static_cast<float>(h);
  const double n_wide = footprintOffsets(0.5, 36.0).size();
  EXPECT_NEAR(analyzeSurface(wide, zw, 36.0).roughness_m.at<float>(40, 40), h * (1.0 - 1.0 / n_wide), 1e-4);
  EXPECT_GT(analyzeSurface(wide, zw, 36.0).roughness_m.at<float>(40, 40), 0.999 * h);
}

TEST(SurfaceAnalysis, StepIsRoughAndTiltsTheFootprintsOverIt) {
  // A 0.5 m step along x = 0 (a scarp): footprints that straddle it see a tilted plane and large residuals,
  // footprints entirely on either side see the flat plane.
  const GridGeometry g = makeGeometry(41, 21, 0.5);
  const double step = 0.5;
  const cv::Mat z = fill(g, [&](double x, double) { return x > 0.1 ? step : 0.0; });
  const SurfaceMaps s = analyzeSurface(g, z, 4.0);
  int col0 = 0;
  int row = 10;
  ASSERT_TRUE(g.cellAt(0.0, g.y_m(row), &col0, &row));
  EXPECT_GT(s.roughness_m.at<float>(row, col0), 0.5 * step * 0.8);
  EXPECT_LT(s.roughness_m.at<float>(row, col0), step);
  EXPECT_GT(s.slope_deg.at<float>(row, col0), 5.0);
  EXPECT_NEAR(s.roughness_m.at<float>(row, col0 - 9), 0.0, 1e-6);
  EXPECT_NEAR(s.roughness_m.at<float>(row, col0 + 9), 0.0, 1e-6);
  EXPECT_NEAR(s.slope_deg.at<float>(row, col0 + 9), 0.0, 1e-6);
}

TEST(SurfaceAnalysis, MatchesABruteForcePlaneFitOnARoughSurface) {
  // An independent fit: the full 3x3 normal equations over the disc's samples, world coordinates, no use of
  // the disc's symmetry or of prefix sums.
  const GridGeometry g = makeGeometry(37, 29, 0.4);
  const double footprint = 3.3;
  const cv::Mat z = fill(g, [](double x, double y) {
    return 40.0 + 0.3 * x - 0.2 * y + 0.7 * std::sin(1.3 * x) * std::cos(0.9 * y) +
           0.2 * std::sin(5.1 * x * y);
  });
  const SurfaceMaps s = analyzeSurface(g, z, footprint);
  const double r = 0.5 * footprint;
  int compared = 0;
  for (int row = 0; row < g.rows; ++row)
    for (int col = 0; col < g.cols; ++col) {
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      std::vector<Eigen::Vector3d> samples;
      bool covered = true;
      for (int j = 0; j < g.rows; ++j)
        for (int i = 0; i < g.cols; ++i) {
          const double dx = g.x_m(i) - g.x_m(col), dy = g.y_m(j) - g.y_m(row);
          if (dx * dx + dy * dy > r * r * (1 + 1e-12)) continue;
          const Eigen::Vector3d a(1.0, g.x_m(i), g.y_m(j));
          A += a * a.transpose();
          b += a * z.at<float>(j, i);
          samples.emplace_back(g.x_m(i), g.y_m(j), z.at<float>(j, i));
        }
      // Covered when the whole disc is in the grid: compare the sample count with the full disc's.
      covered = samples.size() == footprintOffsets(g.cell_size_m, footprint).size();
      if (!covered) {
        EXPECT_TRUE(std::isnan(s.slope_deg.at<float>(row, col)));
        continue;
      }
      const Eigen::Vector3d p = A.ldlt().solve(b);
      double worst = 0.0;
      for (const Eigen::Vector3d& q : samples)
        worst = std::max(worst, std::abs(q.z() - (p(0) + p(1) * q.x() + p(2) * q.y())));
      EXPECT_NEAR(s.slope_deg.at<float>(row, col), std::atan(std::hypot(p(1), p(2))) * kRad2Deg, 1e-3);
      EXPECT_NEAR(s.roughness_m.at<float>(row, col), worst, 1e-5);
      ++compared;
    }
  EXPECT_GT(compared, 300);
}

TEST(SurfaceAnalysis, UnknownElevationBlanksEveryFootprintThatTouchesIt) {
  const GridGeometry g = makeGeometry(30, 30, 0.5);
  const double footprint = 4.0;
  const int R = radiusCells(g.cell_size_m, footprint);
  cv::Mat z = fill(g, [](double x, double y) { return 0.1 * x; });
  const int hc = 14, hr = 16;
  z.at<float>(hr, hc) = std::numeric_limits<float>::quiet_NaN();
  z.at<float>(5, 25) = std::numeric_limits<float>::infinity();  // not a number either
  const SurfaceMaps s = analyzeSurface(g, z, footprint);
  for (int row = R; row + R < g.rows; ++row)
    for (int col = R; col + R < g.cols; ++col) {
      const bool touches = (col - hc) * (col - hc) + (row - hr) * (row - hr) <= R * R ||
                           (col - 25) * (col - 25) + (row - 5) * (row - 5) <= R * R;
      EXPECT_EQ(std::isnan(s.slope_deg.at<float>(row, col)), touches) << col << "," << row;
      EXPECT_EQ(std::isnan(s.roughness_m.at<float>(row, col)), touches) << col << "," << row;
      if (!touches) {
        EXPECT_NEAR(s.roughness_m.at<float>(row, col), 0.0, 1e-5);
      }
    }
}

TEST(SurfaceAnalysis, GridSmallerThanTheFootprintIsAllUnknown) {
  const GridGeometry g = makeGeometry(8, 12, 0.5);  // 4 m footprint needs 9 cells across
  const SurfaceMaps s = analyzeSurface(g, g.newLayer(1.0f), 4.0);
  EXPECT_EQ(cv::countNonZero(s.slope_deg == s.slope_deg), 0);  // NaN != NaN everywhere
  EXPECT_EQ(s.slope_deg.size(), cv::Size(8, 12));
  EXPECT_THROW(analyzeSurface(g, cv::Mat(12, 8, CV_64FC1, cv::Scalar(0.0)), 4.0), std::invalid_argument);
  EXPECT_THROW(analyzeSurface(g, cv::Mat(8, 12, CV_32FC1, cv::Scalar(0.0)), 4.0), std::invalid_argument);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
