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
/// resolution; issue 12: no_frame_id (images without a frame_id: the fallback camera frame, never an empty
/// child frame), exposure_drop (every image from part 2 on 0.3x as bright: compensated, tracked), distortion
/// (plumb_bob with a D of 3, 6, 100), mono16_bigendian (converted, tracked), absurd_intrinsics (cx = 1e6,
/// 1e9, fx = 1e9: rejected, then good camera_info again), frozen (the last image repeated with fresh stamps:
/// BAD_INPUT "frozen frame"), stamp_jump (one image stamped 5 s, then one a year, ahead: each refused as
/// suspect, the next good frame tracked; then the stream's clock really jumps 3 s: one image refused, the
/// next confirms and is processed, tracking goes on), stamp_restart (the clock goes back 2 s for good: one
/// image refused, the next restarts the trajectory by itself, tracking again); and samples: the fused
/// configuration (vo_bad_input.test config:=config/lunar_fused.yaml) with the dataset's IMU and altimeter
/// streams published before each image (lock step: the nodelet has queued them before the image is sent), the
/// initial state handed over, and bad samples in place of part 2's image: non-finite, REP-145 "no angular
/// velocity", zero, duplicate and out-of-order stamps, NaN, negative,
/// +-Inf ranges; and a 0.2 s gap in the IMU stream before the last 4 images. Checks besides: every bad
/// sample counted (exactly), the status says so, every good sample used, nav/odometry at the IMU rate after
/// the bad samples, the gap reported, metric nav/odometry after it.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseStamped.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/image_encodings.h>

#include <opencv2/imgproc.hpp>

