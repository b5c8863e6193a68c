/// gtest node of the player rostests: subscribes to every topic the player publishes (from the player node,
/// or from `rosbag play` of a bag the player wrote) and checks the stream against the dataset read by the
/// core reader.
///
/// Private parameters:
///   ~dataset (string)        the dataset the stream comes from
///   ~live (bool, true)       the player node runs with ~start_paused: wait for the connections, then call
///                            /player/resume; also pause it mid-stream and check that nothing arrives while
///                            paused
///   ~expect_clock (bool)     /clock is published with the stamp of every message
///   ~expect_fx (double, 0)   when > 0, the focal length the CameraInfo must carry
///   ~timeout (double, 60)    seconds to wait for the whole stream

#include <algorithm>
#include <cstdio>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <std_srvs/Trigger.h>
#include <tf2/buffer_core.h>
#include <tf2_msgs/TFMessage.h>

#include "planetary_vo/ros_io/player.h"

namespace planetary_vo::ros_io {
namespace {

/// Everything received, in arrival order per topic.
struct Received {
  std::mutex mutex;
  std::vector<sensor_msgs::ImageConstPtr> images;
  std::vector<sensor_msgs::CameraInfoConstPtr> infos;
  std::vector<geometry_msgs::PoseStamped> poses;
  std::vector<size_t> path_sizes;
  std::vector<geometry_msgs::TransformStamped> transforms;
  std::vector<sensor_msgs::Imu> imu;
  std::vector<sensor_msgs::Range> altimeter;
  std::vector<ros::Time> clock;

  size_t numImages() {
    std::lock_guard<std::mutex> lock(mutex);
    return images.size();
  }
};

class PlayerStreamTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::NodeHandle pnh("~");
    ASSERT_TRUE(pnh.getParam("dataset", dataset_dir_)) << "~dataset not set";
    live_ = pnh.param("live", true);
    expect_clock_ = pnh.param("expect_clock", false);
    expect_fx_ = pnh.param("expect_fx", 0.0);
    timeout_s_ = pnh.param("timeout", 60.0);
    dataset_ = std::make_unique<Dataset>(Dataset::open(dataset_dir_));
    reference_ = std::make_unique<Player>(*dataset_, PlayerOptions());

    image_sub_ = transport_.subscribe(player_topics::kImage, 1000, &PlayerStreamTest::onImage, this);
    subs_.push_back(nh_.subscribe(player_topics::kCameraInfo, 1000, &PlayerStreamTest::onInfo, this));
    subs_.push_back(nh_.subscribe(player_topics::kGroundTruthPose, 1000, &PlayerStreamTest::onPose, this));
    subs_.push_back(nh_.subscribe(player_topics::kGroundTruthPath, 1000, &PlayerStreamTest::onPath, this));
    subs_.push_back(nh_.subscribe(player_topics::kTf, 1000, &PlayerStreamTest::onTf, this));
    // The bag has /imu and /altimeter only when the dataset has these streams (the live node always
    // advertises).
    if (live_ || !dataset_->imu().empty())
      subs_.push_back(nh_.subscribe(player_topics::kImu, 10000, &PlayerStreamTest::onImu, this));
    if (live_ || !dataset_->altimeter().empty())
      subs_.push_back(nh_.subscribe(player_topics::kAltimeter, 1000, &PlayerStreamTest::onRange, this));
    if (expect_clock_)
      subs_.push_back(nh_.subscribe(player_topics::kClock, 10000, &PlayerStreamTest::onClock, this));
  }

