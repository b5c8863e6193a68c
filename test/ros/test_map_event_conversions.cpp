/// Unit tests (no master) of the vo/map_events conversions (map_event_conversions.h): a MapEvents with every
/// group filled and a keyframe image survives toMsg -> fromMsg; the message's layout (frame, stamps, flat
/// arrays, mono8 image) is what the message documents; malformed messages are rejected with a clear
/// std::invalid_argument.

#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "planetary_vo/ros_io/conversions.h"
#include "planetary_vo/ros_io/map_event_conversions.h"

namespace planetary_vo::ros_io {
namespace {

MapPointState makePoint(uint64_t id, double seed) {
  MapPointState p;
  p.id = id;
  p.p_world = Eigen::Vector3d(seed, -2.5 * seed + 0.1, 100.0 / 3.0 + seed);
  Eigen::Matrix3d a;
  a << 1.0, 0.1 * seed, 0.2, 0.0, 2.0, 1.0 / 7.0, 0.3, 0.0, 3.0 + seed;
  p.covariance_world = a * a.transpose();  // symmetric, off-diagonal terms that a transposition would swap
  p.covariance_world(0, 1) += 1e-3;        // and one that is not symmetric: row-major order must hold
  p.num_observations = static_cast<int>(id % 5);
  return p;
}

MapEvents makeEvents() {
  MapEvents e;
  MapKeyframeState kf;
  kf.id = 42;
  kf.timestamp_s = 3.25;  // on a nanosecond: exact through ros::Time
  kf.T_world_cam = Eigen::Translation3d(1.0 / 3.0, -7.5, 1234.5) *
                   Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -1.0, 0.4).normalized());
  e.keyframes_added.push_back(kf);
  for (uint64_t i = 0; i < 2; ++i) {  // two keyframes left the window, with their adjusted poses
    MapKeyframeState old;
    old.id = 30 + i;
    const double a = static_cast<double>(i);
    old.timestamp_s = 1.5 + 0.125 * a;
    old.T_world_cam = Eigen::Translation3d(-2.0 * a, 0.25, 1300.0) *
                      Eigen::AngleAxisd(0.1 + a, Eigen::Vector3d(1.0, 0.5, -0.3).normalized());
    e.keyframes_retired.push_back(old);
  }
  for (uint64_t i = 0; i < 4; ++i) e.points_added.push_back(makePoint(100 + i, 0.5 * i));
  for (uint64_t i = 0; i < 3; ++i) e.points_updated.push_back(makePoint(200 + i, -1.0 - i));
  for (uint64_t i = 0; i < 2; ++i) e.points_retired.push_back(makePoint(300 + i, 10.0 + i));
  e.points_retired.back().covariance_world(2, 2) = 1e12;  // an unconstrained depth, as the VO caps it
  e.points_removed = {7, 9, std::numeric_limits<uint64_t>::max()};
  e.map_restarted = true;
  return e;
}

cv::Mat makeImage() {
  cv::Mat gray(5, 7, CV_8UC1);
  for (int i = 0; i < gray.rows * gray.cols; ++i) gray.data[i] = static_cast<uint8_t>(37 * i);
  return gray;
}

const ros::Time kEpoch(1700000000, 0);

VoMapEvents makeMsg() {
  const cv::Mat gray = makeImage();
  const std_msgs::Header header = makeHeader(kEpoch + ros::Duration(3.25), "world");
  const std_msgs::Header image_header = makeHeader(header.stamp, "camera_optical");
  return toMsg(makeEvents(), true, header, kEpoch, &gray, image_header);
}

void expectSamePoints(const std::vector<MapPointState>& a, const std::vector<MapPointState>& b,
                      const std::string& group) {
  ASSERT_EQ(a.size(), b.size()) << group;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].id, b[i].id) << group << " " << i;
    EXPECT_EQ(a[i].p_world, b[i].p_world) << group << " " << i;  // bit-exact
    EXPECT_EQ(a[i].covariance_world, b[i].covariance_world) << group << " " << i;
    EXPECT_EQ(a[i].num_observations, b[i].num_observations) << group << " " << i;
  }
}