#include "planetary_vo/VoStatus.h"
#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/eval/evaluation_inputs.h"
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
    subs_.push_back(nh_.subscribe("vo/odometry", 1000, &VoBadInputTest::onOdometry, this));
    fused_ = case_ == "samples";
    if (fused_) {
      imu_pub_ = nh_.advertise<sensor_msgs::Imu>("imu", 10000);
      altimeter_pub_ = nh_.advertise<sensor_msgs::Range>("altimeter", 1000);
      initial_state_pub_ = nh_.advertise<nav_msgs::Odometry>("nav/initial_state", 1, true);
      subs_.push_back(nh_.subscribe("nav/odometry", 10000, &VoBadInputTest::onNav, this));
    }
    // The outputs' connections as the manager sees them: a status published before it has accepted ours is
    // lost, and send() would wait for it in vain (see allConnected()).
    manager_ = pnh.param<std::string>("manager", "/vo_manager");
    ASSERT_TRUE(waitFor(
        [&] {
          if (image_pub_.getNumSubscribers() == 0 || info_pub_.getNumSubscribers() == 0) return false;
          if (fused_ && (imu_pub_.getNumSubscribers() == 0 || altimeter_pub_.getNumSubscribers() == 0 ||
                         initial_state_pub_.getNumSubscribers() == 0))
            return false;
          for (const ros::Subscriber& s : subs_)
            if (!publisherSendsTo(manager_, s.getTopic())) return false;
          return true;
        },
        30.0))
        << "the nodelet did not connect";
    if (fused_) {
      // The handover: ground truth at the first image (what the player's ~publish_initial_state sends).
      const std::vector<GroundTruthState> states = readGroundTruthStates(dir + "/groundtruth_state.txt");
      initial_state_pub_.publish(toInitialStateMsg(dataset_->groundTruth().front().T_world_cam,
                                                   states.front().velocity_world_mps,
                                                   makeHeader(stamp(0), "world"), "camera_optical"));
      ASSERT_TRUE(waitFor([&] { return messagesReceived(manager_, "/nav/initial_state") >= 1; }, 10.0));
    }
  }

  /// No callback may run into the members being destroyed (the nodelet may still be publishing).
  void TearDown() override {
    for (ros::Subscriber& s : subs_) s.shutdown();
  }

  /// Every vo/odometry names its child frame (tf refuses an empty one).
  void onOdometry(const nav_msgs::OdometryConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (m->child_frame_id.empty()) ++empty_child_frames_;
  }
  void onNav(const nav_msgs::OdometryConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    nav_.push_back(*m);
  }

  sensor_msgs::Imu imuMsg(const ImuSample& s, double t) const {
    return toImu(s, makeHeader(toStamp(kEpoch, t), "camera_optical"));
  }
  sensor_msgs::Range rangeMsg(double range, double t) const {
    AltimeterSample s;
    s.slant_range_m = range;
    return toRange(s, makeHeader(toStamp(kEpoch, t), "camera_optical"),
                   altimeterSpec(dataset_->sensorSpecification()));
  }
  void publishImu(const sensor_msgs::Imu& m) {
    imu_pub_.publish(m);
    ++imu_sent_;
  }
  void publishRange(const sensor_msgs::Range& m) {
    altimeter_pub_.publish(m);
    ++altimeter_sent_;
  }
  /// The dataset's IMU and altimeter samples up to dataset time t (IMU samples in (skip_from, skip_to]
  /// withheld: a gap), then waits until the nodelet has queued every sample sent so far, so that they are
  /// handled before the next image.
  void publishSamplesUpTo(double t, double skip_from = 0.0, double skip_to = 0.0) {
    const auto& imu = dataset_->imu();
    const auto& alt = dataset_->altimeter();
    for (; next_imu_ < imu.size() && imu[next_imu_].timestamp_s <= t; ++next_imu_) {
      const double ts = imu[next_imu_].timestamp_s;
      if (ts > skip_from && ts <= skip_to) continue;
      publishImu(imuMsg(imu[next_imu_], ts));
      ++good_imu_sent_;
    }
    for (; next_altimeter_ < alt.size() && alt[next_altimeter_].timestamp_s <= t; ++next_altimeter_) {
      publishRange(rangeMsg(alt[next_altimeter_].slant_range_m, alt[next_altimeter_].timestamp_s));
      if (!alt[next_altimeter_].hasReturn()) ++no_range_sent_;
    }
    EXPECT_TRUE(waitFor(
        [&] {
          return messagesReceived(manager_, "/imu") >= int(imu_sent_) &&
                 messagesReceived(manager_, "/altimeter") >= int(altimeter_sent_);
        },
        30.0))
        << "the nodelet did not receive the samples";
  }

  void onStatus(const VoStatusConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    statuses_.push_back(*m);
  }
  void onPose(const geometry_msgs::PoseStampedConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    poses_.push_back(*m);
  }

  ros::Time stamp(size_t i) const { return toStamp(kEpoch, dataset_->timestamp(i)) + stamp_offset_; }
  cv::Mat image(size_t i) const { return dataset_->loadImage(i); }
  sensor_msgs::CameraInfo info(const ros::Time& t, double scale = 1.0) const {
    const PinholeCamera& c = dataset_->camera();
    const PinholeCamera scaled(int(c.width() * scale), int(c.height() * scale), c.fx() * scale,
                               c.fy() * scale, (c.cx() + 0.5) * scale - 0.5, (c.cy() + 0.5) * scale - 0.5,
                               c.distortionModel(), c.distortion());
    return toCameraInfo(scaled, makeHeader(t, "camera_optical"));
  }
  static sensor_msgs::ImagePtr imageMsg(const cv::Mat& m, const ros::Time& t, const std::string& encoding,
                                        const std::string& frame_id = "camera_optical") {
    return cv_bridge::CvImage(makeHeader(t, frame_id), encoding, m).toImageMsg();
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
    if (fused_) publishSamplesUpTo(dataset_->timestamp(i));
    cv::Mat m = image(i);
    if (gain_ != 1.0) m.convertTo(m, CV_8U, gain_);
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
  size_t empty_child_frames_ = 0;
  double gain_ = 1.0;  ///< brightness of the good images (case exposure_drop: 0.3 from part 2 on)
  ros::Duration stamp_offset_{0.0};  ///< added to every stamp (case stamp_jump: the stream's timeline moved)
  // Case "samples".
  bool fused_ = false;
  std::string manager_;
  ros::Publisher imu_pub_, altimeter_pub_, initial_state_pub_;
  size_t next_imu_ = 0, next_altimeter_ = 0;
  size_t imu_sent_ = 0, altimeter_sent_ = 0, good_imu_sent_ = 0, no_range_sent_ = 0;
  std::vector<nav_msgs::Odometry> nav_;
  size_t rejected_imu_ = 0, rejected_altimeter_ = 0;
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
  size_t poses_before = poses_.size();  // the no-jump check starts here (case stamp_restart: later)
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
  } else if (case_ == "distortion") {  // issue 12: cv::undistortPoints asserted and the manager aborted
    for (size_t n : {3u, 6u, 100u}) {
      sensor_msgs::CameraInfo short_d = info(stamp(next));
      short_d.distortion_model = "plumb_bob";
      short_d.D.assign(n, 0.01);
      expectBad(send(imageMsg(image(next), stamp(next), "mono8"), short_d), "plumb_bob distortion needs 5");
      ++next;
    }
  } else if (case_ == "mono16_bigendian") {  // issue 12: cv_bridge gave 2 channels, checkExposure asserted
    for (const size_t end = next + 3; next < end; ++next) {
      cv::Mat m16;
      image(next).convertTo(m16, CV_16U, 256.0);
      sensor_msgs::ImagePtr msg = imageMsg(m16, stamp(next), "mono16");
      for (size_t b = 0; b + 1 < msg->data.size(); b += 2) std::swap(msg->data[b], msg->data[b + 1]);
      msg->is_bigendian = 1;
      const VoStatus s = send(msg, info(stamp(next)));
      EXPECT_TRUE(s.processed) << s.state_name << ": " << s.message;
      EXPECT_NE(s.state, VoStatus::STATE_BAD_INPUT) << s.message;
    }
  } else if (case_ == "absurd_intrinsics") {
    // Issue 12: cx = 1e6 .. 1e9 for some frames corrupted the poses (1e43, non-unit quaternions) for good.
    for (double cx : {1e6, 1e9}) {
      sensor_msgs::CameraInfo absurd = info(stamp(next));
      absurd.K[2] = absurd.P[2] = cx;
      expectBad(send(imageMsg(image(next), stamp(next), "mono8"), absurd), "principal point");
      ++next;
    }
    sensor_msgs::CameraInfo narrow = info(stamp(next));
    narrow.K[0] = narrow.K[4] = narrow.P[0] = narrow.P[5] = 1e9;
    expectBad(send(imageMsg(image(next), stamp(next), "mono8"), narrow), "field of view");
    ++next;
  } else if (case_ == "black") {
    for (const size_t end = next + 3; next < end; ++next)
      expectBad(
          send(imageMsg(cv::Mat::zeros(image(0).size(), CV_8UC1), stamp(next), "mono8"), info(stamp(next))),
          "black");
  } else if (case_ == "no_frame_id") {
    // Issue 12: an image without a frame_id (and no ~camera_frame) gave tf and vo/odometry an empty child
    // frame, which tf refuses. The fallback frame is used and the frames are tracked.
    for (const size_t end = next + 5; next < end; ++next) {
      const VoStatus s = send(imageMsg(image(next), stamp(next), "mono8", ""), info(stamp(next)));
      EXPECT_EQ(s.state, VoStatus::STATE_TRACKING) << s.message;
    }
  } else if (case_ == "exposure_drop") {
    // Issue 12: a sudden 0.3x exposure drop cost 12 LOST frames. From here on every image is 0.3x as bright
    // (part 3 too); the core compensates the step: no frame is refused or lost.
    gain_ = 0.3;
    for (const size_t end = next + 5; next < end; ++next) {
      const VoStatus s = sendGood(next);
      EXPECT_EQ(s.state, VoStatus::STATE_TRACKING) << s.message;
    }
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
  } else if (case_ == "frozen") {
    // Issue 12: a stuck frame buffer (the last image repeated with fresh stamps for 1 s) was tracked as
    // TRACKING with zero motion, then the pose jumped. Each repeat is BAD_INPUT naming the frozen frame; the
    // good frames after it (their stamps moved on meanwhile) track without a jump.
    const cv::Mat stuck = image(next - 1);
    for (const size_t end = next + 10; next < end; ++next)
      expectBad(send(imageMsg(stuck, stamp(next), "mono8"), info(stamp(next))), "frozen frame");
  } else if (case_ == "stamp_jump") {
    // Issue 12: one image stamped 5 s (or a year) ahead was accepted and every later frame refused as
    // "backwards" until vo/reset. The jumped image is refused as suspect; the next, on the old timeline,
    // shows it was an outlier, and tracking goes on.
    for (double ahead_s : {5.0, 365.25 * 86400.0}) {
      const ros::Time ahead = stamp(next) + ros::Duration(ahead_s);
      expectBad(send(imageMsg(image(next), ahead, "mono8"), info(ahead)), "jumped forward");
      ++next;
      const VoStatus s = sendGood(next++);
      EXPECT_NE(s.state, VoStatus::STATE_BAD_INPUT) << s.message;
      EXPECT_NE(s.message.find("ahead was an outlier"), std::string::npos) << s.message;
    }
    // A real jump of the stream's clock (3 s ahead from now on): the first image is refused as suspect, the
    // next confirms the new timeline and is processed (tracking restarts from the current pose), and the
    // good frames after it go on.
    stamp_offset_ = ros::Duration(3.0);
    expectBad(sendGood(next++), "jumped forward");
    const VoStatus confirmed = sendGood(next++);
    EXPECT_TRUE(confirmed.processed) << confirmed.state_name << ": " << confirmed.message;
    EXPECT_NE(confirmed.message.find("next image confirmed it"), std::string::npos) << confirmed.message;
  } else if (case_ == "stamp_restart") {
    // The stream's clock goes back 2 s for good (a restarted bag or camera): the first image is refused as
    // suspect, the next confirms the old-again timeline and the trajectory restarts (as after vo/reset), with
    // a status saying so; no call of vo/reset is needed. The no-jump check starts with the new trajectory.
    stamp_offset_ = ros::Duration(-2.0);
    expectBad(sendGood(next++), "went backwards");
    const ros::Time restart = stamp(next);
    const VoStatus confirmed = sendGood(next++);
    EXPECT_TRUE(confirmed.processed) << confirmed.state_name << ": " << confirmed.message;
    EXPECT_NE(confirmed.message.find("jumped back"), std::string::npos) << confirmed.message;
    EXPECT_NE(confirmed.message.find("trajectory restarts"), std::string::npos) << confirmed.message;
    ASSERT_TRUE(waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          // From the end: the old trajectory has poses with the same stamps (20 frames back).
          for (size_t k = poses_.size(); k-- > 0;)
            if (poses_[k].header.stamp == restart) return poses_before = k + 1, true;
          return false;
        },
        10.0))
        << "no pose for the image that restarted the trajectory";
  } else if (case_ == "dropped") {
    next += 4;  // four frames never arrive
    const VoStatus s = sendGood(next++);
    EXPECT_NE(s.message.find("dropped"), std::string::npos) << s.message;
  } else if (case_ == "resolution") {  // the camera switches to half resolution (image and camera_info agree)
    scale = 0.5;
    const VoStatus s = sendGood(next++, scale);
    EXPECT_TRUE(s.processed);
    EXPECT_NE(s.message.find("camera_info changed"), std::string::npos) << s.message;
  } else if (case_ == "samples") {
    const double t_given = dataset_->timestamp(next - 1);  // every sample up to here is in the pipeline
    const double inf = std::numeric_limits<double>::infinity();
    sensor_msgs::Imu m = imuMsg(dataset_->imu()[0], t_given + 0.0025);
    m.angular_velocity.x = std::nan("");
    publishImu(m);  // non-finite
    m = imuMsg(dataset_->imu()[0], t_given + 0.003);
    m.angular_velocity_covariance[0] = -1.0;
    publishImu(m);  // REP-145: no angular velocity
    m = imuMsg(dataset_->imu()[0], 0.0);
    m.header.stamp = ros::Time();
    publishImu(m);                                             // zero stamp
    publishImu(imuMsg(dataset_->imu()[0], t_given - 0.0025));  // older than what the pipeline has
    publishImu(imuMsg(dataset_->imu()[0], t_given));           // duplicate of a sample already given
    publishImu(imuMsg(dataset_->imu()[0], t_given + 3.15e7));  // a year ahead (issue 12: it pushed every
                                                               // later sample out of the buffer)
    publishRange(rangeMsg(std::nan(""), t_given + 0.01));      // erroneous
    publishRange(rangeMsg(-5.0, t_given + 0.02));              // negative
    publishRange(rangeMsg(-inf, t_given + 0.03));              // REP-117: too close (no range)
    publishRange(rangeMsg(inf, t_given + 0.035));              // no return (no range)
    publishRange(rangeMsg(700.0, t_given - 0.01));             // out of order
    publishRange(rangeMsg(700.0, t_given + 3.15e7));           // a year ahead
    const size_t imu_rejected = 6 + 1, altimeter_rejected = 4, no_range = 2;
    // The next image's samples, one of them twice (a duplicate while buffered), then the image.
    publishSamplesUpTo(dataset_->timestamp(next));
    publishImu(imuMsg(dataset_->imu()[next_imu_ - 1], dataset_->imu()[next_imu_ - 1].timestamp_s));
    const VoStatus s = sendGood(next++);
    EXPECT_NE(s.message.find("IMU sample rejected"), std::string::npos) << s.message;
    EXPECT_NE(s.message.find("altimeter reading rejected"), std::string::npos) << s.message;
    EXPECT_EQ(s.num_imu_rejected, imu_rejected);
    EXPECT_EQ(s.num_altimeter_rejected, altimeter_rejected);
    EXPECT_EQ(s.num_altimeter_no_range, no_range + no_range_sent_);
    no_range_sent_ += no_range;
    rejected_imu_ = imu_rejected;
    rejected_altimeter_ = altimeter_rejected;
  } else {
    FAIL() << "unknown case " << case_;
  }

  VoStatus last;
  bool resumed = false;
  // Case samples: a 0.2 s gap in the IMU stream before the last kGapFrames images.
  constexpr size_t kGapFrames = 4;
  const ros::Time gap_start = stamp(next + kGoodAfter - kGapFrames - 1) + ros::Duration(0.02);
  bool gap_reported = false;
  for (size_t k = 0; k < kGoodAfter; ++k, ++next) {
    if (fused_ && k + kGapFrames >= kGoodAfter) {
      const double from = toDatasetTime(kEpoch, gap_start);
      publishSamplesUpTo(dataset_->timestamp(next), from, from + 0.2);
    }
    last = sendGood(next, scale);
    gap_reported |= last.message.find("IMU gap") != std::string::npos;
    EXPECT_NE(last.state, VoStatus::STATE_BAD_INPUT)
        << "good frame " << next << " rejected: " << last.message;
    resumed |= last.state == VoStatus::STATE_TRACKING || last.state == VoStatus::STATE_RECOVERED;
  }
  EXPECT_TRUE(resumed) << "no pose estimate after the bad input; last: " << last.state_name << " "
                       << last.message;
  if (fused_) {
    // The bad samples did not stop the good ones: every good one was used, the navigation is metric and
    // nav/odometry continues (finite) after them.
    EXPECT_EQ(last.num_imu_rejected, rejected_imu_);
    EXPECT_EQ(last.num_altimeter_rejected, rejected_altimeter_);
    EXPECT_EQ(last.num_imu_used, good_imu_sent_);
    EXPECT_EQ(last.num_altimeter_no_range, no_range_sent_);
    EXPECT_EQ(last.num_altimeter_used, altimeter_sent_ - rejected_altimeter_ - no_range_sent_);
    EXPECT_TRUE(last.metric);
    EXPECT_TRUE(last.initial_state_applied);
    EXPECT_EQ(last.mode, "vision+imu+altimeter");
    std::printf(
        "samples: last status %s, metric %d, inertial %d, IMU %u used / %u rejected, altimeter %u "
        "used / %u without range / %u rejected; message '%s'\n",
        last.state_name.c_str(), last.metric, last.inertial, last.num_imu_used, last.num_imu_rejected,
        last.num_altimeter_used, last.num_altimeter_no_range, last.num_altimeter_rejected,
        last.message.c_str());
    EXPECT_TRUE(gap_reported) << "no status says that the IMU stream had a gap";
    // nav/odometry and vo/status come over separate connections: the last image's may still be on its way.
    const ros::Time last_image = stamp(next - 1);
    EXPECT_TRUE(waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          return !nav_.empty() && nav_.back().header.stamp >= last_image;
        },
        10.0))
        << "no nav/odometry for the last image";
    std::lock_guard<std::mutex> lock(mutex_);
    // After the bad samples and before the gap, at the IMU rate (5 ms); after the gap, on at the image rate.
    std::set<ros::Time> before_gap, after_gap;
    for (const nav_msgs::Odometry& o : nav_) {
      ASSERT_TRUE(fromPoseMsg(o.pose.pose).matrix().allFinite());
      ASSERT_TRUE(std::isfinite(o.twist.twist.linear.x) && std::isfinite(o.pose.covariance[0]));
      if (o.header.stamp > stamp(kGoodBefore + 1) && o.header.stamp <= gap_start)
        before_gap.insert(o.header.stamp);
      if (o.header.stamp > gap_start + ros::Duration(0.2)) after_gap.insert(o.header.stamp);
    }
    const double span = (gap_start - stamp(kGoodBefore + 1)).toSec();
    std::printf(
        "samples: nav/odometry %zu stamps in the %.2f s between the bad samples and the gap, %zu after "
        "the gap\n",
        before_gap.size(), span, after_gap.size());
    EXPECT_GT(double(before_gap.size()), 0.8 * span / 0.005) << "nav/odometry not at the IMU rate";
    EXPECT_GE(after_gap.size(), 2u) << "no navigation output after the gap (images 3 and 4 of the 4)";
  }

  std::lock_guard<std::mutex> lock(mutex_);
  EXPECT_EQ(empty_child_frames_, 0u) << "vo/odometry with an empty child_frame_id";
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
