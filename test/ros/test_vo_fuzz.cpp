/// gtest node of the fuzz rostest vo_fuzz.test (issue 12, fault containment). Streams the rendered Lunar
/// sequence into the VO nodelet (camera + IMU + altimeter configuration, state handed over), one good frame
/// at a time in lock step with vo/status, and between two good frames a few randomly malformed messages:
///   - sensor_msgs/Image: unknown or wrong encodings, truncated / padded data, wrong step, zero / huge /
///     mismatched width and height, bit flips, byte-order flag, colour and 16-bit variants, odd consistent
///     resolutions (down to 1 pixel), black and saturated frames, frame ids, stamps zero / duplicate /
///     backwards / far ahead (up to the end of ros::Time);
///   - sensor_msgs/CameraInfo (with a good image): NaN / Inf / huge / zero / negative K, D and P entries,
///     D of the wrong length, unknown distortion models, zero / huge width and height, R, binning, ROI;
///   - sensor_msgs/Imu: NaN / Inf / huge rates and accelerations, covariance[0] = -1 (REP-145 "no data")
///     and other covariances, NaN orientation, stamps zero / duplicate / backwards / far ahead;
///   - sensor_msgs/Range: NaN / +-Inf / negative / out-of-[min, max] ranges, bad limits, field of view and
///     radiation types, stamps zero / duplicate / backwards / far ahead.
/// Checks:
///   - the nodelet stays alive: every message case gets its vo/status, every good frame after a case is
///     processed (never BAD_INPUT), and the manager still answers at the end;
///   - every pose published on vo/pose, vo/odometry and nav/odometry is finite with a unit quaternion (and
///     the odometry twist and covariance are finite);
///   - every rejection has a reason: a BAD_INPUT status has a non-empty message, a status whose IMU or
///     altimeter rejection counter went up names the reason, the cases that must be rejected are (a
///     malformed image with BAD_INPUT on its stamp, a malformed sample counted as rejected).
/// Seeded: $PLANETARY_VO_FUZZ_SEED (else ~seed, else the fixed default below), printed at the start, so a
/// failure reproduces with `PLANETARY_VO_FUZZ_SEED=<seed> ctest -R vo_fuzz`. ~cases_per_frame sets how many
/// cases come between two good frames (default 5: about 270 cases over the 6 s sequence).

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <random>
#include <sstream>
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

const ros::Time kEpoch(1000000000, 0);
constexpr uint64_t kDefaultSeed = 20261127;
constexpr size_t kGoodFirst = 6;  ///< good frames before the first case (the VO initialises)
constexpr size_t kGoodLast = 4;   ///< good frames after the last case
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

/// The random source of every case, and the "wild" values the mutations draw from.
class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed) {}
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(engine_); }
  uint64_t integer64(uint64_t lo, uint64_t hi) {
    return std::uniform_int_distribution<uint64_t>(lo, hi)(engine_);
  }
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(engine_); }
  bool chance(double p) { return uniform(0.0, 1.0) < p; }
  template <class T>
  const T& pick(const std::vector<T>& values) {
    return values[size_t(integer(0, int(values.size()) - 1))];
  }
  /// Non-finite, huge, tiny, zero, negative or merely odd.
  double wild() {
    return pick<double>({kNaN, kInf, -kInf, 0.0, -0.0, -1.0, 1e300, -1e300, DBL_MAX, -DBL_MAX, 1e-300,
                         DBL_TRUE_MIN, 1e9, -1e9, 1e6, uniform(-1e3, 1e3)});
  }
  /// Only non-finite.
  double nonFinite() { return pick<double>({kNaN, kInf, -kInf}); }

 private:
  std::mt19937_64 engine_;
};

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

bool finite(double v) { return std::isfinite(v); }

/// Whether `message` has `prefix` followed by a reason (the nodelet appends "<prefix><why> (N so far)").
bool namesReason(const std::string& message, const std::string& prefix) {
  const size_t at = message.find(prefix);
  if (at == std::string::npos) return false;
  const size_t reason = at + prefix.size();
  return reason < message.size() && message[reason] != ' ' && message[reason] != '(';
}

/// What a case must give.
enum class Expect {
  kReject,  ///< BAD_INPUT (image) / counted as rejected (sample), with a reason
  kAny,     ///< may be accepted or rejected; a rejection still needs a reason
};

/// One malformed camera frame: the image and camera_info as published.
struct FrameCase {
  sensor_msgs::ImagePtr image;
  sensor_msgs::CameraInfo info;
  Expect expect = Expect::kAny;
  std::string what;
};

class VoFuzzTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::NodeHandle pnh("~");
    std::string dir;
    ASSERT_TRUE(pnh.getParam("dataset", dir));
    seed_ = uint64_t(pnh.param<int>("seed", int(kDefaultSeed)));
    if (const char* env = std::getenv("PLANETARY_VO_FUZZ_SEED"); env && *env) seed_ = std::stoull(env);
    cases_per_frame_ = pnh.param<int>("cases_per_frame", 5);
    std::printf("vo_fuzz: seed %llu (set PLANETARY_VO_FUZZ_SEED to reproduce or vary), %d cases per frame\n",
                static_cast<unsigned long long>(seed_), cases_per_frame_);
    std::fflush(stdout);
    rng_ = std::make_unique<Rng>(seed_);
    dataset_ = std::make_unique<Dataset>(Dataset::open(dir));
    ASSERT_GE(dataset_->size(), kGoodFirst + kGoodLast + 10);
    manager_ = pnh.param<std::string>("manager", "/vo_manager");
    image_pub_ = transport_.advertise("camera/image_raw", 10);
    info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("camera/camera_info", 10);
    imu_pub_ = nh_.advertise<sensor_msgs::Imu>("imu", 10000);
    altimeter_pub_ = nh_.advertise<sensor_msgs::Range>("altimeter", 1000);
    initial_state_pub_ = nh_.advertise<nav_msgs::Odometry>("nav/initial_state", 1, true);
    subs_.push_back(nh_.subscribe("vo/status", 10000, &VoFuzzTest::onStatus, this));
    subs_.push_back(nh_.subscribe("vo/pose", 10000, &VoFuzzTest::onPose, this));
    subs_.push_back(nh_.subscribe("vo/odometry", 10000, &VoFuzzTest::onVoOdometry, this));
    subs_.push_back(nh_.subscribe("nav/odometry", 100000, &VoFuzzTest::onNavOdometry, this));
    ASSERT_TRUE(waitFor(
        [&] {
          if (image_pub_.getNumSubscribers() == 0 || info_pub_.getNumSubscribers() == 0 ||
              imu_pub_.getNumSubscribers() == 0 || altimeter_pub_.getNumSubscribers() == 0 ||
              initial_state_pub_.getNumSubscribers() == 0)
            return false;
          for (const ros::Subscriber& s : subs_)
            if (!publisherSendsTo(manager_, s.getTopic())) return false;
          return true;
        },
        60.0))
        << "the nodelet did not connect";
    const std::vector<GroundTruthState> states = readGroundTruthStates(dir + "/groundtruth_state.txt");
    initial_state_pub_.publish(toInitialStateMsg(dataset_->groundTruth().front().T_world_cam,
                                                 states.front().velocity_world_mps,
                                                 makeHeader(stamp(0), "world"), "camera_optical"));
    ASSERT_TRUE(waitFor([&] { return messagesReceived(manager_, "/nav/initial_state") >= 1; }, 30.0));
  }

  void TearDown() override {
    for (ros::Subscriber& s : subs_) s.shutdown();
  }

  // ---- outputs -------------------------------------------------------------------------------------------
  void onStatus(const VoStatusConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    statuses_.push_back(*m);
  }
  /// A pose must be finite with a unit quaternion; a violation is kept for the end of the test.
  void checkPose(const char* topic, const ros::Time& stamp, const geometry_msgs::Pose& p) {
    const auto& q = p.orientation;
    const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    if (!finite(p.position.x) || !finite(p.position.y) || !finite(p.position.z) ||
        !(std::abs(norm - 1.0) < 1e-6))
      violations_.push_back(std::string(topic) + " at " + num(stamp.toSec()) + ": position (" +
                            num(p.position.x) + ", " + num(p.position.y) + ", " + num(p.position.z) +
                            "), |q| = " + num(norm));
  }
  void checkOdometry(const char* topic, const nav_msgs::Odometry& m) {
    checkPose(topic, m.header.stamp, m.pose.pose);
    const auto& v = m.twist.twist;
    std::string bad;
    if (!finite(v.linear.x) || !finite(v.linear.y) || !finite(v.linear.z))
      bad += " linear velocity (" + num(v.linear.x) + ", " + num(v.linear.y) + ", " + num(v.linear.z) + ")";
    if (!finite(v.angular.x) || !finite(v.angular.y) || !finite(v.angular.z))
      bad +=
          " angular velocity (" + num(v.angular.x) + ", " + num(v.angular.y) + ", " + num(v.angular.z) + ")";
    for (size_t i = 0; i < 36; ++i) {
      if (!finite(m.pose.covariance[i]))
        bad += " pose covariance[" + std::to_string(i) + "] " + num(m.pose.covariance[i]);
      if (!finite(m.twist.covariance[i]))
        bad += " twist covariance[" + std::to_string(i) + "] " + num(m.twist.covariance[i]);
    }
    if (!bad.empty()) {
      std::ostringstream stamp;
      stamp << m.header.stamp;
      violations_.push_back(std::string(topic) + " at " + stamp.str() + ": non-finite" + bad.substr(0, 400));
    }
  }
  void onPose(const geometry_msgs::PoseStampedConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++num_poses_;
    checkPose("vo/pose", m->header.stamp, m->pose);
  }
  void onVoOdometry(const nav_msgs::OdometryConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++num_odometry_;
    checkOdometry("vo/odometry", *m);
  }
  void onNavOdometry(const nav_msgs::OdometryConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++num_nav_;
    checkOdometry("nav/odometry", *m);
  }

  // ---- inputs --------------------------------------------------------------------------------------------
  ros::Time stamp(size_t i) const { return toStamp(kEpoch, dataset_->timestamp(i)); }
  sensor_msgs::CameraInfo info(const ros::Time& t) const {
    return toCameraInfo(dataset_->camera(), makeHeader(t, "camera_optical"));
  }
  static sensor_msgs::ImagePtr imageMsg(const cv::Mat& m, const ros::Time& t, const std::string& encoding) {
    return cv_bridge::CvImage(makeHeader(t, "camera_optical"), encoding, m).toImageMsg();
  }
  /// Image i with a little noise: never a frozen copy of the good frame next to it.
  cv::Mat noisyImage(size_t i) {
    cv::Mat m = dataset_->loadImage(i), noise(m.size(), CV_16SC1);
    cv::randu(noise, cv::Scalar(-3), cv::Scalar(4));
    cv::Mat out;
    cv::add(m, noise, out, cv::noArray(), CV_8U);
    return out;
  }

  /// Publishes one frame and waits for the status with its stamp. False (and a failure) when none comes.
  bool send(const sensor_msgs::ImagePtr& img, const sensor_msgs::CameraInfo& cam, VoStatus* status) {
    size_t before;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      before = statuses_.size();
    }
    info_pub_.publish(cam);
    image_pub_.publish(img);
    const bool ok = waitFor(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          for (size_t k = before; k < statuses_.size(); ++k)
            if (statuses_[k].header.stamp == img->header.stamp) return *status = statuses_[k], true;
          return false;
        },
        60.0);
    EXPECT_TRUE(ok) << "no vo/status for the frame stamped " << img->header.stamp << " (nodelet dead?)";
    return ok;
  }

  /// Publishes samples in order and waits until the nodelet has queued them all.
  void publishSamples(std::vector<std::pair<double, std::function<void()>>>* queue) {
    std::stable_sort(queue->begin(), queue->end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (auto& [t, publish] : *queue) publish();
    queue->clear();
    EXPECT_TRUE(waitFor(
        [&] {
          return messagesReceived(manager_, "/imu") >= int(imu_sent_) &&
                 messagesReceived(manager_, "/altimeter") >= int(altimeter_sent_);
        },
        60.0))
        << "the nodelet did not receive the samples";
  }

  /// The dataset's samples in (from, to] (dataset time) into the queue.
  void queueGoodSamples(double from, double to,
                        std::vector<std::pair<double, std::function<void()>>>* queue) {
    const SensorSpecification& spec = dataset_->sensorSpecification();
    for (const ImuSample& s : dataset_->imu())
      if (s.timestamp_s > from && s.timestamp_s <= to)
        queue->emplace_back(s.timestamp_s, [this, s, spec] {
          imu_pub_.publish(
              toImu(s, makeHeader(toStamp(kEpoch, s.timestamp_s), "camera_optical"), imuNoiseSpec(spec)));
          ++imu_sent_;
          ++good_imu_sent_;
        });
    for (const AltimeterSample& s : dataset_->altimeter())
      if (s.timestamp_s > from && s.timestamp_s <= to)
        queue->emplace_back(s.timestamp_s, [this, s, spec] {
          altimeter_pub_.publish(
              toRange(s, makeHeader(toStamp(kEpoch, s.timestamp_s), "camera_optical"), altimeterSpec(spec)));
          ++altimeter_sent_;
          ++good_altimeter_sent_;
        });
  }

  /// The stamp of the last good sample of `samples` at or before t (given to the pipeline with the last good
  /// frame), or -1.
  template <class Sample>
  static double lastStampUpTo(const std::vector<Sample>& samples, double t) {
    double last = -1.0;
    for (const Sample& s : samples)
      if (s.timestamp_s <= t) last = s.timestamp_s;
    return last;
  }

  /// A stamp mutation of a sample at dataset time t: zero, duplicate of the last good sample given to the
  /// pipeline (at last_good_t), backwards, far ahead.
  /// far_ahead counts the stamps far ahead (such a sample may wait in the nodelet's buffer for good).
  ros::Time mutatedSampleStamp(double t, double last_good_t, std::string* what, bool* must_reject,
                               size_t* far_ahead) {
    switch (rng_->integer(0, 3)) {
      case 0:
        *what = "stamp zero";
        *must_reject = true;
        return ros::Time();
      case 1:
        *what = "stamp duplicate of the last sample given";
        *must_reject = last_good_t >= 0.0;
        return toStamp(kEpoch, std::max(0.0, last_good_t));
      case 2: {
        const double back = rng_->pick<double>({0.01, 0.5, 3.0, 1e5});
        *what = "stamp " + num(back) + " s backwards";
        return toStamp(kEpoch, t) - ros::Duration(back);
      }
      default: {
        const uint32_t sec = uint32_t(rng_->integer64(uint64_t(kEpoch.sec) + 10, 4294967295ull));
        *what = "stamp far ahead (" + std::to_string(sec) + " s)";
        ++*far_ahead;
        return ros::Time(sec, 0);
      }
    }
  }

  /// A malformed IMU sample at dataset time t (between two good ones).
  void queueImuCase(double t, double last_good_t,
                    std::vector<std::pair<double, std::function<void()>>>* queue) {
    ImuSample s;
    s.timestamp_s = t;
    s.angular_velocity_radps = Eigen::Vector3d(0.001, -0.002, 0.0005);
    s.specific_force_mps2 = Eigen::Vector3d(0.0, 0.0, 1.62);
    sensor_msgs::Imu m = toImu(s, makeHeader(toStamp(kEpoch, t), "camera_optical"),
                               imuNoiseSpec(dataset_->sensorSpecification()));
    bool must_reject = false;
    std::string what;
    double* fields[6] = {&m.angular_velocity.x,    &m.angular_velocity.y,    &m.angular_velocity.z,
                         &m.linear_acceleration.x, &m.linear_acceleration.y, &m.linear_acceleration.z};
    switch (rng_->integer(0, 7)) {
      case 0: {
        const int i = rng_->integer(0, 5);
        *fields[i] = rng_->nonFinite();
        what = "field " + std::to_string(i) + " = " + num(*fields[i]);
        must_reject = true;
        break;
      }
      case 1: {
        const int i = rng_->integer(0, 5);
        *fields[i] = rng_->pick<double>({1e300, -1e300, DBL_MAX, 1e9, -1e6, 1e-300});
        what = "field " + std::to_string(i) + " = " + num(*fields[i]);
        break;
      }
      case 2:
        (rng_->chance(0.5) ? m.angular_velocity_covariance : m.linear_acceleration_covariance)[0] = -1.0;
        what = "covariance[0] = -1 (REP-145: no data)";
        must_reject = true;
        break;
      case 3: {
        auto& c = rng_->chance(0.5) ? m.angular_velocity_covariance : m.linear_acceleration_covariance;
        const double v = rng_->wild();
        for (int i : {0, 4, 8})
          if (rng_->chance(0.7)) c[size_t(i)] = v;
        what = "covariance diagonal " + num(v);
        if (c[0] == -1.0) must_reject = true;
        break;
      }
      case 4:
        m.orientation.x = rng_->wild();
        m.orientation_covariance[0] = rng_->pick<double>({-1.0, 0.0, kNaN});
        what = "orientation " + num(m.orientation.x);
        break;
      case 5:
        m.header.stamp = mutatedSampleStamp(t, last_good_t, &what, &must_reject, &imu_far_ahead_);
        break;
      case 6:
        for (double* f : fields) *f = rng_->wild();
        what = "every field wild";
        for (double* f : fields) must_reject |= !finite(*f);
        break;
      default:
        m.header.frame_id = rng_->pick<std::string>({"", "world", std::string(300, 'x'), "/"});
        what = "frame_id '" + m.header.frame_id.substr(0, 10) + "'";
        break;
    }
    must_imu_rejects_ += must_reject ? 1 : 0;
    log("IMU", what, must_reject);
    queue->emplace_back(t, [this, m] {
      imu_pub_.publish(m);
      ++imu_sent_;
    });
  }

  /// The defects the fuzz test found, as fixed cases at the first fuzzed frame (whatever the seed).
  void queueRegressionCases(double t, std::vector<std::pair<double, std::function<void()>>>* queue) {
    // Seed 20261127: a specific force of -1e300 m/s^2 was accepted (finite) and made the inertial state
    // infinite for good: every later image refused ("IMU propagation: non-finite state or gravity").
    // InertialAiding::add now refuses a sample beyond any IMU's range.
    const SensorSpecification& spec = dataset_->sensorSpecification();
    for (const auto& [w, a] :
         {std::make_pair(Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(0.0, 0.0, -1e300)),
          std::make_pair(Eigen::Vector3d(1e6, 0.0, 0.0), Eigen::Vector3d(0.0, 0.0, 1.62))}) {
      ImuSample s;
      s.timestamp_s = t;
      s.angular_velocity_radps = w;
      s.specific_force_mps2 = a;
      t += 0.005;
      const sensor_msgs::Imu m =
          toImu(s, makeHeader(toStamp(kEpoch, s.timestamp_s), "camera_optical"), imuNoiseSpec(spec));
      ++must_imu_rejects_;
      log("IMU",
          "regression: angular rate " + num(w.norm()) + " rad/s, specific force " + num(a.norm()) + " m/s^2",
          true);
      queue->emplace_back(s.timestamp_s, [this, m] {
        imu_pub_.publish(m);
        ++imu_sent_;
      });
    }
  }

  /// A malformed altimeter reading at dataset time t.
  void queueRangeCase(double t, double last_good_t,
                      std::vector<std::pair<double, std::function<void()>>>* queue) {
    AltimeterSample s;
    s.timestamp_s = t;
    s.slant_range_m = 500.0;
    const AltimeterSpec spec = altimeterSpec(dataset_->sensorSpecification());
    sensor_msgs::Range m = toRange(s, makeHeader(toStamp(kEpoch, t), "camera_optical"), spec);
    bool must_reject = false;
    std::string what;
    switch (rng_->integer(0, 6)) {
      case 0:
        m.range = rng_->pick<float>({std::numeric_limits<float>::quiet_NaN(), -1.0f, -1e30f, -0.001f,
                                     -std::numeric_limits<float>::max()});
        what = "range " + num(m.range);
        must_reject = true;
        break;
      case 1:
        m.range = rng_->pick<float>(
            {std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(), 0.0f, 1e-30f,
             std::numeric_limits<float>::max(), m.min_range * 0.5f, m.max_range * 2.0f});
        what = "range " + num(m.range) + " (no range or out of [min, max])";
        break;
      case 2: {
        float* limits[3] = {&m.min_range, &m.max_range, &m.field_of_view};
        const int i = rng_->integer(0, 2);
        *limits[i] = float(rng_->wild());
        what = std::string(i == 0   ? "min_range"
                           : i == 1 ? "max_range"
                                    : "field_of_view") +
               " " + num(*limits[i]);
        break;
      }
      case 3:
        std::swap(m.min_range, m.max_range);
        what = "min_range > max_range";
        break;
      case 4:
        m.radiation_type = uint8_t(rng_->integer(2, 255));
        what = "radiation_type " + std::to_string(m.radiation_type);
        break;
      case 5:
        m.header.stamp = mutatedSampleStamp(t, last_good_t, &what, &must_reject, &altimeter_far_ahead_);
        break;
      default:
        m.range = float(rng_->wild());
        m.min_range = float(rng_->wild());
        m.max_range = float(rng_->wild());
        what = "range " + num(m.range) + " in [" + num(m.min_range) + ", " + num(m.max_range) + "]";
        must_reject = std::isnan(m.range) || (std::isfinite(m.range) && m.range < 0.0f);
        break;
    }
    must_altimeter_rejects_ += must_reject ? 1 : 0;
    log("Range", what, must_reject);
    queue->emplace_back(t, [this, m] {
      altimeter_pub_.publish(m);
      ++altimeter_sent_;
    });
  }

  /// A malformed image (with a good camera_info) of image i at stamp t.
  FrameCase imageCase(size_t i, const ros::Time& t) {
    namespace enc = sensor_msgs::image_encodings;
    FrameCase c;
    const cv::Mat gray = noisyImage(i);
    c.image = imageMsg(gray, t, "mono8");
    c.info = info(t);
    sensor_msgs::Image& m = *c.image;
    switch (rng_->integer(0, 12)) {
      case 0:
        m.encoding = rng_->pick<std::string>({"32FC1", "16UC3", "yuv422", "bayer_rggb8", "", "MONO8", "rgb16",
                                              "8UC1 ", "mono8\n", std::string(200, 'm')});
        c.what = "encoding '" + m.encoding.substr(0, 12) + "'";
        c.expect = Expect::kReject;
        break;
      case 1:  // a supported encoding whose pixels need more bytes than mono8 gives
        m.encoding = rng_->pick<std::string>({"rgb8", "bgr8", "rgba8", "bgra8", "mono16"});
        c.what = "encoding " + m.encoding + " with mono8 data";
        c.expect = Expect::kReject;
        break;
      case 2:
        m.data.resize(size_t(rng_->integer(0, int(m.data.size()) - 1)));
        c.what = "data truncated to " + std::to_string(m.data.size()) + " bytes";
        c.expect = Expect::kReject;
        break;
      case 3:
        m.data.resize(m.data.size() + size_t(rng_->integer(1, 100000)), 7);
        c.what = "data padded to " + std::to_string(m.data.size()) + " bytes";
        break;
      case 4:
        m.step = uint32_t(rng_->integer(0, int(m.width) - 1));
        c.what = "step " + std::to_string(m.step) + " < width";
        c.expect = Expect::kReject;
        break;
      case 5: {  // step larger than a row: padded rows when the data follow, else too little data
        const uint32_t step = m.width + uint32_t(rng_->integer(1, 64));
        if (rng_->chance(0.5)) {
          std::vector<uint8_t> padded(size_t(step) * m.height, 0);
          for (uint32_t r = 0; r < m.height; ++r)
            std::copy_n(m.data.begin() + size_t(r) * m.width, m.width, padded.begin() + size_t(r) * step);
          m.data = padded;
          c.what = "step " + std::to_string(step) + " with padded rows";
        } else {
          c.what = "step " + std::to_string(step) + " without the data";
          c.expect = Expect::kReject;
        }
        m.step = step;
        break;
      }
      case 6: {
        uint32_t* dim = rng_->chance(0.5) ? &m.width : &m.height;
        *dim = rng_->pick<uint32_t>({0u, 1u << 16, 1u << 31, 0x7fffffffu, 0xffffffffu});
        if (rng_->chance(0.3)) m.step = rng_->pick<uint32_t>({0u, 0xffffffffu, m.width});
        c.what = "size " + std::to_string(m.width) + "x" + std::to_string(m.height) + ", step " +
                 std::to_string(m.step);
        c.expect = Expect::kReject;
        break;
      }
      case 7: {  // a consistent image of another size, camera_info unchanged
        const cv::Mat crop =
            gray(cv::Rect(0, 0, rng_->integer(1, gray.cols), rng_->integer(1, gray.rows - 1))).clone();
        c.image = imageMsg(crop, t, "mono8");
        c.what =
            "image " + std::to_string(crop.cols) + "x" + std::to_string(crop.rows) + " against camera_info";
        c.expect = Expect::kReject;
        break;
      }
      case 8: {  // image and camera_info agree on an odd resolution (down to one pixel)
        const int w = rng_->pick<int>({1, 2, 3, 7, 16, 33, rng_->integer(1, 600)});
        const int h = rng_->pick<int>({1, 2, 5, 31, rng_->integer(1, 600)});
        cv::Mat resized;
        cv::resize(gray, resized, cv::Size(w, h), 0, 0, cv::INTER_AREA);
        c.image = imageMsg(resized, t, "mono8");
        const PinholeCamera& cam = dataset_->camera();
        const double sx = double(w) / cam.width(), sy = double(h) / cam.height();
        c.info =
            toCameraInfo(PinholeCamera(w, h, cam.fx() * sx, cam.fy() * sy, (cam.cx() + 0.5) * sx - 0.5,
                                       (cam.cy() + 0.5) * sy - 0.5, cam.distortionModel(), cam.distortion()),
                         makeHeader(t, "camera_optical"));
        c.what = "image and camera_info at " + std::to_string(w) + "x" + std::to_string(h);
        break;
      }
      case 9: {  // bit flips, byte-order flag
        const int flips = rng_->integer(1, 2000);
        for (int k = 0; k < flips; ++k)
          m.data[size_t(rng_->integer(0, int(m.data.size()) - 1))] ^= uint8_t(1 << rng_->integer(0, 7));
        m.is_bigendian = uint8_t(rng_->integer(0, 255));
        c.what = std::to_string(flips) + " bit flips, is_bigendian " + std::to_string(m.is_bigendian);
        break;
      }
      case 10: {  // a correct colour or 16-bit image, in either byte order
        const std::string e = rng_->pick<std::string>({"rgb8", "bgr8", "rgba8", "bgra8", "mono16"});
        cv::Mat converted;
        if (e == "mono16") {
          gray.convertTo(converted, CV_16U, 256.0);
        } else {
          cv::cvtColor(gray, converted, e.size() == 5 ? cv::COLOR_GRAY2BGRA : cv::COLOR_GRAY2BGR);
        }
        c.image = imageMsg(converted, t, e);
        if (e == "mono16" && rng_->chance(0.5)) {  // big-endian, as the message says
          sensor_msgs::Image& b = *c.image;
          b.is_bigendian = 1;
          for (size_t k = 0; k + 1 < b.data.size(); k += 2) std::swap(b.data[k], b.data[k + 1]);
        }
        c.what = "valid " + e + (c.image->is_bigendian ? " big-endian" : "");
        break;
      }
      case 11:
        c.image =
            imageMsg(cv::Mat(gray.size(), CV_8UC1, cv::Scalar(rng_->chance(0.5) ? 0 : 255)), t, "mono8");
        c.what = "black or saturated frame";
        c.expect = Expect::kReject;
        break;
      default:
        m.header.frame_id = rng_->pick<std::string>({"", "world", "/", std::string(500, 'c'), "a b"});
        c.info.header.frame_id = m.header.frame_id;
        c.what = "frame_id '" + m.header.frame_id.substr(0, 10) + "'";
        break;
    }
    return c;
  }

  /// A malformed camera_info (with a good image) of image i at stamp t.
  FrameCase infoCase(size_t i, const ros::Time& t) {
    FrameCase c;
    c.image = imageMsg(noisyImage(i), t, "mono8");
    c.info = info(t);
    sensor_msgs::CameraInfo& m = c.info;
    switch (rng_->integer(0, 9)) {
      case 0: {  // fx, fy, cx or cy
        const size_t k = rng_->pick<size_t>({0, 4, 2, 5});
        m.K[k] = rng_->wild();
        c.what = "K[" + std::to_string(k) + "] = " + num(m.K[k]);
        const bool focal = k == 0 || k == 4;
        if (!finite(m.K[k]) || (focal && m.K[k] <= 0.0)) c.expect = Expect::kReject;
        break;
      }
      case 1: {
        const size_t k = rng_->pick<size_t>({1, 3, 6, 7, 8});
        m.K[k] = rng_->wild();
        c.what = "K[" + std::to_string(k) + "] = " + num(m.K[k]);
        break;
      }
      case 2:
        for (double& k : m.K) k = rng_->wild();
        c.what = "every K entry wild";
        if (!finite(m.K[0]) || !finite(m.K[4]) || !finite(m.K[2]) || !finite(m.K[5]) || m.K[0] <= 0.0 ||
            m.K[4] <= 0.0)
          c.expect = Expect::kReject;
        break;
      case 3: {
        m.distortion_model = "plumb_bob";
        m.D.assign(5, 0.0);
        const size_t k = size_t(rng_->integer(0, 4));
        m.D[k] = rng_->wild();
        c.what = "D[" + std::to_string(k) + "] = " + num(m.D[k]);
        if (!finite(m.D[k])) c.expect = Expect::kReject;
        break;
      }
      case 4: {
        m.distortion_model = rng_->pick<std::string>({"plumb_bob", "rational_polynomial", "equidistant"});
        const size_t n = rng_->pick<size_t>({1, 3, 4, 5, 6, 8, 14, 1000});
        m.D.assign(n, 0.0);
        for (double& d : m.D) d = rng_->uniform(-0.01, 0.01);
        const size_t needed = m.distortion_model == "plumb_bob"     ? 5
                              : m.distortion_model == "equidistant" ? 4
                                                                    : 8;
        c.what = m.distortion_model + " with " + std::to_string(n) + " coefficients";
        if (n != needed) c.expect = Expect::kReject;
        break;
      }
      case 5:
        m.distortion_model = rng_->pick<std::string>(
            {"", "fisheye", "none", "PLUMB_BOB", "kannala_brandt", std::string(300, 'd')});
        m.D.assign(size_t(rng_->integer(1, 8)), 0.001);
        c.what = "distortion model '" + m.distortion_model.substr(0, 12) + "'";
        // Unknown models are refused; "" and "none" with these non-zero coefficients too (an ideal camera
        // only when D is all zeros).
        c.expect = Expect::kReject;
        break;
      case 6: {
        const size_t k = size_t(rng_->integer(0, 11));
        m.P[k] = rng_->wild();
        if (rng_->chance(0.5)) m.R[size_t(rng_->integer(0, 8))] = rng_->wild();
        c.what = "P[" + std::to_string(k) + "] = " + num(m.P[k]) + " (and R)";
        break;
      }
      case 7: {
        uint32_t* dim = rng_->chance(0.5) ? &m.width : &m.height;
        *dim = rng_->pick<uint32_t>({0u, 1u, 1u << 16, 1u << 31, 0xffffffffu});
        c.what = "camera_info size " + std::to_string(m.width) + "x" + std::to_string(m.height);
        c.expect = Expect::kReject;
        break;
      }
      case 8:
        m.binning_x = uint32_t(rng_->integer(0, 100));
        m.binning_y = rng_->pick<uint32_t>({0u, 0xffffffffu});
        m.roi.x_offset = rng_->pick<uint32_t>({0u, 10000u, 0xffffffffu});
        m.roi.width = rng_->pick<uint32_t>({0u, 1u, 0xffffffffu});
        m.roi.do_rectify = rng_->chance(0.5);
        c.what = "binning and ROI";
        break;
      default:
        for (double& d : m.D) d = rng_->wild();
        c.what = "every D entry wild";
        for (double d : m.D) c.expect = finite(d) ? c.expect : Expect::kReject;
        break;
    }
    return c;
  }

  /// A stamp mutation of a good frame (image + camera_info): zero, duplicate, backwards, far ahead.
  FrameCase stampCase(size_t i, const ros::Time& last_good) {
    FrameCase c;
    ros::Time t;
    switch (rng_->integer(0, 3)) {
      case 0:
        t = ros::Time();
        c.what = "stamp zero";
        break;
      case 1:
        t = last_good;
        c.what = "stamp duplicate";
        break;
      case 2: {
        const double back = rng_->pick<double>({1e-9, 0.05, 1.0, 1e4, 9.9e8});
        t = last_good - ros::Duration(back);
        c.what = "stamp " + num(back) + " s backwards";
        break;
      }
      default: {
        const uint32_t sec = uint32_t(rng_->integer64(uint64_t(last_good.sec) + 2, 4294967295ull));
        t = ros::Time(sec, uint32_t(rng_->integer(0, 999999999)));
        c.what = "stamp far ahead (" + std::to_string(sec) + " s)";
        break;
      }
    }
    c.image = imageMsg(noisyImage(i), t, "mono8");
    c.info = info(t);
    c.expect = Expect::kReject;
    return c;
  }

  void log(const char* kind, const std::string& what, bool must_reject) {
    ++num_cases_;
    std::printf("case %d: %s %s%s\n", num_cases_, kind, what.c_str(),
                must_reject ? " (must be rejected)" : "");
  }

  /// Sends a frame case and checks its status.
  bool runFrameCase(const char* kind, const FrameCase& c) {
    log(kind, c.what, c.expect == Expect::kReject);
    VoStatus s;
    if (!send(c.image, c.info, &s)) return false;
    std::printf("  -> %s%s\n", s.state_name.c_str(),
                s.message.empty() ? "" : (": " + s.message.substr(0, 300)).c_str());
    if (c.expect == Expect::kReject) {
      EXPECT_EQ(s.state, VoStatus::STATE_BAD_INPUT) << "case " << num_cases_ << " " << kind << " " << c.what
                                                    << " not rejected: " << s.state_name << " " << s.message;
    }
    if (s.state == VoStatus::STATE_BAD_INPUT) ++num_rejected_frames_;
    return true;
  }

  ros::NodeHandle nh_;
  image_transport::ImageTransport transport_{nh_};
  image_transport::Publisher image_pub_;
  ros::Publisher info_pub_, imu_pub_, altimeter_pub_, initial_state_pub_;
  std::vector<ros::Subscriber> subs_;
  std::string manager_;
  uint64_t seed_ = kDefaultSeed;
  int cases_per_frame_ = 5;
  std::unique_ptr<Rng> rng_;
  std::unique_ptr<Dataset> dataset_;
  std::mutex mutex_;
  std::vector<VoStatus> statuses_;
  std::vector<std::string> violations_;
  size_t num_poses_ = 0, num_odometry_ = 0, num_nav_ = 0;
  size_t imu_sent_ = 0, altimeter_sent_ = 0;
  size_t must_imu_rejects_ = 0, must_altimeter_rejects_ = 0;
  size_t imu_far_ahead_ = 0, altimeter_far_ahead_ = 0;
  size_t good_imu_sent_ = 0, good_altimeter_sent_ = 0;
  int num_cases_ = 0, num_rejected_frames_ = 0;
};

