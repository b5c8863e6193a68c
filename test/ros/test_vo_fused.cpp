/// gtest node of the fused-navigation rostest (vo_fused.test): the player streams a rendered Lunar descent
/// with its image, IMU and altimeter streams and hands the ground-truth state at the first image over on
/// nav/initial_state; the VO nodelet runs config/lunar_fused.yaml (camera + IMU + altimeter) and waits for
/// the handover. Checks the metric navigation output nav/odometry against the ground truth WITHOUT any
/// alignment (position and velocity errors in metres and m/s), its rate (the IMU's between images), and
/// vo/status (mode, metric, inertial, counters). With ~expect_inertial false it checks the vision + altimeter
/// mode the same way (config/lunar_altimeter.yaml): no IMU, nav/odometry at the image rate, its velocity the
/// motion filter's.
///
/// Private parameters:
///   ~dataset (string)                  the rendered dataset (images, imu.txt, groundtruth_state.txt)
///   ~expect_mode (string)              VoStatus.mode the configuration must give ("vision+imu+altimeter")
///   ~expect_inertial (bool, true)      the IMU holds the map and nav/odometry runs at the IMU rate; false:
///                                      no IMU (vision + altimeter), nav/odometry at the image rate
///   ~expect_vision (bool, true)        false: every image is refused (a dark descent), nothing is tracked,
///                                      and nav/odometry is the IMU's dead reckoning from the handover,
///                                      at the IMU rate, not confident (pose sigma over ~min_dead_reckoning_sigma_m)
///   ~min_dead_reckoning_sigma_m (double, 1)
///   ~max_position_error_m (double)     bound on every nav/odometry position error (m)
///   ~max_mean_position_nees (double, 0: not checked)  bound on the mean position NEES of nav/odometry
///                                      (its pose covariance against the error; 3 is consistent)
///   ~max_velocity_error_mps (double)   bound on every nav/odometry velocity error (m/s)
///   ~min_rate_fraction (double, 0.8)   nav/odometry stamps per second / IMU rate (image rate without the
///                                      IMU), from the first output on
///   ~max_first_output_s (double, 2)    the first nav/odometry within this of the first image (dataset time)
///   ~manager, ~player (string)         node names ("/vo_manager", "/player")
///   ~timeout (double, 90)              seconds to wait for the whole stream

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>

#include "planetary_vo/VoStatus.h"
#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/eval/evaluation_inputs.h"
#include "planetary_vo/ros_io/conversions.h"
#include "planetary_vo/ros_io/player.h"
#include "test_ros_helpers.h"

namespace planetary_vo::ros_io {
namespace {

class VoFusedTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::NodeHandle pnh("~");
    ASSERT_TRUE(pnh.getParam("dataset", dataset_dir_));
    expect_mode_ = pnh.param<std::string>("expect_mode", VoStatus::MODE_VISION_IMU_ALTIMETER);
    expect_inertial_ = pnh.param("expect_inertial", true);
    expect_vision_ = pnh.param("expect_vision", true);
    min_dead_reckoning_sigma_m_ = pnh.param("min_dead_reckoning_sigma_m", 1.0);
    max_position_error_m_ = pnh.param("max_position_error_m", 5.0);
    max_mean_position_nees_ = pnh.param("max_mean_position_nees", 0.0);
    max_velocity_error_mps_ = pnh.param("max_velocity_error_mps", 1.0);
    min_rate_fraction_ = pnh.param("min_rate_fraction", 0.8);
    max_first_output_s_ = pnh.param("max_first_output_s", 2.0);
    timeout_s_ = pnh.param("timeout", 90.0);
    manager_ = pnh.param<std::string>("manager", "/vo_manager");
    player_ = pnh.param<std::string>("player", "/player");
    dataset_ = std::make_unique<Dataset>(Dataset::open(dataset_dir_));
    states_ = readGroundTruthStates(dataset_dir_ + "/groundtruth_state.txt");
    epoch_ = chooseEpoch(*dataset_, -1.0);  // the player's default (auto) epoch
    subs_.push_back(nh_.subscribe("nav/odometry", 10000, &VoFusedTest::onNav, this));
    subs_.push_back(nh_.subscribe("vo/status", 1000, &VoFusedTest::onStatus, this));
    subs_.push_back(nh_.subscribe("ground_truth/pose", 1000, &VoFusedTest::onGroundTruth, this));
  }

