// Sequences through the sensor models: the ideal preset reproduces renderer 1.2 bit for bit, cached images
// survive a change of the IMU/altimeter streams, the flight preset writes 16-bit images through a distorted
// lens and keeps everything derived from ground truth in ground-truth files.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/render/sequence_renderer.h"
#include "planetary_vo/sensors/sensor_suite.h"
#include "test_support.h"

using namespace planetary_vo;
using namespace planetary_vo::render;
namespace fs = std::filesystem;

namespace {

constexpr uint64_t kFnvOffset = 1469598103934665603ULL;
constexpr uint64_t kFnvPrime = 1099511628211ULL;

uint64_t fnv1a(const unsigned char* data, size_t n, uint64_t h = kFnvOffset) {
  for (size_t i = 0; i < n; ++i) {
    h ^= data[i];
    h *= kFnvPrime;
  }
  return h;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

uint64_t fileHash(const std::string& path) {
  const std::string s = readFile(path);
  return fnv1a(reinterpret_cast<const unsigned char*>(s.data()), s.size());
}

std::string hex(uint64_t h) {
  std::ostringstream os;
  os << std::hex;
  os.width(16);
  os.fill('0');
  os << h;
  return os.str();
}

// The reference sequence of renderer 1.2 (before the sensor models): approach_30deg, 128x96, 0.5 s, seed 1,
// default Sun, Apollo 15 DEM. The hashes below were taken from that version's lunar_render output.
SequenceOptions referenceOptions(const std::string& dir) {
  SequenceOptions o;
  o.sequence = "approach_30deg";
  o.output_dir = dir;
  o.dem_yaml = test::dataPath("lunar_dem/apollo15_gld100.yaml");
  o.width = 128;
  o.height = 96;
  o.duration_s = 0.5;
  o.sensors = sensors::sensorPreset("ideal");
  return o;
}

}  // namespace

TEST(SensorRender, IdealPresetReproducesRenderer12BitForBit) {
  const SequenceOptions o = referenceOptions(test::outputDir("render_ideal_reference"));
  ASSERT_TRUE(test::requireDataFile(o.dem_yaml));
  const SequenceResult r = renderSequence(o);
  EXPECT_EQ(r.param_hash, "65d79ef837bde06c");  // the 1.2 cache stamp: old ideal renders stay valid
  const Dataset ds = Dataset::open(o.output_dir);
  ASSERT_EQ(ds.size(), 6u);
  uint64_t h = kFnvOffset;
  for (size_t i = 0; i < ds.size(); ++i) {
    const cv::Mat im = ds.loadImageUnchanged(i);
    ASSERT_EQ(im.type(), CV_8UC1) << "the ideal camera writes 8-bit images";
    ASSERT_TRUE(im.isContinuous());
    h = fnv1a(im.data, im.total(), h);
  }
  EXPECT_EQ(hex(h), "f04b33d75fdf3e10") << "ideal pixels differ from renderer 1.2";
  EXPECT_EQ(hex(fileHash(o.output_dir + "/groundtruth.txt")), "6d51807d721cde18");
  EXPECT_EQ(hex(fileHash(o.output_dir + "/imu.txt")), "2663dee08289ba7b") << "ideal IMU differs from 1.2";
  EXPECT_FALSE(fs::exists(o.output_dir + "/groundtruth_camera.yaml"));  // the camera is what camera.yaml says
  EXPECT_TRUE(ds.camera().distortion().empty() || ds.camera().distortionModel() == "none");
}

TEST(SensorRender, OldStampKeepsImagesAndRewritesStreams) {
  SequenceOptions o = referenceOptions(test::outputDir("render_old_stamp"));
  o.duration_s = 0.2;
  ASSERT_TRUE(test::requireDataFile(o.dem_yaml));
  const SequenceResult first = renderSequence(o);
  ASSERT_FALSE(first.skipped);
  const std::string image0 = readFile(o.output_dir + "/images/000000.png");
  ASSERT_FALSE(image0.empty());
  const auto mtime = fs::last_write_time(o.output_dir + "/images/000000.png");
  // A 1.2 stamp has no streams_hash line: the images are valid, the streams are of the old format.
  std::ofstream(o.output_dir + "/render_stamp.txt")
      << "param_hash: " << first.param_hash << "\nframes: " << first.frames << "\ncomplete: true\n";
  std::ofstream(o.output_dir + "/altimeter.txt") << "# timestamp altitude_m range_m\n0 100 101\n";
  const SequenceResult second = renderSequence(o);
  EXPECT_FALSE(second.skipped);
  EXPECT_TRUE(second.images_reused);
  EXPECT_EQ(readFile(o.output_dir + "/images/000000.png"), image0);
  EXPECT_EQ(fs::last_write_time(o.output_dir + "/images/000000.png"), mtime) << "cached image rewritten";
  EXPECT_EQ(Dataset::open(o.output_dir).altimeter().size(), 5u);  // 20 Hz over 0.2 s, rewritten
  EXPECT_TRUE(renderSequence(o).skipped);
  // Another IMU grade changes only the streams; the images stay.
  const std::string ideal_imu = readFile(o.output_dir + "/imu.txt");
  o.sensors.imu = sensors::imuGrade("mems");
  const SequenceResult third = renderSequence(o);
  EXPECT_TRUE(third.images_reused);
  EXPECT_EQ(third.param_hash, first.param_hash);
  EXPECT_NE(third.streams_hash, first.streams_hash);
  EXPECT_NE(readFile(o.output_dir + "/imu.txt"), ideal_imu);
  EXPECT_EQ(readFile(o.output_dir + "/images/000000.png"), image0);
}

TEST(SensorRender, FlightPresetWritesMeasuredStreamsAndSeparatesGroundTruth) {
  SequenceOptions o;
  o.sequence = "approach_down";
  o.output_dir = test::outputDir("render_flight");
  o.dem_yaml = test::dataPath("lunar_dem/apollo15_gld100.yaml");
  ASSERT_TRUE(test::requireDataFile(o.dem_yaml));
  o.width = 128;
  o.height = 128;
  o.duration_s = 0.3;
  ASSERT_TRUE(o.sensors.camera.enabled) << "flight is the default preset";
  const SequenceResult r = renderSequence(o);
  ASSERT_FALSE(r.skipped);
  const Dataset ds = Dataset::open(o.output_dir);
  ASSERT_EQ(ds.size(), 4u);

  // 16-bit images holding 12-bit samples in the most significant bits, over the black level.
  const cv::Mat im = ds.loadImageUnchanged(1);
  ASSERT_EQ(im.type(), CV_16UC1);
  const int shift_mult = 1 << (16 - o.sensors.camera.bit_depth);
  int not_aligned = 0;
  double lo = 1e9, hi = 0;
  for (int y = 0; y < im.rows; ++y)
    for (int x = 0; x < im.cols; ++x) {
      const int v = im.at<uint16_t>(y, x);
      not_aligned += v % shift_mult != 0;
      lo = std::min<double>(lo, v);
      hi = std::max<double>(hi, v);
    }
  EXPECT_EQ(not_aligned, 0);
  EXPECT_GT(hi, lo + 1000) << "an exposed scene has contrast";
  EXPECT_EQ(ds.loadImage(1).type(), CV_8UC1);

  // The VO's camera.yaml is the calibrated model with its distortion; the true one is ground truth.
  EXPECT_EQ(ds.camera().distortionModel(), "plumb_bob");
  ASSERT_EQ(ds.camera().distortion().size(), 5u);
  EXPECT_LT(ds.camera().distortion()[0], -0.01);
  ASSERT_TRUE(fs::exists(o.output_dir + "/groundtruth_camera.yaml"));
  EXPECT_NE(readFile(o.output_dir + "/groundtruth_camera.yaml"), readFile(o.output_dir + "/camera.yaml"));

  // The altimeter stream holds only time and slant range; altitude and truth go to ground-truth files.
  std::ifstream alt(o.output_dir + "/altimeter.txt");
  for (std::string line; std::getline(alt, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream is(line);
    std::vector<std::string> cols;
    for (std::string c; is >> c;) cols.push_back(c);
    EXPECT_EQ(cols.size(), 2u) << line;
  }
  for (const char* f : {"groundtruth_state.txt", "groundtruth_altimeter.txt", "groundtruth_sensors.yaml",
                        "sensors.yaml", "image_exposure.txt"})
    EXPECT_TRUE(fs::exists(o.output_dir + "/" + f)) << f;
  EXPECT_EQ(readFile(o.output_dir + "/sensors.yaml").find("bias_at_start"), std::string::npos)
      << "the drawn errors are ground truth";

  // Measured, not true: the flight IMU and altimeter differ from the ideal ones along the same trajectory.
  SequenceOptions ideal = o;
  ideal.output_dir = test::outputDir("render_flight_ideal");
  ideal.sensors = sensors::sensorPreset("ideal");
  renderSequence(ideal);
  const Dataset di = Dataset::open(ideal.output_dir);
  ASSERT_EQ(di.imu().size(), ds.imu().size());
  double gyro_diff = 0;
  for (size_t i = 0; i < ds.imu().size(); ++i)
    gyro_diff =
        std::max(gyro_diff, (ds.imu()[i].angular_velocity_radps - di.imu()[i].angular_velocity_radps).norm());
  EXPECT_GT(gyro_diff, 1e-6);
  for (size_t i = 0; i < ds.size(); ++i)
    EXPECT_LT((ds.groundTruth()[i].T_world_cam.translation() - di.groundTruth()[i].T_world_cam.translation())
                  .norm(),
              1e-9);

  // Another sensor seed: other noise, the same truth and the same image hash inputs except the seed.
  SequenceOptions other = o;
  other.output_dir = test::outputDir("render_flight_seed2");
  other.sensor_seed = 2;
  renderSequence(other);
  EXPECT_NE(readFile(other.output_dir + "/images/000001.png"), readFile(o.output_dir + "/images/000001.png"));
  EXPECT_EQ(readFile(other.output_dir + "/groundtruth.txt"), readFile(o.output_dir + "/groundtruth.txt"));
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