TEST(MapEventConversions, RoundTripIsExact) {
  const MapEvents in = makeEvents();
  const VoMapEvents msg = makeMsg();
  cv::Mat image;
  const MapEvents out = fromMsg(msg, kEpoch, &image);
  EXPECT_EQ(out.map_restarted, in.map_restarted);
  ASSERT_EQ(out.keyframes_added.size(), 1u);
  const MapKeyframeState &a = in.keyframes_added[0], &b = out.keyframes_added[0];
  EXPECT_EQ(b.id, a.id);
  EXPECT_EQ(b.timestamp_s, a.timestamp_s);
  EXPECT_EQ(b.T_world_cam.translation(), a.T_world_cam.translation());
  EXPECT_LT((b.T_world_cam.rotation() - a.T_world_cam.rotation()).cwiseAbs().maxCoeff(), 1e-15);
  ASSERT_EQ(out.keyframes_retired.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const MapKeyframeState &c = in.keyframes_retired[i], &d = out.keyframes_retired[i];
    EXPECT_EQ(d.id, c.id);
    EXPECT_EQ(d.timestamp_s, c.timestamp_s);
    EXPECT_EQ(d.T_world_cam.translation(), c.T_world_cam.translation());
    EXPECT_LT((d.T_world_cam.rotation() - c.T_world_cam.rotation()).cwiseAbs().maxCoeff(), 1e-15);
  }
  expectSamePoints(in.points_added, out.points_added, "added");
  expectSamePoints(in.points_updated, out.points_updated, "updated");
  expectSamePoints(in.points_retired, out.points_retired, "retired");
  EXPECT_EQ(out.points_removed, in.points_removed);
  ASSERT_EQ(image.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(image, makeImage(), cv::NORM_INF), 0.0);
}

TEST(MapEventConversions, MessageLayout) {
  const VoMapEvents msg = makeMsg();
  const MapEvents in = makeEvents();
  EXPECT_EQ(msg.header.frame_id, "world");
  EXPECT_TRUE(msg.metric_scale);
  EXPECT_TRUE(msg.map_restarted);
  ASSERT_EQ(msg.keyframe_stamps.size(), 1u);
  EXPECT_EQ(msg.keyframe_stamps[0], ros::Time(1700000003, 250000000));
  EXPECT_EQ(msg.keyframe_T_world_cam[0].position.z, 1234.5);
  EXPECT_EQ(msg.retired_keyframe_ids, (std::vector<uint64_t>{30, 31}));
  ASSERT_EQ(msg.retired_keyframe_stamps.size(), 2u);
  EXPECT_EQ(msg.retired_keyframe_stamps[1], ros::Time(1700000001, 625000000));
  ASSERT_EQ(msg.retired_keyframe_T_world_cam.size(), 2u);
  EXPECT_EQ(msg.retired_keyframe_T_world_cam[1].position.x, -2.0);
  ASSERT_EQ(msg.added_positions.size(), 12u);
  ASSERT_EQ(msg.added_covariances.size(), 36u);
  EXPECT_EQ(msg.added_positions[3 * 2 + 1], in.points_added[2].p_world.y());
  EXPECT_EQ(msg.added_covariances[9 * 1 + 3 * 0 + 1],
            in.points_added[1].covariance_world(0, 1));  // row-major
  EXPECT_EQ(msg.updated_ids, (std::vector<uint64_t>{200, 201, 202}));
  EXPECT_EQ(msg.retired_num_observations.size(), 2u);
  EXPECT_EQ(msg.keyframe_image.encoding, "mono8");
  EXPECT_EQ(msg.keyframe_image.width, 7u);
  EXPECT_EQ(msg.keyframe_image.height, 5u);
  EXPECT_EQ(msg.keyframe_image.header.frame_id, "camera_optical");
  EXPECT_EQ(msg.keyframe_image.header.stamp, msg.header.stamp);
}