  /// No callback may run into the members being destroyed (the nodelet may still be publishing).
  void TearDown() override {
    for (ros::Subscriber& s : subs_) s.shutdown();
  }

  void onNav(const nav_msgs::OdometryConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    nav_.push_back(*m);
  }
  void onStatus(const VoStatusConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!m->header.stamp.isZero()) statuses_.push_back(*m);
  }
  void onGroundTruth(const geometry_msgs::PoseStampedConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    ground_truth_.push_back(*m);
  }

  bool streamDone() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (ground_truth_.size() < dataset_->size()) return false;
    return !statuses_.empty() && statuses_.back().header.stamp >= ground_truth_.back().header.stamp;
  }

  /// The ground-truth state at dataset time t (linear between the 200 Hz samples; the rotation of the
  /// nearer).
  GroundTruthState truthAt(double t) const {
    const auto after =
        std::lower_bound(states_.begin(), states_.end(), t,
                         [](const GroundTruthState& s, double v) { return s.timestamp_s < v; });
    if (after == states_.begin()) return states_.front();
    if (after == states_.end()) return states_.back();
    const GroundTruthState& a = *(after - 1);
    const GroundTruthState& b = *after;
    const double f = (t - a.timestamp_s) / (b.timestamp_s - a.timestamp_s);
    GroundTruthState s = f < 0.5 ? a : b;
    s.timestamp_s = t;
    s.T_world_body.translation() =
        (1.0 - f) * a.T_world_body.translation() + f * b.T_world_body.translation();
    s.velocity_world_mps = (1.0 - f) * a.velocity_world_mps + f * b.velocity_world_mps;
    return s;
  }

  ros::NodeHandle nh_;
  std::string dataset_dir_, expect_mode_, manager_, player_;
  double max_position_error_m_ = 5.0, max_velocity_error_mps_ = 1.0, min_rate_fraction_ = 0.8;
  double max_mean_position_nees_ = 0.0;
  double max_first_output_s_ = 2.0, timeout_s_ = 90.0;
  bool expect_inertial_ = true, expect_vision_ = true;
  double min_dead_reckoning_sigma_m_ = 1.0;
  std::unique_ptr<Dataset> dataset_;
  std::vector<GroundTruthState> states_;
  ros::Time epoch_;
  std::vector<ros::Subscriber> subs_;
  std::mutex mutex_;
  std::vector<nav_msgs::Odometry> nav_;
  std::vector<VoStatus> statuses_;
  std::vector<geometry_msgs::PoseStamped> ground_truth_;
};

