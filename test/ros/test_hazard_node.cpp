/// gtest node of the AGNC rostest (hazard_end_to_end.test): the player streams a rendered Lunar descent and
/// hands the initial state over; the VO nodelet (config/lunar_fused.yaml) and the hazard nodelet run in one
/// manager. Checks what hazard detection hands on:
///   - hazard/map is metric, covers the ground the camera saw, and its elevation under the camera along the
///     whole descent agrees with the truth (camera height minus the true altitude above the terrain, from the
///     dataset's groundtruth_altimeter.txt: ground truth used only here, by the test);
///   - hazard/occupancy has the map's geometry and exactly its known cells;
///   - hazard/landing_sites is published with the map, and hazard/status reaches the last image (the
///     products include every frame) with densified keyframes and no rejected input;
///   - a malformed vo/map_events is rejected with a reason on hazard/status and the nodelet goes on applying
///     the next, valid one.
///
/// Private parameters: ~dataset (string); ~max_elevation_rms_m (double, 3) and ~max_elevation_bias_m (double,
/// 1.5): the RMS and the mean of the elevation error at the nadir cells of every image (0.5 % and 0.25 % of
/// the 650 m range; a 1 % scale error or a wrong datum gives more than 6 m). Measured offline on this clip
/// with the same configuration (vo_run --output-terrain, docs/visual_core.md): RMS 1.85 m, mean -0.44 m;
/// ~min_cells_known (int, 200), ~manager, ~player ("/agnc_manager", "/player"), ~timeout (double, 90).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>

#include "planetary_vo/HazardMap.h"
#include "planetary_vo/HazardStatus.h"
#include "planetary_vo/LandingSites.h"
#include "planetary_vo/VoMapEvents.h"
#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/ros_io/conversions.h"
#include "planetary_vo/ros_io/hazard_conversions.h"
#include "planetary_vo/ros_io/player.h"
#include "test_ros_helpers.h"

namespace planetary_vo::ros_io {
namespace {

/// True altitude above the terrain at dataset time t (the nearest sample of groundtruth_altimeter.txt).
double trueAltitudeAt(const std::string& dataset_dir, double t) {
  std::ifstream in(dataset_dir + "/groundtruth_altimeter.txt");
  std::string line;
  double best_dt = 1e9, altitude = std::nan("");
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    double ts = 0, range = 0, alt = 0;
    if (!(s >> ts >> range >> alt)) continue;
    if (std::abs(ts - t) < best_dt) best_dt = std::abs(ts - t), altitude = alt;
  }
  return altitude;
}

class HazardNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::NodeHandle pnh("~");
    ASSERT_TRUE(pnh.getParam("dataset", dataset_dir_));
    max_elevation_rms_m_ = pnh.param("max_elevation_rms_m", 3.0);
    max_elevation_bias_m_ = pnh.param("max_elevation_bias_m", 1.5);
    min_cells_known_ = pnh.param("min_cells_known", 200);
    timeout_s_ = pnh.param("timeout", 90.0);
    manager_ = pnh.param<std::string>("manager", "/agnc_manager");
    player_ = pnh.param<std::string>("player", "/player");
    dataset_ = std::make_unique<Dataset>(Dataset::open(dataset_dir_));
    epoch_ = chooseEpoch(*dataset_, -1.0);
    subs_.push_back(nh_.subscribe("hazard/map", 10, &HazardNodeTest::onMap, this));
    subs_.push_back(nh_.subscribe("hazard/occupancy", 10, &HazardNodeTest::onOccupancy, this));
    subs_.push_back(nh_.subscribe("hazard/landing_sites", 10, &HazardNodeTest::onSites, this));
    subs_.push_back(nh_.subscribe("hazard/status", 100, &HazardNodeTest::onStatus, this));
    subs_.push_back(nh_.subscribe("ground_truth/pose", 1000, &HazardNodeTest::onGroundTruth, this));
    events_pub_ = nh_.advertise<VoMapEvents>("vo/map_events", 10);
  }
  void TearDown() override {
    for (ros::Subscriber& s : subs_) s.shutdown();
  }

  void onMap(const HazardMap::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    map_ = *m;
  }
  void onOccupancy(const nav_msgs::OccupancyGrid::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    occupancy_ = *m;
  }
  void onSites(const LandingSites::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    sites_ = *m;
  }
  void onStatus(const HazardStatus::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    status_ = *m;
    ++num_status_;
  }
  void onGroundTruth(const geometry_msgs::PoseStamped::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    ground_truth_.push_back(*m);
  }

  /// Every image played, and the products include the last one.
  bool productsCoverTheStream() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (ground_truth_.size() < dataset_->size() || !status_ || !map_ || !sites_) return false;
    return status_->header.stamp >= ground_truth_.back().header.stamp && status_->products_published > 0 &&
           map_->sequence == status_->products_published && sites_->sequence == status_->products_published;
  }

  ros::NodeHandle nh_;
  std::string dataset_dir_, manager_, player_;
  double max_elevation_rms_m_ = 3.0, max_elevation_bias_m_ = 1.5, timeout_s_ = 90.0;
  int min_cells_known_ = 200;
  std::unique_ptr<Dataset> dataset_;
  ros::Time epoch_;
  std::vector<ros::Subscriber> subs_;
  ros::Publisher events_pub_;
  std::mutex mutex_;
  std::optional<HazardMap> map_;
  std::optional<nav_msgs::OccupancyGrid> occupancy_;
  std::optional<LandingSites> sites_;
  std::optional<HazardStatus> status_;
  int num_status_ = 0;
  std::vector<geometry_msgs::PoseStamped> ground_truth_;
};

