// The true terrain grids of the landing area that every rendered dataset carries: they are the rendered
// LunarTerrain (elevation at the cell centres, slope and roughness of a plane fitted to it over the
// footprint, checked here by an independent fit), their metadata says how they were made, and cached renders
// get them without re-rendering the images.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "planetary_vo/render/sequence_renderer.h"
#include "planetary_vo/render/terrain_truth.h"
#include "planetary_vo/terrain/grid.h"
#include "test_support.h"

using namespace planetary_vo;
using namespace planetary_vo::render;
namespace fs = std::filesystem;

namespace {

SequenceOptions tinyClip(const std::string& dir) {
  SequenceOptions o;
  o.sequence = "approach_down";
  o.output_dir = dir;
  o.dem_yaml = test::dataPath("lunar_dem/apollo15_gld100.yaml");
  o.width = o.height = 64;
  o.duration_s = 0.2;
  o.sensors = sensors::sensorPreset("ideal");
  return o;
}

const char* const kTerrainFiles[] = {"groundtruth_terrain.yaml", "groundtruth_terrain_elevation_m.tiff",
                                     "groundtruth_terrain_slope_deg.tiff",
                                     "groundtruth_terrain_roughness_m.tiff"};

}  // namespace

TEST(TerrainTruth, RenderedDatasetCarriesTheTrueTerrainOfTheLandingArea) {
  const SequenceOptions o = tinyClip(test::outputDir("render_terrain_truth"));
  ASSERT_TRUE(test::requireDataFile(o.dem_yaml));
  renderSequence(o);
  for (const char* f : kTerrainFiles) EXPECT_TRUE(fs::exists(o.output_dir + "/" + f)) << f;

  const terrain::GridSet grids = terrain::readGridSet(o.output_dir, kGroundTruthTerrainName);
  const terrain::LandingAreaParams area;  // the defaults
  const terrain::GridGeometry& g = grids.geometry;
  EXPECT_EQ(g, area.geometry());
  EXPECT_EQ(grids.parameters.at("half_extent_m"), area.half_extent_m);
  EXPECT_EQ(grids.parameters.at("cell_size_m"), area.cell_size_m);
  EXPECT_EQ(grids.parameters.at("footprint_diameter_m"), area.footprint_diameter_m);
  const double lod = grids.parameters.at("lod_m");
  EXPECT_EQ(lod, area.cell_size_m);
  ASSERT_EQ(grids.layers.size(), 3u);
  const cv::Mat& elevation = grids.layers.at("elevation_m");
  const cv::Mat& slope = grids.layers.at("slope_deg");
  const cv::Mat& roughness = grids.layers.at("roughness_m");

  // The terrain the images were rendered from.
  const SequenceSetup setup = prepareSequence(o);
  const LunarTerrain& lunar = *setup.terrain;
  EXPECT_EQ(cv::countNonZero(elevation != elevation), 0) << "the elevation is known everywhere";
  // Cells across the whole area, off the diagonal so that swapped axes show.
  const int probes[][2] = {{256, 256}, {0, 0},    {512, 512}, {10, 400},
                           {400, 10},  {37, 211}, {498, 123}, {300, 77}};
  for (const auto& p : probes) {
    const int col = p[0], row = p[1];
    EXPECT_FLOAT_EQ(elevation.at<float>(row, col),
                    static_cast<float>(lunar.height(g.x_m(col), g.y_m(row), lod)))
        << "cell " << col << "," << row << " at x " << g.x_m(col) << " y " << g.y_m(row);
  }
  // The landing site is cell (256, 256); z = 0 is the DEM there, the procedural relief adds to it.
  EXPECT_LT(std::abs(elevation.at<float>(256, 256) - lunar.demHeight(0.0, 0.0)),
            lunar.maxProceduralReliefM());

  // Slope and roughness: a plane fitted to LunarTerrain::height over the 4 m disc, solved in full.
  const double r = 0.5 * area.footprint_diameter_m;
  const int R = static_cast<int>(std::floor(r / g.cell_size_m + 1e-9));
  int checked = 0;
  for (const auto& p : probes) {
    const int col = p[0], row = p[1];
    if (col < R || row < R || col + R >= g.cols || row + R >= g.rows) {
      EXPECT_TRUE(std::isnan(slope.at<float>(row, col)))
          << "footprint leaves the area at " << col << "," << row;
      EXPECT_TRUE(std::isnan(roughness.at<float>(row, col)));
      continue;
    }
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> samples;
    for (int dj = -R; dj <= R; ++dj)
      for (int di = -R; di <= R; ++di) {
        if ((di * di + dj * dj) * g.cell_size_m * g.cell_size_m > r * r + 1e-9) continue;
        const double x = g.x_m(col + di), y = g.y_m(row + dj);
        const double z = static_cast<float>(lunar.height(x, y, lod));  // stored as float
        const Eigen::Vector3d a(1.0, x - g.x_m(col), y - g.y_m(row));
        A += a * a.transpose();
        b += a * z;
        samples.emplace_back(a.y(), a.z(), z);
      }
    const Eigen::Vector3d plane = A.ldlt().solve(b);
    double worst = 0.0;
    for (const Eigen::Vector3d& s : samples)
      worst = std::max(worst, std::abs(s.z() - (plane(0) + plane(1) * s.x() + plane(2) * s.y())));
    EXPECT_NEAR(slope.at<float>(row, col), std::atan(std::hypot(plane(1), plane(2))) * 180.0 / M_PI, 1e-3)
        << "cell " << col << "," << row;
    EXPECT_NEAR(roughness.at<float>(row, col), worst, 1e-4) << "cell " << col << "," << row;
    ++checked;
  }
  EXPECT_EQ(checked, 6);
  // Only the 4-cell border (the footprint radius) is unknown.
  EXPECT_EQ(cv::countNonZero(slope == slope), (g.cols - 2 * R) * (g.rows - 2 * R));
  EXPECT_EQ(cv::countNonZero(roughness == roughness), (g.cols - 2 * R) * (g.rows - 2 * R));
}

