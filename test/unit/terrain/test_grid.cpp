// The landing-area raster: its geometry and the round trip of a grid set through its files (bit for bit).
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "planetary_vo/terrain/grid.h"
#include "planetary_vo/terrain/landing_area.h"
#include "test_support.h"

using namespace planetary_vo;
using namespace planetary_vo::terrain;
namespace fs = std::filesystem;

TEST(TerrainGrid, CenteredGeometryPutsTheLandingSiteOnACellCentre) {
  const GridGeometry g = GridGeometry::centeredOnOrigin(128.0, 0.5);
  EXPECT_EQ(g.cols, 513);
  EXPECT_EQ(g.rows, 513);
  EXPECT_EQ(g.x0_m, -128.0);
  EXPECT_EQ(g.y0_m, -128.0);
  EXPECT_EQ(g.x_m(256), 0.0);
  EXPECT_EQ(g.y_m(512), 128.0);
  int col = -1, row = -1;
  ASSERT_TRUE(g.cellAt(0.0, 0.0, &col, &row));
  EXPECT_EQ(col, 256);
  EXPECT_EQ(row, 256);
  // Columns along +x, rows along +y; a cell spans its centre +- half a cell.
  ASSERT_TRUE(g.cellAt(0.24, -0.26, &col, &row));
  EXPECT_EQ(col, 256);
  EXPECT_EQ(row, 255);
  ASSERT_TRUE(g.cellAt(-128.24, 128.24, &col, &row));
  EXPECT_EQ(col, 0);
  EXPECT_EQ(row, 512);
  EXPECT_FALSE(g.cellAt(-128.26, 0.0, &col, &row));
  EXPECT_FALSE(g.cellAt(0.0, 128.26, &col, &row));
  EXPECT_FALSE(g.cellAt(std::nan(""), 0.0, &col, &row));
  EXPECT_TRUE(g.contains(512, 0));
  EXPECT_FALSE(g.contains(513, 0));
  EXPECT_EQ(LandingAreaParams{}.geometry(), g) << "the documented default landing area";
  EXPECT_THROW(GridGeometry::centeredOnOrigin(0.2, 0.5), std::invalid_argument);
  EXPECT_THROW(GridGeometry::centeredOnOrigin(10.0, 0.0), std::invalid_argument);
  const cv::Mat layer = g.newLayer();
  EXPECT_EQ(layer.type(), CV_32FC1);
  EXPECT_EQ(layer.size(), cv::Size(513, 513));
  EXPECT_TRUE(std::isnan(layer.at<float>(3, 4)));
}

TEST(TerrainGrid, RoundTripThroughFilesIsExact) {
  const std::string dir = test::outputDir("terrain_grid_round_trip");
  GridSet out;
  out.geometry.x0_m = -12.345678901234567;
  out.geometry.y0_m = 0.1 + 0.2;  // not a short decimal
  out.geometry.cell_size_m = 1.0 / 3.0;
  out.geometry.cols = 37;
  out.geometry.rows = 23;
  out.description = "test: random layers, with NaN, infinities and denormals";
  out.parameters = {{"footprint_diameter_m", 4.0}, {"lod_m", 1.0 / 7.0}};
  std::mt19937 rng(7);
  std::normal_distribution<float> normal(0.0f, 300.0f);
  for (const char* name : {"elevation_m", "slope_deg", "roughness_m"}) {
    cv::Mat m = out.geometry.newLayer();
    for (int r = 0; r < m.rows; ++r)
      for (int c = 0; c < m.cols; ++c) m.at<float>(r, c) = normal(rng) * std::pow(10.0f, float(r % 7 - 3));
    m.at<float>(1, 2) = std::numeric_limits<float>::quiet_NaN();
    m.at<float>(3, 4) = std::numeric_limits<float>::infinity();
    m.at<float>(5, 6) = std::numeric_limits<float>::denorm_min();
    m.at<float>(7, 8) = -0.0f;
    out.layers[name] = m;
  }
  writeGridSet(dir, "groundtruth_terrain", out);
  for (const char* f : {"groundtruth_terrain.yaml", "groundtruth_terrain_elevation_m.tiff",
                        "groundtruth_terrain_slope_deg.tiff", "groundtruth_terrain_roughness_m.tiff"})
    EXPECT_TRUE(fs::exists(dir + "/" + f)) << f;

  const GridSet in = readGridSet(dir, "groundtruth_terrain");
  EXPECT_EQ(in.geometry, out.geometry);
  EXPECT_EQ(in.description, out.description);
  EXPECT_EQ(in.parameters, out.parameters);
  ASSERT_EQ(in.layers.size(), out.layers.size());
  for (const auto& [name, m] : out.layers) {
    ASSERT_TRUE(in.layers.count(name)) << name;
    const cv::Mat& back = in.layers.at(name);
    ASSERT_EQ(back.type(), CV_32FC1) << name;
    ASSERT_EQ(back.size(), m.size()) << name;
    for (int r = 0; r < m.rows; ++r)
      EXPECT_EQ(std::memcmp(back.ptr(r), m.ptr(r), m.cols * sizeof(float)), 0) << name << " row " << r;
  }
}

TEST(TerrainGrid, BadLayersAndFilesAreRejectedWithTheFileName) {
  const std::string dir = test::outputDir("terrain_grid_errors");
  GridSet g;
  g.geometry = GridGeometry::centeredOnOrigin(2.0, 0.5);
  g.layers["elevation_m"] = cv::Mat(3, 3, CV_32FC1, cv::Scalar(0.0f));  // not 9 x 9
  EXPECT_THROW(writeGridSet(dir, "grids", g), GridFileError);
  g.layers["elevation_m"] = g.geometry.newLayer(0.0f);
  g.layers["slope deg"] = g.geometry.newLayer(0.0f);  // not a file name
  EXPECT_THROW(writeGridSet(dir, "grids", g), GridFileError);
  g.layers.erase("slope deg");
  EXPECT_THROW(writeGridSet(dir, "../grids", g), GridFileError);
  g.layers["slope_deg"] = cv::Mat(9, 9, CV_64FC1, cv::Scalar(0.0));  // not float
  EXPECT_THROW(writeGridSet(dir, "grids", g), GridFileError);
  g.layers.erase("slope_deg");
  writeGridSet(dir, "grids", g);
  EXPECT_NO_THROW(readGridSet(dir, "grids"));

  fs::remove(dir + "/grids_elevation_m.tiff");
  try {
    readGridSet(dir, "grids");
    ADD_FAILURE() << "a missing layer file must throw";
  } catch (const GridFileError& e) {
    EXPECT_NE(std::string(e.what()).find("grids_elevation_m.tiff"), std::string::npos) << e.what();
  }
  EXPECT_THROW(readGridSet(dir, "absent"), GridFileError);
  std::ofstream(dir + "/other.yaml") << "format: something else\n";
  EXPECT_THROW(readGridSet(dir, "other"), GridFileError);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