TEST_F(HazardNodeTest, TheHazardMapOfTheDescentAndMalformedEventsRejected) {
  ASSERT_TRUE(resumePlayerWhenConnected(
      player_, manager_,
      {"/camera/image_raw", "/camera/camera_info", "/imu", "/altimeter", "/nav/initial_state"}, subs_));
  ASSERT_TRUE(waitFor([&] { return productsCoverTheStream(); }, timeout_s_))
      << "the hazard products never covered the last image";

  std::unique_lock<std::mutex> lock(mutex_);
  const HazardStatus status = *status_;
  std::printf(
      "hazard: status: %u products, %u events applied, %u rejected, %u keyframes densified, %u points, "
      "metric %d, densifying %d, message '%s'\n",
      status.products_published, status.events_applied, status.inputs_rejected, status.keyframes_densified,
      status.num_points, status.metric, status.densifying, status.message.c_str());
  EXPECT_TRUE(status.metric);
  EXPECT_TRUE(status.densifying);
  EXPECT_GT(status.events_applied, 10u);
  EXPECT_GT(status.keyframes_densified, 2u);
  EXPECT_EQ(status.inputs_rejected, 0u) << status.message;

  // hazard/map: metric, in the world frame, covering what the camera saw.
  const HazardMap& map = *map_;
  EXPECT_TRUE(map.metric);
  EXPECT_EQ(map.header.frame_id, "world");
  const terrain::GridSet grids = fromHazardMapMsg(map);
  const terrain::GridGeometry& g = grids.geometry;
  const cv::Mat& elevation = grids.layers.at("elevation_m");
  const int known = cv::countNonZero(elevation == elevation);  // NaN != NaN
  std::printf("hazard: map %d x %d cells of %.1f m, %d known (message says %d), %u points\n", g.cols, g.rows,
              g.cell_size_m, known, map.cells_known, map.num_points);
  EXPECT_EQ(known, map.cells_known);
  EXPECT_GE(known, min_cells_known_);

  // The elevation under the camera against the truth, at every image's nadir cell (the whole track the map
  // covers, not one cell: a single 10 m cell of this map is off by up to ~3 m either way while the track's
  // mean error is a fraction of that).
  std::vector<double> errors_m;
  for (const geometry_msgs::PoseStamped& pose : ground_truth_) {
    const double t = toDatasetTime(epoch_, pose.header.stamp);
    const double true_ground_z = pose.pose.position.z - trueAltitudeAt(dataset_dir_, t);
    int col = 0, row = 0;
    if (!g.cellAt(pose.pose.position.x, pose.pose.position.y, &col, &row)) continue;
    const float z_est = elevation.at<float>(row, col);
    if (std::isfinite(z_est) && std::isfinite(true_ground_z)) errors_m.push_back(z_est - true_ground_z);
  }
  ASSERT_GE(errors_m.size(), ground_truth_.size() / 2)
      << "the map misses most of the ground under the camera";
  double sum = 0.0, sum_sq = 0.0;
  for (double e : errors_m) sum += e, sum_sq += e * e;
  const double mean_m = sum / errors_m.size(), rms_m = std::sqrt(sum_sq / errors_m.size());
  std::printf(
      "hazard: elevation under the camera at %zu of %zu images: error mean %+.2f m, RMS %.2f m, last %+.2f "
      "m\n",
      errors_m.size(), ground_truth_.size(), mean_m, rms_m, errors_m.back());
  EXPECT_LT(rms_m, max_elevation_rms_m_);
  EXPECT_LT(std::abs(mean_m), max_elevation_bias_m_);

  // hazard/occupancy: the map's geometry, known exactly where slope and roughness are.
  ASSERT_TRUE(occupancy_);
  EXPECT_EQ(occupancy_->info.width, map.info.width);
  EXPECT_EQ(occupancy_->info.height, map.info.height);
  EXPECT_FLOAT_EQ(occupancy_->info.resolution, map.info.resolution);
  EXPECT_DOUBLE_EQ(occupancy_->info.origin.position.x, map.info.origin.position.x);
  const cv::Mat& slope = grids.layers.at("slope_deg");
  const cv::Mat& roughness = grids.layers.at("roughness_m");
  int occupancy_known = 0, surface_known = 0, hazards = 0;
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const int8_t o = occupancy_->data[size_t(r) * g.cols + c];
      occupancy_known += o != kOccupancyUnknown;
      hazards += o == kOccupancyHazard;
      surface_known += std::isfinite(slope.at<float>(r, c)) && std::isfinite(roughness.at<float>(r, c));
    }
  EXPECT_EQ(occupancy_known, surface_known);
  EXPECT_GT(occupancy_known, 0);
  std::printf("hazard: occupancy %d known cells, %d hazardous\n", occupancy_known, hazards);

  // hazard/landing_sites: with the map; sites or the reason why none.
  ASSERT_TRUE(sites_);
  EXPECT_TRUE(sites_->metric);
  EXPECT_TRUE(!sites_->sites.empty() || !sites_->reason.empty());
  std::printf("hazard: %zu landing sites; reason '%s'\n", sites_->sites.size(), sites_->reason.c_str());

  // A malformed message (3 positions for 2 points) is rejected with a reason, and the next valid one is
  // applied: the nodelet lives on.
  const uint32_t applied_before = status.events_applied;
  const ros::Time last_stamp = ground_truth_.back().header.stamp;
  lock.unlock();
  ASSERT_TRUE(waitFor([&] { return events_pub_.getNumSubscribers() > 0; }, 10.0));
  VoMapEvents bad;
  bad.header.frame_id = "world";
  bad.header.stamp = last_stamp;
  bad.metric_scale = true;
  bad.added_ids = {uint64_t{1} << 62, (uint64_t{1} << 62) + 1};
  bad.added_positions = {1.0, 2.0, 3.0};
  bad.added_covariances.assign(18, 0.0);
  bad.added_num_observations = {2, 2};
  events_pub_.publish(bad);
  ASSERT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> l(mutex_);
        return status_->inputs_rejected >= 1;
      },
      10.0))
      << "the malformed message was not reported";
  {
    std::lock_guard<std::mutex> l(mutex_);
    EXPECT_NE(status_->message.find("vo/map_events"), std::string::npos) << status_->message;
    EXPECT_NE(status_->message.find("added_positions"), std::string::npos) << status_->message;
    EXPECT_EQ(status_->events_applied, applied_before);
  }
  VoMapEvents good = bad;
  good.added_ids = {uint64_t{1} << 62};
  good.added_covariances.assign(9, 0.0);
  good.added_num_observations = {2};
  events_pub_.publish(good);
  EXPECT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> l(mutex_);
        return status_->events_applied == applied_before + 1;
      },
      10.0))
      << "the nodelet did not apply the valid message after the malformed one";
}

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) { return planetary_vo::ros_io::runRosTests(argc, argv, "test_hazard_node"); }
