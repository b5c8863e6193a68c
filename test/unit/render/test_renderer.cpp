// Rendered frames: exact pinhole geometry (epipolar tracks, depth warping), determinism, sequence caching.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/render/renderer.h"
#include "planetary_vo/render/sequence_renderer.h"
#include "planetary_vo/sensors/sensor_suite.h"
#include "test_support.h"

using namespace planetary_vo;
using namespace planetary_vo::render;

namespace {

struct Scene {
  std::shared_ptr<const LunarTerrain> terrain;
  DescentTrajectory trajectory{TrajectoryPhase::kApproach, CameraMode::kForward30};
  RenderSettings settings;
};

Scene makeScene(const std::string& sequence, int size) {
  Scene s;
  const std::string dem_path = test::dataPath("lunar_dem/apollo15_gld100.yaml");
  EXPECT_TRUE(test::requireDataFile(dem_path));
  const auto dem = LunarDem::load(dem_path);
  s.trajectory = DescentTrajectory::fromSequence(findSequence(sequence));
  s.terrain =
      std::make_shared<const LunarTerrain>(dem, placeTrajectoryOnDem(*dem, s.trajectory), TerrainParams());
  s.settings.camera = PinholeCamera::fromFieldOfView(size, size, 60.0);
  return s;
}

// Sampson distance of (p0, p1) under F, in pixels.
double sampson(const Eigen::Matrix3d& F, const cv::Point2f& a, const cv::Point2f& b) {
  const Eigen::Vector3d x0(a.x, a.y, 1), x1(b.x, b.y, 1);
  const Eigen::Vector3d Fx0 = F * x0, Ftx1 = F.transpose() * x1;
  const double e = x1.dot(Fx0);
  return std::abs(e) /
         std::sqrt(Fx0.x() * Fx0.x() + Fx0.y() * Fx0.y() + Ftx1.x() * Ftx1.x() + Ftx1.y() * Ftx1.y());
}

double medianEpipolarError(const cv::Mat& im0, const cv::Mat& im1, const Pose& T_w0, const Pose& T_w1,
                           const PinholeCamera& cam, size_t* n_tracks) {
  std::vector<cv::Point2f> p0, p1;
  cv::goodFeaturesToTrack(im0, p0, 400, 0.01, 6);
  std::vector<uchar> status;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(im0, im1, p0, p1, status, err, cv::Size(15, 15), 3);
  const Pose T_10 = T_w1.inverse() * T_w0;
  const Eigen::Vector3d t = T_10.translation();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  const Eigen::Matrix3d Kinv = cam.K().inverse();
  const Eigen::Matrix3d F = Kinv.transpose() * tx * T_10.linear() * Kinv;
  std::vector<double> errors;
  for (size_t i = 0; i < p0.size(); ++i)
    if (status[i]) errors.push_back(sampson(F, p0[i], p1[i]));
  *n_tracks = errors.size();
  if (errors.empty()) return 1e9;
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

}  // namespace

TEST(Renderer, TracksObeyGroundTruthEpipolarGeometry) {
  Scene s = makeScene("approach_30deg", 256);
  Renderer renderer(s.terrain, s.settings);
  const Pose T0 = s.trajectory.state(20.0).T_world_cam(), T1 = s.trajectory.state(20.5).T_world_cam();
  const RenderOutput a = renderer.render(T0), b = renderer.render(T1);
  ASSERT_GT(cv::countNonZero(a.depth > 0), 0.99 * a.depth.total());  // terrain fills the view, no sky
  size_t n = 0;
  const double good = medianEpipolarError(a.image, b.image, T0, T1, s.settings.camera, &n);
  EXPECT_GT(n, 60u);
  EXPECT_LT(good, 0.5);
  // A slightly wrong relative pose (1 deg yaw) must break the epipolar constraint: the check can fail.
  Pose T1_wrong = T1;
  T1_wrong.linear() =
      T1.linear() * Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const double bad = medianEpipolarError(a.image, b.image, T0, T1_wrong, s.settings.camera, &n);
  EXPECT_GT(bad, 4.0 * good);
  EXPECT_GT(bad, 0.5);
  std::cout << "median Sampson error " << good << " px (wrong pose: " << bad << " px), " << n << " tracks\n";
}

TEST(Renderer, DepthWarpReproducesTheNextFrame) {
  Scene s = makeScene("approach_down", 256);
  Renderer renderer(s.terrain, s.settings);
  const PinholeCamera& cam = s.settings.camera;
  const Pose Ta = s.trajectory.state(30.0).T_world_cam(), Tb = s.trajectory.state(30.2).T_world_cam();
  const RenderOutput a = renderer.render(Ta), b = renderer.render(Tb);
  // Shadow boundaries move with the LOD and the viewpoint: exclude a 2 px band around them.
  cv::Mat edges_a, edges_b, boundary;
  cv::morphologyEx(a.shadow, edges_a, cv::MORPH_GRADIENT, cv::Mat());
  cv::morphologyEx(b.shadow, edges_b, cv::MORPH_GRADIENT, cv::Mat());
  cv::dilate(edges_a | edges_b, boundary, cv::Mat(), cv::Point(-1, -1), 2);
  auto meanWarpError = [&](const Pose& T_w_b) {
    const Pose T_ab = Ta.inverse() * T_w_b;
    double sum = 0;
    int n = 0;
    for (int v = 0; v < cam.height(); ++v)
      for (int u = 0; u < cam.width(); ++u) {
        const float z = b.depth(v, u);
        if (z <= 0 || boundary.at<uchar>(v, u)) continue;
        const Eigen::Vector3d Xb(z * (u - cam.cx()) / cam.fx(), z * (v - cam.cy()) / cam.fy(), z);
        const Eigen::Vector3d Xa = T_ab * Xb;
        const Eigen::Vector2d px = cam.project(Xa);
        if (!cam.isInImage(px, 1.0)) continue;
        // Occlusion check: the point must be the one frame a sees there.
        const int iu = static_cast<int>(std::lround(px.x())), iv = static_cast<int>(std::lround(px.y()));
        if (std::abs(a.depth(iv, iu) - Xa.z()) > 0.01 * Xa.z()) continue;
        cv::Mat patch;
        cv::getRectSubPix(a.image, cv::Size(1, 1), cv::Point2f(px.x(), px.y()), patch, CV_32F);
        sum += std::abs(patch.at<float>(0, 0) - b.image(v, u));
        ++n;
      }
    EXPECT_GT(n, static_cast<int>(0.3 * cam.width() * cam.height()));
    return sum / std::max(n, 1);
  };
  const double good = meanWarpError(Tb);
  Pose wrong = Tb;
  wrong.translation() += Eigen::Vector3d(3.0, 0, 0);  // 3 m sideways at ~250 m: ~2.5 px
  const double bad = meanWarpError(wrong);
  std::cout << "mean photometric warp error " << good << " DN (wrong pose: " << bad << " DN)\n";
  EXPECT_LT(good, 4.0);
  EXPECT_GT(bad, 2.0 * good);
}

TEST(Renderer, DeterministicWhateverThreadsAndCache) {
  Scene s = makeScene("main_brake_down", 128);
  const Pose T = s.trajectory.state(10.0).T_world_cam();
  s.settings.num_threads = 1;
  Renderer one(s.terrain, s.settings);
  s.settings.num_threads = 2;
  Renderer two(s.terrain, s.settings);
  two.render(s.trajectory.state(9.9).T_world_cam());  // warm cache with a neighbouring view
  const RenderOutput a = one.render(T), b = two.render(T);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.depth, b.depth, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a.image, cv::NORM_L1), 0.0);
  // A different seed gives a different terrain.
  TerrainParams tp = s.terrain->params();
  tp.seed = 2;
  auto other = std::make_shared<const LunarTerrain>(std::make_shared<LunarDem>(s.terrain->dem()),
                                                    s.terrain->placement(), tp);
  Renderer r2(other, s.settings);
  EXPECT_GT(cv::norm(r2.render(T).image, a.image, cv::NORM_L1), 0.0);
}