  /// Spins until `done` holds or the timeout passes; returns done().
  bool waitFor(const std::function<bool()>& done, double timeout_s) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::ok() && ros::WallTime::now() < deadline) {
      ros::spinOnce();
      if (done()) return true;
      ros::WallDuration(0.005).sleep();  // polling period of the condition
    }
    ros::spinOnce();
    return done();
  }

  bool allConnected() {
    if (image_sub_.getNumPublishers() == 0) return false;
    return std::all_of(subs_.begin(), subs_.end(),
                       [](const ros::Subscriber& s) { return s.getNumPublishers() > 0; });
  }

  bool streamComplete() {
    std::lock_guard<std::mutex> lock(rx_.mutex);
    const size_t n = dataset_->size();
    const bool gt = dataset_->hasGroundTruth();
    return rx_.images.size() >= n && rx_.infos.size() >= n && (!gt || rx_.poses.size() >= n) &&
           (!gt || rx_.path_sizes.size() >= n) && (!gt || rx_.transforms.size() >= n) &&
           rx_.imu.size() >= dataset_->imu().size() && rx_.altimeter.size() >= dataset_->altimeter().size() &&
           (!expect_clock_ || rx_.clock.size() >= reference_->schedule().size());
  }

  std_srvs::Trigger::Response call(const std::string& service) {
    std_srvs::Trigger srv;
    EXPECT_TRUE(ros::service::waitForService(service, ros::Duration(timeout_s_))) << service;
    EXPECT_TRUE(ros::service::call(service, srv)) << service;
    EXPECT_TRUE(srv.response.success) << service << ": " << srv.response.message;
    return srv.response;
  }

  ros::Time expectedImageStamp(size_t i) const { return reference_->stampOf(dataset_->timestamp(i)); }

  void onImage(const sensor_msgs::ImageConstPtr& m) {
    std::lock_guard<std::mutex> lock(rx_.mutex);
    rx_.images.push_back(m);
  }
  void onInfo(const sensor_msgs::CameraInfoConstPtr& m) {
    std::lock_guard<std::mutex> lock(rx_.mutex);
    rx_.infos.push_back(m);
  }
  void onPose(const geometry_msgs::PoseStampedConstPtr& m) {
    std::lock_guard<std::mutex> lock(rx_.mutex);
    rx_.poses.push_back(*m);
  }
  void onPath(const nav_msgs::PathConstPtr& m) {
    std::lock_guard<std::mutex> lock(rx_.mutex);
    rx_.path_sizes.push_back(m->poses.size());
  }
  void onTf(const tf2_msgs::TFMessageConstPtr& m) {
    std::lock_guard<std::mutex> lock(rx_.mutex);
    for (const geometry_msgs::TransformStamped& t : m->transforms) rx_.transforms.push_back(t);
  }
  void onImu(const sensor_msgs::ImuConstPtr& m) {
    std::lock_guard<std::mutex> lock(rx_.mutex);
    rx_.imu.push_back(*m);
  }
  void onRange(const sensor_msgs::RangeConstPtr& m) {
    std::lock_guard<std::mutex> lock(rx_.mutex);
    rx_.altimeter.push_back(*m);
  }
  void onClock(const rosgraph_msgs::ClockConstPtr& m) {
    std::lock_guard<std::mutex> lock(rx_.mutex);
    rx_.clock.push_back(m->clock);
  }

  ros::NodeHandle nh_;
  image_transport::ImageTransport transport_{nh_};
  image_transport::Subscriber image_sub_;
  std::vector<ros::Subscriber> subs_;
  std::string dataset_dir_;
  bool live_ = true;
  bool expect_clock_ = false;
  double expect_fx_ = 0.0;
  double timeout_s_ = 60.0;
  std::unique_ptr<Dataset> dataset_;
  std::unique_ptr<Player> reference_;
  Received rx_;
};