TEST(MapEventConversions, NoImageWithoutKeyframe) {
  MapEvents e = makeEvents();
  e.keyframes_added.clear();
  const cv::Mat gray = makeImage();
  const VoMapEvents msg = toMsg(e, false, makeHeader(kEpoch, "world"), kEpoch, &gray);
  EXPECT_TRUE(msg.keyframe_image.data.empty());
  EXPECT_EQ(msg.keyframe_image.width, 0u);
  cv::Mat image = gray.clone();
  const MapEvents out = fromMsg(msg, kEpoch, &image);
  EXPECT_TRUE(image.empty());
  EXPECT_TRUE(out.keyframes_added.empty());
  expectSamePoints(e.points_added, out.points_added, "added");
  // An empty MapEvents is an empty message and back.
  EXPECT_TRUE(fromMsg(toMsg(MapEvents(), false, std_msgs::Header(), kEpoch), kEpoch).empty());
}

/// fromMsg must throw std::invalid_argument whose message contains `expected`.
void expectRejected(const VoMapEvents& msg, const std::string& expected) {
  try {
    fromMsg(msg, kEpoch);
    ADD_FAILURE() << "accepted; expected a rejection mentioning '" << expected << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

TEST(MapEventConversions, BadMessagesAreRejected) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ASSERT_NO_THROW(fromMsg(makeMsg(), kEpoch));
  VoMapEvents m = makeMsg();
  m.keyframe_stamps.push_back(ros::Time(1));
  expectRejected(m, "keyframe arrays disagree");
  m = makeMsg();
  m.keyframe_T_world_cam[0].position.x = nan;
  expectRejected(m, "keyframe 0: pose not finite");
  m = makeMsg();
  m.retired_keyframe_ids.pop_back();
  expectRejected(m, "retired_keyframe arrays disagree: 1 retired_keyframe_ids, 2 retired_keyframe_stamps");
  m = makeMsg();
  m.retired_keyframe_T_world_cam[1].orientation.w = 3.0;
  expectRejected(m, "retired_keyframe 1: orientation is not a unit quaternion");
  m = makeMsg();
  m.keyframe_T_world_cam[0].orientation.w = 0.0;
  m.keyframe_T_world_cam[0].orientation.x = 0.0;
  m.keyframe_T_world_cam[0].orientation.y = 0.0;
  m.keyframe_T_world_cam[0].orientation.z = 0.0;
  expectRejected(m, "not a unit quaternion");
  m = makeMsg();
  m.added_positions.pop_back();
  expectRejected(m, "added_positions has 11 values, expected 3 x 4");
  m = makeMsg();
  m.updated_covariances.push_back(0.0);
  expectRejected(m, "updated_covariances has 28 values, expected 9 x 3");
  m = makeMsg();
  m.retired_num_observations.pop_back();
  expectRejected(m, "retired_num_observations has 1 values, expected 2");
  m = makeMsg();
  m.added_ids.push_back(5);  // one more id than the other arrays hold
  expectRejected(m, "added_positions");
  m = makeMsg();
  m.updated_positions[4] = std::numeric_limits<double>::infinity();
  expectRejected(m, "updated point 1 (id 201): position not finite");
  m = makeMsg();
  m.retired_covariances[9 + 8] = nan;
  expectRejected(m, "retired point 1 (id 301): covariance not finite");
  m = makeMsg();
  m.added_num_observations[0] = -1;
  expectRejected(m, "negative num_observations");
  m = makeMsg();
  m.keyframe_image.encoding = "bgr8";
  expectRejected(m, "keyframe_image encoding 'bgr8', expected mono8");
  m = makeMsg();
  m.keyframe_image.data.resize(10);
  expectRejected(m, "does not hold 10 bytes");
  m = makeMsg();
  m.keyframe_ids.clear();
  m.keyframe_stamps.clear();
  m.keyframe_T_world_cam.clear();
  expectRejected(m, "keyframe_image present but no keyframe was added");
}

TEST(MapEventConversions, ToMsgRejectsANon8BitImage) {
  const cv::Mat rgb(2, 2, CV_8UC3, cv::Scalar(1, 2, 3));
  EXPECT_THROW(toMsg(makeEvents(), true, std_msgs::Header(), kEpoch, &rgb), std::invalid_argument);
}

}  // namespace
}  // namespace planetary_vo::ros_io