TEST(SequenceRenderer, WritesDatasetAndSkipsWhenUnchanged) {
  SequenceOptions o;
  o.sequence = "approach_nozzle";
  o.output_dir = test::outputDir("render_sequence");
  o.dem_yaml = test::dataPath("lunar_dem/apollo17_gld100.yaml");
  ASSERT_TRUE(test::requireDataFile(o.dem_yaml));
  o.width = o.height = 96;
  o.duration_s = 0.3;
  o.sensors = sensors::sensorPreset("ideal");  // perfect pinhole camera: camera.yaml is the exact model
  const SequenceResult r = renderSequence(o);
  EXPECT_FALSE(r.skipped);
  EXPECT_EQ(r.frames, 4u);
  const Dataset ds = Dataset::open(o.output_dir);
  ASSERT_EQ(ds.size(), 4u);
  ASSERT_TRUE(ds.hasGroundTruth());
  EXPECT_EQ(ds.imu().size(), 61u);  // 200 Hz over 0.3 s, both ends
  EXPECT_EQ(ds.altimeter().size(), 7u);
  EXPECT_EQ(ds.camera(), PinholeCamera::fromFieldOfView(96, 96, 60.0));
  const DescentTrajectory tr(TrajectoryPhase::kApproach, CameraMode::kNozzle);
  EXPECT_LT((ds.groundTruth()[3].T_world_cam.translation() - tr.position(0.3)).norm(), 1e-3);
  EXPECT_NE(ds.sequenceYaml().find(r.param_hash), std::string::npos);
  EXPECT_EQ(ds.loadImage(2).size(), cv::Size(96, 96));
  EXPECT_TRUE(renderSequence(o).skipped);  // unchanged: cached
  o.seed = 5;
  EXPECT_FALSE(renderSequence(o).skipped);  // any parameter change re-renders
}