TEST(TerrainTruth, CachedImagesGetTheTerrainGridsWithoutARerender) {
  SequenceOptions o = tinyClip(test::outputDir("render_terrain_truth_cache"));
  ASSERT_TRUE(test::requireDataFile(o.dem_yaml));
  const SequenceResult first = renderSequence(o);
  ASSERT_FALSE(first.skipped);
  const auto image_time = fs::last_write_time(o.output_dir + "/images/000000.png");
  // A render of an older streams version: valid images, no terrain grids.
  for (const char* f : kTerrainFiles) fs::remove(o.output_dir + "/" + f);
  std::ofstream(o.output_dir + "/render_stamp.txt")
      << "param_hash: " << first.param_hash << "\nframes: " << first.frames
      << "\ncomplete: true\nstreams_hash: older\n";
  const SequenceResult second = renderSequence(o);
  EXPECT_TRUE(second.images_reused);
  EXPECT_EQ(fs::last_write_time(o.output_dir + "/images/000000.png"), image_time) << "images re-rendered";
  for (const char* f : kTerrainFiles) EXPECT_TRUE(fs::exists(o.output_dir + "/" + f)) << f;
  EXPECT_TRUE(renderSequence(o).skipped);

  // Another landing area changes the streams only: the grids are rewritten with the new geometry.
  o.landing_area.half_extent_m = 40.0;
  o.landing_area.cell_size_m = 1.0;
  o.landing_area.footprint_diameter_m = 6.0;
  const SequenceResult third = renderSequence(o);
  EXPECT_TRUE(third.images_reused);
  EXPECT_EQ(third.param_hash, first.param_hash);
  EXPECT_NE(third.streams_hash, first.streams_hash);
  const terrain::GridSet grids = terrain::readGridSet(o.output_dir, kGroundTruthTerrainName);
  EXPECT_EQ(grids.geometry.cols, 81);
  EXPECT_EQ(grids.geometry.cell_size_m, 1.0);
  EXPECT_EQ(grids.parameters.at("footprint_diameter_m"), 6.0);
  EXPECT_EQ(grids.parameters.at("lod_m"), 1.0);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
