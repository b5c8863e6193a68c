/// gtest node of the bad-input rostests (vo_bad_input.test, one ctest per ~case). Publishes frames of the
/// rendered Lunar sequence directly on camera/image_raw + camera/camera_info, one at a time in lock step with
/// vo/status (each frame waits for its status: conditions, no sleeps):
///   1. 20 good frames (the VO initialises and tracks),
///   2. the bad input of the case, in place of the next frames of the sequence,
///   3. 25 good frames again.
/// Checks: the status names the problem, the nodelet stays alive and resumes (tracking again at the end),
/// every pose is finite and no step between consecutive poses is a jump (> 5x the largest step per frame of
/// part 1).
///
/// Cases (~case): encoding, info_missing, size_mismatch, bad_intrinsics, black, saturated, stamps, dropped,
/// resolution.

#include <algorithm>
#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseStamped.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/image_encodings.h>

#include <opencv2/imgproc.hpp>

#include "planetary_vo/VoStatus.h"
#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/ros_io/conversions.h"
#include "test_ros_helpers.h"

namespace planetary_vo::ros_io {
namespace {

constexpr size_t kGoodBefore = 20, kGoodAfter = 25;
const ros::Time kEpoch(1000000000, 0);

class VoBadInputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::NodeHandle pnh("~");
    std::string dir;
    ASSERT_TRUE(pnh.getParam("dataset", dir));
    ASSERT_TRUE(pnh.getParam("case", case_));
    dataset_ = std::make_unique<Dataset>(Dataset::open(dir));
    ASSERT_GE(dataset_->size(), kGoodBefore + kGoodAfter + 6);
    image_pub_ = transport_.advertise("camera/image_raw", 10);
    info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("camera/camera_info", 10);
    subs_.push_back(nh_.subscribe("vo/status", 1000, &VoBadInputTest::onStatus, this));
    subs_.push_back(nh_.subscribe("vo/pose", 1000, &VoBadInputTest::onPose, this));
    // The outputs' connections as the manager sees them: a status published before it has accepted ours is
    // lost, and send() would wait for it in vain (see allConnected()).
    const std::string manager = pnh.param<std::string>("manager", "/vo_manager");
    ASSERT_TRUE(waitFor(
        [&] {
          if (image_pub_.getNumSubscribers() == 0 || info_pub_.getNumSubscribers() == 0) return false;
          for (const ros::Subscriber& s : subs_)
            if (!publisherSendsTo(manager, s.getTopic())) return false;
          return true;
        },
        30.0))
        << "the nodelet did not connect";
  }

  void onStatus(const VoStatusConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    statuses_.push_back(*m);
  }
  void onPose(const geometry_msgs::PoseStampedConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    poses_.push_back(*m);
  }

  ros::Time stamp(size_t i) const { return toStamp(kEpoch, dataset_->timestamp(i)); }
  cv::Mat image(size_t i) const { return dataset_->loadImage(i); }
  sensor_msgs::CameraInfo info(const ros::Time& t, double scale = 1.0) const {
    const PinholeCamera& c = dataset_->camera();
    const PinholeCamera scaled(int(c.width() * scale), int(c.height() * scale), c.fx() * scale,
                               c.fy() * scale, (c.cx() + 0.5) * scale - 0.5, (c.cy() + 0.5) * scale - 0.5,
                               c.distortionModel(), c.distortion());
    return toCameraInfo(scaled, makeHeader(t, "camera_optical"));
  }
  static sensor_msgs::ImagePtr imageMsg(const cv::Mat& m, const ros::Time& t, const std::string& encoding) {
    return cv_bridge::CvImage(makeHeader(t, "camera_optical"), encoding, m).toImageMsg();
  }

  /// Publishes one frame and waits for a new status with its stamp; returns that status.
  VoStatus send(const sensor_msgs::ImagePtr& img, const sensor_msgs::CameraInfo& cam) {
    size_t before;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      before = statuses_.size();
    }
    info_pub_.publish(cam);
    image_pub_.publish(img);
    VoStatus found;
    const bool ok = waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          for (size_t k = before; k < statuses_.size(); ++k)
            if (statuses_[k].header.stamp == img->header.stamp) return found = statuses_[k], true;
          return false;
        },
        30.0);
    EXPECT_TRUE(ok) << "no status for the frame at " << img->header.stamp << " (nodelet dead?)";
    return found;
  }
  VoStatus sendGood(size_t i, double scale = 1.0) {
    cv::Mat m = image(i);
    if (scale != 1.0) cv::resize(m, m, cv::Size(), scale, scale, cv::INTER_AREA);
    return send(imageMsg(m, stamp(i), "mono8"), info(stamp(i), scale));
  }
  /// Waits for a watchdog status (zero stamp) whose message contains `text`.
  bool waitWatchdog(const std::string& text) {
    return waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          for (const VoStatus& s : statuses_)
            if (s.header.stamp.isZero() && s.state == VoStatus::STATE_BAD_INPUT &&
                s.message.find(text) != std::string::npos)
              return true;
          return false;
        },
        10.0);
  }

  static void expectBad(const VoStatus& s, const std::string& text) {
    EXPECT_EQ(s.state, VoStatus::STATE_BAD_INPUT) << s.message;
    EXPECT_FALSE(s.processed);
    EXPECT_NE(s.message.find(text), std::string::npos) << "'" << s.message << "' lacks '" << text << "'";
  }

  /// Largest step between consecutive poses so far.
  double maxStep(size_t from, size_t to) {
    std::lock_guard<std::mutex> lock(mutex_);
    double step = 0.0;
    for (size_t k = std::max<size_t>(from, 1); k < std::min(to, poses_.size()); ++k)
      step = std::max(
          step,
          (fromPoseMsg(poses_[k].pose).translation() - fromPoseMsg(poses_[k - 1].pose).translation()).norm());
    return step;
  }

  ros::NodeHandle nh_;
  image_transport::ImageTransport transport_{nh_};
  image_transport::Publisher image_pub_;
  ros::Publisher info_pub_;
  std::vector<ros::Subscriber> subs_;
  std::string case_;
  std::unique_ptr<Dataset> dataset_;
  std::mutex mutex_;
  std::vector<VoStatus> statuses_;
  std::vector<geometry_msgs::PoseStamped> poses_;
};