TEST_F(VoFusedTest, MetricNavigationAtTheImuRateWithoutAlignment) {
  // Start the paused player once the nodelet has the camera, the IMU, the altimeter and the handover, and
  // this node the outputs (see test_vo_node.cpp: only accepted connections receive what is published).
  std::vector<std::string> inputs = {"/camera/image_raw", "/camera/camera_info", "/altimeter",
                                     "/nav/initial_state"};
  if (expect_inertial_) inputs.push_back("/imu");
  ASSERT_TRUE(resumePlayerWhenConnected(player_, manager_, inputs, subs_));
  ASSERT_TRUE(waitFor([&] { return streamDone(); }, timeout_s_))
      << "stream incomplete: " << ground_truth_.size() << " ground-truth poses, " << statuses_.size()
      << " statuses of " << dataset_->size() << " images";

  std::lock_guard<std::mutex> lock(mutex_);
  // vo/status: the configured mode, metric and inertial at the end, the handover applied, every sample used.
  const VoStatus& last = statuses_.back();
  std::printf(
      "vo_fused: last status: mode %s, state %s, metric %d (scale from %s), inertial %d, initial "
      "state applied %d, IMU %u used / %u rejected of %u, altimeter %u used / %u without range / %u "
      "rejected of %u; message '%s'\n",
      last.mode.c_str(), last.state_name.c_str(), last.metric, last.scale_source.c_str(), last.inertial,
      last.initial_state_applied, last.num_imu_used, last.num_imu_rejected, last.num_imu_msgs,
      last.num_altimeter_used, last.num_altimeter_no_range, last.num_altimeter_rejected,
      last.num_altimeter_msgs, last.message.c_str());
  EXPECT_EQ(last.mode, expect_mode_);
  EXPECT_EQ(last.metric, expect_vision_) << "the map is not metric, or there is one without vision";
  if (expect_vision_) {
    EXPECT_NE(last.scale_source, "none");
  }
  EXPECT_EQ(last.inertial, expect_inertial_ && expect_vision_) << "IMU factors hold the map, or do not";
  if (expect_vision_) {  // dark: BAD_INPUT statuses, which carry no velocity
    EXPECT_EQ(last.has_velocity, expect_inertial_);
  }
  EXPECT_TRUE(last.initial_state_applied) << "the handover was not applied";
  EXPECT_EQ(last.num_imu_rejected, 0u);
  EXPECT_EQ(last.num_altimeter_rejected, 0u);
  if (expect_inertial_) {
    EXPECT_GT(last.num_imu_used, last.num_imu_msgs * 9 / 10);
  }
  EXPECT_GT(last.num_altimeter_used, 0u);
  int tracked = 0;
  for (const VoStatus& s : statuses_) {
    if (expect_vision_) {
      EXPECT_NE(s.state, VoStatus::STATE_BAD_INPUT) << s.message;
    } else {  // every image refused, with the reason
      EXPECT_EQ(s.state, VoStatus::STATE_BAD_INPUT) << s.message;
    }
    if (s.state == VoStatus::STATE_TRACKING || s.state == VoStatus::STATE_RECOVERED) ++tracked;
  }
  if (expect_vision_) {
    EXPECT_GE(tracked, int(dataset_->size()) / 2);
  } else {
    EXPECT_EQ(tracked, 0) << "the dark images were tracked";
  }

  // nav/odometry: present, metric, from early on, at the IMU rate.
  ASSERT_FALSE(nav_.empty()) << "no nav/odometry";
  const double t_first_image = dataset_->timestamp(0);
  const double t_last_image = dataset_->timestamps().back();
  std::set<ros::Time> stamps;
  for (const auto& m : nav_) stamps.insert(m.header.stamp);
  const double t_first_nav = toDatasetTime(epoch_, *stamps.begin());
  const double t_last_nav = toDatasetTime(epoch_, *stamps.rbegin());
  const auto& imu = dataset_->imu();
  const double imu_rate_hz =
      expect_inertial_ ? (imu.size() - 1) / (imu.back().timestamp_s - imu.front().timestamp_s)
                       : (dataset_->size() - 1) / std::max(1e-9, t_last_image - t_first_image);
  const double nav_rate_hz = (stamps.size() - 1) / std::max(1e-9, t_last_nav - t_first_nav);
  std::printf(
      "vo_fused: %zu nav/odometry messages, %zu stamps from %.3f s to %.3f s (images %.1f to %.1f s): "
      "%.1f Hz, IMU %.1f Hz\n",
      nav_.size(), stamps.size(), t_first_nav, t_last_nav, t_first_image, t_last_image, nav_rate_hz,
      imu_rate_hz);
  EXPECT_LT(t_first_nav - t_first_image, max_first_output_s_) << "nav/odometry starts late";
  EXPECT_GT(t_last_nav, t_last_image - 0.2);
  EXPECT_GT(nav_rate_hz, min_rate_fraction_ * imu_rate_hz)
      << "nav/odometry is not at the IMU rate (the image rate without the IMU)";

  // Errors against the ground truth, no alignment: position of the camera (the child frame here), and the
  // velocity (twist in the child frame, rotated back into the world).
  double max_dp = 0.0, max_dv = 0.0, sum_dp2 = 0.0, sum_dv2 = 0.0, t_max_dp = 0.0, t_max_dv = 0.0;
  double end_dp = 0.0, end_dv = 0.0, sum_position_nees = 0.0;
  size_t unknown_velocity = 0, known_velocity = 0;
  for (const auto& m : nav_) {
    const double t = toDatasetTime(epoch_, m.header.stamp);
    const Pose T = fromPoseMsg(m.pose.pose);
    ASSERT_TRUE(T.matrix().allFinite()) << "non-finite nav/odometry at " << t;
    EXPECT_EQ(m.header.frame_id, "world");
    const Eigen::Vector3d v_child(m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z);
    const Eigen::Vector3d v_world = T.rotation() * v_child;
    const GroundTruthState truth = truthAt(t);
    const double dp = (T.translation() - truth.T_world_body.translation()).norm();
    const double dv = (v_world - truth.velocity_world_mps).norm();
    for (int i : {0, 7, 14, 21, 28, 35}) {
      EXPECT_GT(m.pose.covariance[i], 0.0);
      EXPECT_TRUE(std::isfinite(m.pose.covariance[i]));
    }
    // Dead reckoning is never published as confident.
    if (!expect_vision_) {
      EXPECT_GT(m.pose.covariance[0], min_dead_reckoning_sigma_m_ * min_dead_reckoning_sigma_m_) << "at " << t;
    }
    Eigen::Matrix3d P;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) P(r, c) = m.pose.covariance[6 * r + c];
    const Eigen::Vector3d e = truth.T_world_body.translation() - T.translation();
    sum_position_nees += e.dot(P.ldlt().solve(e));
    sum_dp2 += dp * dp;
    if (dp > max_dp) max_dp = dp, t_max_dp = t;
    end_dp = dp;
    // A velocity the message says is unknown (variance about 1e6: the first metric image without the IMU)
    // is not one guidance may use: counted, not scored.
    if (m.twist.covariance[0] > 1e5) {
      ++unknown_velocity;
      continue;
    }
    ++known_velocity;
    sum_dv2 += dv * dv;
    if (dv > max_dv) max_dv = dv, t_max_dv = t;
    end_dv = dv;
  }
  const double n = double(nav_.size());
  std::printf("vo_fused: %zu nav/odometry velocities known, %zu unknown\n", known_velocity, unknown_velocity);
  EXPECT_LE(unknown_velocity, 2u) << "nav/odometry without a velocity beyond the first image";
  const Eigen::Vector3d p0 = states_.front().T_world_body.translation();
  const Eigen::Vector3d p1 = truthAt(t_last_image).T_world_body.translation();
  std::printf(
      "vo_fused: position error RMS %.3f m, max %.3f m (at %.2f s), end %.3f m over %.1f m travelled; "
      "velocity error RMS %.3f m/s, max %.3f m/s (at %.2f s), end %.3f m/s\n",
      std::sqrt(sum_dp2 / n), max_dp, t_max_dp, end_dp, (p1 - p0).norm(),
      std::sqrt(sum_dv2 / std::max<size_t>(1, known_velocity)), max_dv,
      t_max_dv, end_dv);
  EXPECT_LT(max_dp, max_position_error_m_);
  EXPECT_LT(max_dv, max_velocity_error_mps_);
  std::printf("vo_fused: mean position NEES %.3f over %zu nav/odometry messages\n", sum_position_nees / n,
              nav_.size());
  if (max_mean_position_nees_ > 0.0) EXPECT_LT(sum_position_nees / n, max_mean_position_nees_);
}

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) { return planetary_vo::ros_io::runRosTests(argc, argv, "test_vo_fused"); }