TEST_F(VoFuzzTest, MalformedInputIsContainedAndExplained) {
  std::vector<std::pair<double, std::function<void()>>> queue;
  const size_t n = dataset_->size();
  double last_sample_t = -1.0;  // dataset time of the last good samples sent
  std::array<int, 5> good_states{};
  VoStatus after_cases;  // the status of the good frame after the last case
  size_t good_imu_after_cases = 0, good_altimeter_after_cases = 0;
  for (size_t k = 0; k < n; ++k) {
    const double t = dataset_->timestamp(k);
    const bool fuzz = k >= kGoodFirst && k + kGoodLast < n;
    // The slot before good frame k: the good samples up to 50 ms before it, malformed ones among them, the
    // malformed frames, the remaining good samples, then the good frame.
    const double t_cases = t - 0.05;
    std::vector<FrameCase> frames;
    if (fuzz) {
      const double t_prev = dataset_->timestamp(k - 1);
      if (k == kGoodFirst) queueRegressionCases(t_prev + 0.0025, &queue);
      bool stamp_case = false;
      for (int j = 0; j < cases_per_frame_; ++j) {
        // Samples are stamped half-way between the 5 ms IMU ticks, after the previous frame.
        const double ts = t_prev + 0.0025 + 0.005 * rng_->integer(0, int((t_cases - t_prev) / 0.005) - 1);
        switch (rng_->integer(0, 9)) {
          case 0:
          case 1:
            queueImuCase(ts, lastStampUpTo(dataset_->imu(), last_sample_t), &queue);
            break;
          case 2:
          case 3:
            queueRangeCase(ts, lastStampUpTo(dataset_->altimeter(), last_sample_t), &queue);
            break;
          case 4:
          case 5:
          case 6:
            frames.push_back(imageCase(k, toStamp(kEpoch, t_cases + 0.005 * double(frames.size() + 1))));
            frames.back().what = "[image] " + frames.back().what;
            break;
          case 7:
          case 8:
            frames.push_back(infoCase(k, toStamp(kEpoch, t_cases + 0.005 * double(frames.size() + 1))));
            frames.back().what = "[camera_info] " + frames.back().what;
            break;
          default:
            stamp_case = true;  // sent last: the good frame after it shows it was an outlier
            break;
        }
      }
      if (stamp_case) {
        frames.push_back(stampCase(k, stamp(k - 1)));
        frames.back().what = "[stamp] " + frames.back().what;
      }
    }
    queueGoodSamples(last_sample_t, t_cases, &queue);
    publishSamples(&queue);
    for (const FrameCase& c : frames) ASSERT_TRUE(runFrameCase("frame", c)) << "case " << num_cases_;
    queueGoodSamples(t_cases, t, &queue);
    publishSamples(&queue);
    last_sample_t = t;
    VoStatus s;
    ASSERT_TRUE(send(imageMsg(dataset_->loadImage(k), stamp(k), "mono8"), info(stamp(k)), &s))
        << "good frame " << k << " after case " << num_cases_;
    EXPECT_NE(s.state, VoStatus::STATE_BAD_INPUT) << "good frame " << k << " rejected: " << s.message;
    if (k > 0) {
      EXPECT_TRUE(s.processed) << "good frame " << k << " not processed: " << s.message;
    }
    if (s.state < good_states.size()) ++good_states[s.state];
    if (k + kGoodLast + 1 == n) {
      after_cases = s;
      good_imu_after_cases = good_imu_sent_;
      good_altimeter_after_cases = good_altimeter_sent_;
    }
    std::printf(
        "good frame %zu -> %s%s [IMU %u received, %u used, %u rejected; altimeter %u received, %u used, %u "
        "without "
        "range, %u rejected]\n",
        k, s.state_name.c_str(), s.message.empty() ? "" : (": " + s.message.substr(0, 300)).c_str(),
        s.num_imu_msgs, s.num_imu_used, s.num_imu_rejected, s.num_altimeter_msgs, s.num_altimeter_used,
        s.num_altimeter_no_range, s.num_altimeter_rejected);
  }

  // The manager is alive and answers.
  XmlRpc::XmlRpcValue pid;
  EXPECT_TRUE(callNode(manager_, "getPid", &pid)) << "the nodelet manager does not answer";

  std::lock_guard<std::mutex> lock(mutex_);
  std::printf(
      "vo_fuzz: seed %llu, %d cases (%d frames rejected), good frames: %d initialising, %d tracking, %d "
      "lost, "
      "%d recovered; %zu vo/pose, %zu vo/odometry, %zu nav/odometry checked\n",
      static_cast<unsigned long long>(seed_), num_cases_, num_rejected_frames_, good_states[0],
      good_states[1], good_states[2], good_states[3], num_poses_, num_odometry_, num_nav_);
  EXPECT_GT(num_poses_, 0u);
  EXPECT_GT(num_nav_, 0u);
  for (const std::string& v : violations_) ADD_FAILURE() << v;
  // Every rejection has a reason.
  uint32_t imu_rejected = 0, altimeter_rejected = 0;
  for (const VoStatus& s : statuses_) {
    if (s.state == VoStatus::STATE_BAD_INPUT) {
      EXPECT_FALSE(s.message.empty()) << "BAD_INPUT without a reason at " << s.header.stamp;
    }
    if (s.num_imu_rejected > imu_rejected) {
      EXPECT_TRUE(namesReason(s.message, "IMU sample rejected: "))
          << "IMU rejection without a reason at " << s.header.stamp << ": '" << s.message << "'";
    }
    if (s.num_altimeter_rejected > altimeter_rejected) {
      EXPECT_TRUE(namesReason(s.message, "altimeter reading rejected: "))
          << "altimeter rejection without a reason at " << s.header.stamp << ": '" << s.message << "'";
    }
    imu_rejected = std::max(imu_rejected, s.num_imu_rejected);
    altimeter_rejected = std::max(altimeter_rejected, s.num_altimeter_rejected);
  }
  const VoStatus& last = statuses_.back();
  std::printf(
      "vo_fuzz: IMU %u received, %u rejected (%zu must be); altimeter %u received, %u rejected (%zu must "
      "be)\n",
      last.num_imu_msgs, last.num_imu_rejected, must_imu_rejects_, last.num_altimeter_msgs,
      last.num_altimeter_rejected, must_altimeter_rejects_);
  EXPECT_EQ(last.num_imu_msgs, imu_sent_);
  EXPECT_EQ(last.num_altimeter_msgs, altimeter_sent_);
  EXPECT_GE(last.num_imu_rejected, must_imu_rejects_);
  EXPECT_GE(last.num_altimeter_rejected, must_altimeter_rejects_);
  // Every sample is accounted for: used, without range, or rejected with a reason; only a sample stamped far
  // ahead may still wait in the buffer. (A silently dropped sample is a rejection without a reason.)
  const size_t imu_accounted = size_t(last.num_imu_used) + last.num_imu_rejected;
  const size_t altimeter_accounted =
      size_t(last.num_altimeter_used) + last.num_altimeter_no_range + last.num_altimeter_rejected;
  std::printf(
      "vo_fuzz: IMU %u used; altimeter %u used, %u without range; %zu IMU and %zu altimeter samples "
      "stamped far ahead\n",
      last.num_imu_used, last.num_altimeter_used, last.num_altimeter_no_range, imu_far_ahead_,
      altimeter_far_ahead_);
  EXPECT_LE(last.num_imu_msgs, imu_accounted + imu_far_ahead_) << "IMU samples lost without a reason";
  EXPECT_LE(last.num_altimeter_msgs, altimeter_accounted + altimeter_far_ahead_)
      << "altimeter readings lost without a reason";
  // The sample streams survived the cases: every good sample of the last, clean frames was used.
  EXPECT_GE(last.num_imu_used - after_cases.num_imu_used, good_imu_sent_ - good_imu_after_cases)
      << "the IMU stream did not recover from the cases";
  EXPECT_GE(last.num_altimeter_used + last.num_altimeter_no_range - after_cases.num_altimeter_used -
                after_cases.num_altimeter_no_range,
            good_altimeter_sent_ - good_altimeter_after_cases)
      << "the altimeter stream did not recover from the cases";
}

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) { return planetary_vo::ros_io::runRosTests(argc, argv, "test_vo_fuzz"); }