TEST_F(VoBadInputTest, StaysAliveReportsAndResumes) {
  size_t next = 0;
  if (case_ == "info_missing") {  // images before any camera_info: ignored, and the status says why
    for (; next < 3; ++next) image_pub_.publish(imageMsg(image(next), stamp(next), "mono8"));
    EXPECT_TRUE(waitWatchdog("camera_info")) << "no status about the missing camera_info";
  }
  bool tracked = false;
  for (const size_t end = next + kGoodBefore; next < end; ++next)
    tracked |= sendGood(next).state == VoStatus::STATE_TRACKING;
  ASSERT_TRUE(tracked) << "the VO never tracked on good input";
  const size_t poses_before = poses_.size();
  const double step_before = maxStep(0, poses_before);
  ASSERT_GT(step_before, 0.0);

  double scale = 1.0;  // image scale of the frames after the bad input
  const ros::Time t = stamp(next);
  if (case_ == "encoding") {
    cv::Mat f;
    image(next).convertTo(f, CV_32F, 1.0 / 255.0);
    expectBad(send(imageMsg(f, t, "32FC1"), info(t)), "encoding");
    ++next;
  } else if (case_ == "info_missing") {  // camera_info stops mid-stream, then comes back
    for (const size_t end = next + 3; next < end; ++next)
      image_pub_.publish(imageMsg(image(next), stamp(next), "mono8"));
    EXPECT_TRUE(waitWatchdog("camera_info"));
  } else if (case_ == "size_mismatch") {
    expectBad(send(imageMsg(image(next)(cv::Rect(0, 0, 200, 180)).clone(), t, "mono8"), info(t)), "match");
    ++next;
  } else if (case_ == "bad_intrinsics") {
    sensor_msgs::CameraInfo nan_info = info(t);
    nan_info.K[0] = std::nan("");
    expectBad(send(imageMsg(image(next), t, "mono8"), nan_info), "not finite");
    sensor_msgs::CameraInfo zero_info = info(stamp(++next));
    zero_info.K.fill(0.0);
    expectBad(send(imageMsg(image(next), stamp(next), "mono8"), zero_info), "zero");
    ++next;
  } else if (case_ == "black") {
    for (const size_t end = next + 3; next < end; ++next)
      expectBad(
          send(imageMsg(cv::Mat::zeros(image(0).size(), CV_8UC1), stamp(next), "mono8"), info(stamp(next))),
          "black");
  } else if (case_ == "saturated") {
    for (const size_t end = next + 3; next < end; ++next)
      expectBad(send(imageMsg(cv::Mat(image(0).size(), CV_8UC1, cv::Scalar(255)), stamp(next), "mono8"),
                     info(stamp(next))),
                "saturated");
  } else if (case_ == "stamps") {
    const ros::Time previous = stamp(next - 1), older = stamp(next - 5);
    expectBad(send(imageMsg(image(next), previous, "mono8"), info(previous)), "duplicate");
    expectBad(send(imageMsg(image(next), older, "mono8"), info(older)), "backwards");
    ++next;
  } else if (case_ == "dropped") {
    next += 4;  // four frames never arrive
    const VoStatus s = sendGood(next++);
    EXPECT_NE(s.message.find("dropped"), std::string::npos) << s.message;
  } else if (case_ == "resolution") {  // the camera switches to half resolution (image and camera_info agree)
    scale = 0.5;
    const VoStatus s = sendGood(next++, scale);
    EXPECT_TRUE(s.processed);
    EXPECT_NE(s.message.find("camera_info changed"), std::string::npos) << s.message;
  } else {
    FAIL() << "unknown case " << case_;
  }

  VoStatus last;
  bool resumed = false;
  for (size_t k = 0; k < kGoodAfter; ++k, ++next) {
    last = sendGood(next, scale);
    EXPECT_NE(last.state, VoStatus::STATE_BAD_INPUT)
        << "good frame " << next << " rejected: " << last.message;
    resumed |= last.state == VoStatus::STATE_TRACKING || last.state == VoStatus::STATE_RECOVERED;
  }
  EXPECT_TRUE(resumed) << "no pose estimate after the bad input; last: " << last.state_name << " "
                       << last.message;

  std::lock_guard<std::mutex> lock(mutex_);
  for (size_t k = 0; k < poses_.size(); ++k) {
    const Pose T = fromPoseMsg(poses_[k].pose);
    ASSERT_TRUE(T.matrix().allFinite()) << "non-finite pose " << k;
    if (k > 0 && k >= poses_before) {
      const double step = (T.translation() - fromPoseMsg(poses_[k - 1].pose).translation()).norm();
      const double frames = std::max(
          1.0, (poses_[k].header.stamp - poses_[k - 1].header.stamp).toSec() / (stamp(1) - stamp(0)).toSec());
      EXPECT_LT(step, 5.0 * step_before * frames)
          << "jump of " << step << " at pose " << k << " (largest step " << step_before
          << " before the bad input)";
    }
  }
}

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) { return planetary_vo::ros_io::runRosTests(argc, argv, "test_vo_bad_input"); }
