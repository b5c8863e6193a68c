// The track_truth tool (src/tools/vo/track_truth.cpp) on a small render with its depth: it reports the
// tracks' distance to the true projection of their point by age, the error grows when the ground-truth poses
// it projects with are wrong (so it measures the tracks against the truth, not against themselves), and a
// render without depth is refused with a message that says how to make one. It lives with the render tests
// because it needs the renderer (the vo tests are built with the sanitizer, which builds no renderer).

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/render/sequence_renderer.h"
#include "planetary_vo/sensors/sensor_suite.h"
#include "test_support.h"

using namespace planetary_vo;
using namespace planetary_vo::render;
namespace fs = std::filesystem;

namespace {

using test::executableDir;
using test::readText;

int runTrackTruth(const std::string& args, const std::string& log) {
  return test::runTool("track_truth", args, log);
}

/// The median error (px) and the sample count of the age bin `label` ("1-1", "2-5", ...) in a report.
bool binRow(const std::string& report, const std::string& label, double* median_px, long* samples) {
  std::istringstream in(report);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    std::string first;
    row >> first;
    if (first != label) continue;
    return static_cast<bool>(row >> *samples >> *median_px);
  }
  return false;
}

}  // namespace

TEST(TrackTruthTool, TracksAreScoredAgainstTheTrueProjectionOfTheirPoint) {
  ASSERT_TRUE(test::requireDataFile(executableDir() + "/track_truth"))
      << "build the track_truth target first";
  SequenceOptions o;
  o.sequence = "approach_down";
  o.output_dir = test::outputDir("track_truth_tool") + "/render";
  o.dem_yaml = test::dataPath("lunar_dem/apollo15_gld100.yaml");
  ASSERT_TRUE(test::requireDataFile(o.dem_yaml));
  o.width = 256;
  o.height = 256;
  o.duration_s = 2.0;  // 21 images
  o.sensors = sensors::sensorPreset("ideal");
  o.save_depth = true;
  renderSequence(o);
  const std::string dir = fs::path(o.output_dir).parent_path().string();

  ASSERT_EQ(runTrackTruth("--dataset " + o.output_dir + " --csv " + dir + "/samples.csv", dir + "/clean.txt"),
            0)
      << readText(dir + "/clean.txt");
  const std::string clean = readText(dir + "/clean.txt");
  double clean_1 = 0.0, clean_6 = 0.0;
  long n_1 = 0, n_6 = 0;
  ASSERT_TRUE(binRow(clean, "1-1", &clean_1, &n_1)) << clean;
  ASSERT_TRUE(binRow(clean, "6-20", &clean_6, &n_6)) << clean;
  EXPECT_GT(n_1, 100) << clean;
  EXPECT_GT(n_6, 1000) << clean;
  // Ideal images: a tracked corner is within a few tenths of a pixel of its point's projection.
  EXPECT_LT(clean_1, 0.3) << clean;
  EXPECT_LT(clean_6, 0.4) << clean;
  EXPECT_GT(readText(dir + "/samples.csv").size(), 1000u);

  // The same images, with a ground truth whose attitude turns by 0.02 deg per image about the camera's x axis
  // (0.08 px per image at this focal length): the error must grow with age by about that much.
  const std::string bent = dir + "/bent";
  fs::copy(o.output_dir, bent, fs::copy_options::recursive);
  Trajectory truth = readTrajectory(o.output_dir + "/groundtruth.txt");
  for (size_t i = 0; i < truth.size(); ++i)
    truth[i].T_world_cam.linear() =
        truth[i].T_world_cam.linear() *
        Eigen::AngleAxisd(0.02 * M_PI / 180.0 * static_cast<double>(i), Eigen::Vector3d::UnitX())
            .toRotationMatrix();
  writeTumTrajectory(bent + "/groundtruth.txt", truth);
  ASSERT_EQ(runTrackTruth("--dataset " + bent, dir + "/bent.txt"), 0) << readText(dir + "/bent.txt");
  double bent_6 = 0.0;
  long n_bent = 0;
  ASSERT_TRUE(binRow(readText(dir + "/bent.txt"), "6-20", &bent_6, &n_bent));
  EXPECT_GT(bent_6, clean_6 + 0.4) << readText(dir + "/bent.txt");

  // Without the depth images the tool cannot place the points: a clear error, exit 1.
  fs::remove_all(bent + "/depth");
  EXPECT_EQ(runTrackTruth("--dataset " + bent, dir + "/no_depth.txt"), 1);
  EXPECT_NE(readText(dir + "/no_depth.txt").find("--depth"), std::string::npos)
      << readText(dir + "/no_depth.txt");
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