TEST_F(PlayerStreamTest, WholeDatasetArrivesInOrderWithExactStampsAndContent) {
  const size_t n = dataset_->size();
  ASSERT_GT(n, 1u);
  ASSERT_TRUE(waitFor([this] { return allConnected(); }, timeout_s_))
      << "the player's topics never connected";

  if (live_) {
    // The player starts paused: nothing can have been published (and lost) before the connections were up.
    EXPECT_EQ(rx_.numImages(), 0u);
    call("/player/resume");
    // Pause mid-stream. Once ~pause returns, no message is being published; the images published so far
    // arrive, then nothing until ~resume.
    ASSERT_TRUE(waitFor([&] { return rx_.numImages() >= n / 3; }, timeout_s_));
    const std_srvs::Trigger::Response paused = call("/player/pause");
    size_t published = 0;
    ASSERT_EQ(std::sscanf(paused.message.c_str(), "paused after %zu images", &published), 1)
        << paused.message;
    EXPECT_GE(published, n / 3);
    EXPECT_LT(published, n) << "the pause came too late to test anything; lower ~rate in the .test";
    EXPECT_TRUE(waitFor([&] { return rx_.numImages() >= published; }, timeout_s_));
    EXPECT_FALSE(waitFor([&] { return rx_.numImages() > published; }, 0.5))
        << "an image arrived while paused";
    call("/player/resume");
  }

  ASSERT_TRUE(waitFor([this] { return streamComplete(); }, timeout_s_))
      << "received " << rx_.images.size() << " images, " << rx_.infos.size() << " camera_info, "
      << rx_.poses.size() << " poses, " << rx_.transforms.size() << " transforms, " << rx_.imu.size()
      << " IMU, " << rx_.altimeter.size() << " altimeter, " << rx_.clock.size() << " clock";

  std::lock_guard<std::mutex> lock(rx_.mutex);
  // Images and camera_info: all, in order, stamps exact, intrinsics and pixels as the reader gives them.
  ASSERT_EQ(rx_.images.size(), n);
  ASSERT_EQ(rx_.infos.size(), n);
  const PinholeCamera& camera = dataset_->camera();
  for (size_t i = 0; i < n; ++i) {
    SCOPED_TRACE("image " + std::to_string(i));
    const sensor_msgs::Image& image = *rx_.images[i];
    EXPECT_EQ(image.header.stamp, expectedImageStamp(i));
    EXPECT_EQ(image.header.frame_id, "camera_optical");
    EXPECT_EQ(image.encoding, "mono8");
    EXPECT_EQ(static_cast<int>(image.width), camera.width());
    EXPECT_EQ(static_cast<int>(image.height), camera.height());
    if (i == 0 || i == n / 2 || i + 1 == n) {
      const cv::Mat expected = dataset_->loadImage(i);
      const cv::Mat actual(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.data.data()),
                           image.step);
      EXPECT_EQ(cv::countNonZero(actual != expected), 0) << "pixels differ";
    }
    const sensor_msgs::CameraInfo& info = *rx_.infos[i];
    EXPECT_EQ(info.header.stamp, image.header.stamp);
    EXPECT_EQ(fromCameraInfo(info), camera);
    if (expect_fx_ > 0.0) {
      EXPECT_EQ(info.K[0], expect_fx_);
    }
  }

  // Ground truth: poses at the image stamps, a growing path, and the tf world -> camera_gt.
  if (dataset_->hasGroundTruth()) {
    ASSERT_EQ(rx_.poses.size(), n);
    ASSERT_EQ(rx_.path_sizes.size(), n);
    ASSERT_EQ(rx_.transforms.size(), n);
    tf2::BufferCore buffer(ros::Duration(1.0e5));
    for (size_t i = 0; i < n; ++i) {
      SCOPED_TRACE("pose " + std::to_string(i));
      EXPECT_EQ(rx_.poses[i].header.stamp, expectedImageStamp(i));
      EXPECT_EQ(rx_.poses[i].header.frame_id, "world");
      const Pose& expected = dataset_->groundTruth()[i].T_world_cam;
      EXPECT_TRUE(fromPoseMsg(rx_.poses[i].pose).isApprox(expected, 1e-9));
      EXPECT_EQ(rx_.path_sizes[i], i + 1);
      EXPECT_EQ(rx_.transforms[i].header.frame_id, "world");
      EXPECT_EQ(rx_.transforms[i].child_frame_id, "camera_gt");
      buffer.setTransform(rx_.transforms[i], "player");
    }
    for (size_t i : {size_t{0}, n / 2, n - 1}) {
      const geometry_msgs::TransformStamped t =
          buffer.lookupTransform("world", "camera_gt", expectedImageStamp(i));
      EXPECT_TRUE(fromTransformMsg(t.transform).isApprox(dataset_->groundTruth()[i].T_world_cam, 1e-9)) << i;
    }
    // Between two images, tf interpolates: the midpoint lies between the two camera centres.
    const geometry_msgs::TransformStamped mid = buffer.lookupTransform(
        "world", "camera_gt", expectedImageStamp(0) + (expectedImageStamp(1) - expectedImageStamp(0)) * 0.5);
    const Eigen::Vector3d c_mid = fromTransformMsg(mid.transform).translation();
    const Eigen::Vector3d c0 = dataset_->groundTruth()[0].T_world_cam.translation();
    const Eigen::Vector3d c1 = dataset_->groundTruth()[1].T_world_cam.translation();
    EXPECT_LT((c_mid - 0.5 * (c0 + c1)).norm(), 1e-6);
  }

  // IMU and altimeter: every sample, in order, with exact stamps.
  ASSERT_EQ(rx_.imu.size(), dataset_->imu().size());
  for (size_t i = 0; i < rx_.imu.size(); ++i) {
    const ImuSample& s = dataset_->imu()[i];
    EXPECT_EQ(rx_.imu[i].header.stamp, reference_->stampOf(s.timestamp_s)) << "imu " << i;
    EXPECT_EQ(rx_.imu[i].angular_velocity.z, s.angular_velocity_radps.z()) << "imu " << i;
    EXPECT_EQ(rx_.imu[i].linear_acceleration.x, s.specific_force_mps2.x()) << "imu " << i;
  }
  ASSERT_EQ(rx_.altimeter.size(), dataset_->altimeter().size());
  for (size_t i = 0; i < rx_.altimeter.size(); ++i) {
    const AltimeterSample& s = dataset_->altimeter()[i];
    EXPECT_EQ(rx_.altimeter[i].header.stamp, reference_->stampOf(s.timestamp_s)) << "altimeter " << i;
    EXPECT_EQ(rx_.altimeter[i].range, static_cast<float>(s.slant_range_m)) << "altimeter " << i;
  }

  // /clock: one tick per message, never backwards, ending at the last message's stamp.
  if (expect_clock_) {
    ASSERT_EQ(rx_.clock.size(), reference_->schedule().size());
    EXPECT_TRUE(std::is_sorted(rx_.clock.begin(), rx_.clock.end()));
    EXPECT_EQ(rx_.clock.front(), reference_->stampOf(reference_->schedule().front().time_s));
    EXPECT_EQ(rx_.clock.back(), reference_->stampOf(reference_->schedule().back().time_s));
  }
}

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_player_node");
  ros::NodeHandle nh;  // keeps the node up for the whole test
  return RUN_ALL_TESTS();
}