TEST(SequenceRenderer, StartsWhereAskedWithEveryStreamStampedThere) {
  // The last 0.3 s of a 0.5 s clip: the frames of the whole clip from 0.2 s, bit for bit (ideal camera), and
  // IMU, altimeter and ground truth from 0.2 s on their own time stamps.
  SequenceOptions o;
  o.sequence = "approach_down";
  o.dem_yaml = test::dataPath("lunar_dem/apollo17_gld100.yaml");
  ASSERT_TRUE(test::requireDataFile(o.dem_yaml));
  o.width = o.height = 64;
  o.duration_s = 0.5;
  o.sensors = sensors::sensorPreset("ideal");
  const std::string whole_dir = test::outputDir("render_sequence_whole");
  o.output_dir = whole_dir;
  const SequenceResult whole = renderSequence(o);
  o.output_dir = test::outputDir("render_sequence_from_0.2s");
  o.start_s = 0.2;
  const SequenceResult tail = renderSequence(o);
  EXPECT_NE(tail.param_hash, whole.param_hash);
  EXPECT_EQ(whole.frames, 6u);
  ASSERT_EQ(tail.frames, 4u);
  const Dataset a = Dataset::open(whole_dir);
  const Dataset b = Dataset::open(o.output_dir);
  ASSERT_EQ(b.size(), 4u);
  for (size_t i = 0; i < b.size(); ++i) {
    EXPECT_NEAR(b.timestamp(i), a.timestamp(i + 2), 1e-9);
    EXPECT_EQ(cv::norm(b.loadImageUnchanged(i), a.loadImageUnchanged(i + 2), cv::NORM_INF), 0.0) << i;
    EXPECT_LT(
        (b.groundTruth()[i].T_world_cam.translation() - a.groundTruth()[i + 2].T_world_cam.translation())
            .norm(),
        1e-9);
  }
  ASSERT_EQ(b.imu().size(), 61u);  // 200 Hz over 0.3 s, both ends
  EXPECT_NEAR(b.imu().front().timestamp_s, 0.2, 1e-9);
  EXPECT_NEAR(b.imu().back().timestamp_s, 0.5, 1e-9);
  ASSERT_EQ(b.altimeter().size(), 7u);
  EXPECT_NEAR(b.altimeter().front().timestamp_s, 0.2, 1e-9);
  EXPECT_NE(b.sequenceYaml().find("start_s: 0.2"), std::string::npos);
  o.start_s = 0.5;  // nothing left
  EXPECT_THROW(renderSequence(o), std::invalid_argument);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
