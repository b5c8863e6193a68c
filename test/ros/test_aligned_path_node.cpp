/// gtest node of the rostest aligned_path: publishes a ground-truth descent on ground_truth/pose and a copy
/// of it mapped into another world by a known similarity (scale 0.02, a rotation, a translation) on vo/pose,
/// with stamps that are a few ms off and some estimated poses missing (as when the VO skips frames), plus a
/// map in the VO world on vo/map_points. aligned_path_node must undo the similarity: vo/path_aligned equals
/// the ground truth (positions within 1e-6 m, orientations within 1e-9), one pose per vo/pose, in the ground
/// truth's frame; vo/ate_m is ~0; vo/map_points_aligned holds the map in the ground-truth world (float32
/// precision). The first poses are collinear (the alignment is not observable then): the node must survive
/// that.
///
/// Two cases, each against its own aligned_path_node (aligned_path.test): ground truth and estimate
/// interleaved, as the player and the VO send them, to a subscriber that listens from the start; and the
/// worst order: every estimate (and the map) before any ground truth (the two inputs come over separate
/// connections), and the outputs subscribed only afterwards.

#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <std_msgs/Float64.h>

#include "planetary_vo/eval/trajectory_alignment.h"
#include "planetary_vo/ros_io/conversions.h"
#include "test_ros_helpers.h"

namespace planetary_vo::ros_io {
namespace {

constexpr size_t kNumPoses = 60;
const ros::Time kEpoch(1000000000, 0);

/// Ground truth of pose k (10 Hz): a straight vertical drop for the first 4 poses (collinear), then a curved
/// descent with a turning attitude.
Pose groundTruthPose(size_t k) {
  const double t = 0.1 * static_cast<double>(k);
  Pose T = Pose::Identity();
  if (k < 4) {
    T.translation() = Eigen::Vector3d(0.0, 0.0, 1500.0 - 20.0 * t);
  } else {
    T.translation() = Eigen::Vector3d(40.0 * std::sin(0.5 * t), 120.0 * t, 1500.0 - 20.0 * t - 3.0 * t * t);
  }
  T.linear() = (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(0.05 * t, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()))
                   .toRotationMatrix();
  return T;
}

/// The VO world: p_gt = S(p_vo); the estimate is S^-1 applied to the ground truth.
Sim3Transform voToGroundTruth() {
  Sim3Transform S;
  S.scale = 50.0;  // VO units are 1/50 of a metre
  S.R_gt_est = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  S.t_gt_est_m = Eigen::Vector3d(12.0, -340.0, 1490.0);
  return S;
}

Pose toVoWorld(const Pose& T_gt_cam) {
  const Sim3Transform S = voToGroundTruth();
  Pose T = Pose::Identity();
  T.linear() = S.R_gt_est.transpose() * T_gt_cam.rotation();
  T.translation() = S.R_gt_est.transpose() * (T_gt_cam.translation() - S.t_gt_est_m) / S.scale;
  return T;
}

bool estimated(size_t k) { return k % 7 != 3; }  // every 7th frame has no VO pose
ros::Time gtStamp(size_t k) { return kEpoch + ros::Duration(0.1 * static_cast<double>(k)); }
ros::Time estStamp(size_t k) { return gtStamp(k) + ros::Duration(0.003); }  // within ~max_dt (0.02 s)

/// Map points in the ground-truth world (on the ground below the descent).
std::vector<Eigen::Vector3d> groundPoints() {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 4; ++j) points.emplace_back(30.0 * i - 60.0, 50.0 * j + 100.0, 2.0 * i - j);
  return points;
}

sensor_msgs::PointCloud2 voMap() {
  const Sim3Transform S = voToGroundTruth();
  sensor_msgs::PointCloud2 cloud;
  cloud.header.frame_id = "vo_world";
  cloud.header.stamp = estStamp(kNumPoses - 1);
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1,
                                sensor_msgs::PointField::FLOAT32, "z", 1, sensor_msgs::PointField::FLOAT32,
                                "observations", 1, sensor_msgs::PointField::UINT32);
  const std::vector<Eigen::Vector3d> points = groundPoints();
  modifier.resize(points.size());
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  sensor_msgs::PointCloud2Iterator<uint32_t> obs(cloud, "observations");
  for (size_t i = 0; i < points.size(); ++i, ++x, ++y, ++z, ++obs) {
    const Eigen::Vector3d p = S.R_gt_est.transpose() * (points[i] - S.t_gt_est_m) / S.scale;
    *x = static_cast<float>(p.x());
    *y = static_cast<float>(p.y());
    *z = static_cast<float>(p.z());
    *obs = static_cast<uint32_t>(i + 2);
  }
  return cloud;
}

struct Received {
  std::mutex mutex;
  nav_msgs::PathConstPtr path;
  std::vector<double> ate;
  sensor_msgs::PointCloud2ConstPtr map;
  void onPath(const nav_msgs::PathConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex);
    path = m;
  }
  void onAte(const std_msgs::Float64ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex);
    ate.push_back(m->data);
  }
  void onMap(const sensor_msgs::PointCloud2ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex);
    map = m;
  }
};

/// Waits for a vo/path_aligned with every estimated pose, then checks it pose by pose, and the ATE.
void checkPath(Received& received, size_t num_estimated) {
  // The last path holds every estimated pose, aligned onto the ground truth.
  auto pathComplete = [&] {
    std::lock_guard<std::mutex> lock(received.mutex);
    if (!received.path || received.path->poses.size() != num_estimated) return false;
    size_t last = kNumPoses - 1;
    while (!estimated(last)) --last;
    const Eigen::Vector3d last_gt = groundTruthPose(last).translation();
    return (fromPoseMsg(received.path->poses.back().pose).translation() - last_gt).norm() < 1e-6;
  };
  ASSERT_TRUE(waitFor(pathComplete, 30.0))
      << "vo/path_aligned never held all " << num_estimated << " poses aligned onto the ground truth";
  // vo/ate_m comes over its own connection, possibly after the path.
  ASSERT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(received.mutex);
        return !received.ate.empty();
      },
      30.0))
      << "no vo/ate_m";

  std::lock_guard<std::mutex> lock(received.mutex);
  EXPECT_EQ(received.path->header.frame_id, "moon");  // the ground truth's frame, not the VO's
  size_t i = 0;
  for (size_t k = 0; k < kNumPoses; ++k) {
    if (!estimated(k)) continue;
    const geometry_msgs::PoseStamped& p = received.path->poses[i++];
    EXPECT_EQ(p.header.stamp, estStamp(k)) << "pose " << k;
    const Pose T = fromPoseMsg(p.pose);
    const Pose T_gt = groundTruthPose(k);
    EXPECT_LT((T.translation() - T_gt.translation()).norm(), 1e-6) << "pose " << k;
    EXPECT_LT((T.rotation() - T_gt.rotation()).norm(), 1e-9) << "pose " << k;
  }
  EXPECT_LT(received.ate.back(), 1e-6);
}

enum class Scenario {
  kLive,       ///< subscribed to the outputs first, then ground truth and estimate interleaved
  kWorstOrder  ///< estimates and map, then ground truth, then the output subscribers connect
};

/// One run against the aligned_path_node in namespace `ns`.
void checkNode(const std::string& ns, Scenario scenario) {
  ros::NodeHandle nh(ns);
  const std::string node = ros::names::append(nh.getNamespace(), "aligned_path");
  Received received;
  std::vector<ros::Subscriber> outputs;
  auto subscribeOutputs = [&] {
    outputs.push_back(nh.subscribe("vo/path_aligned", 10, &Received::onPath, &received));
    outputs.push_back(nh.subscribe("vo/ate_m", 100, &Received::onAte, &received));
    outputs.push_back(nh.subscribe("vo/map_points_aligned", 10, &Received::onMap, &received));
  };
  if (scenario == Scenario::kLive) subscribeOutputs();
  ros::Publisher gt_pub = nh.advertise<geometry_msgs::PoseStamped>("ground_truth/pose", 1000);
  ros::Publisher est_pub = nh.advertise<geometry_msgs::PoseStamped>("vo/pose", 1000);
  ros::Publisher map_pub = nh.advertise<sensor_msgs::PointCloud2>("vo/map_points", 10);
  ASSERT_TRUE(waitFor(
      [&] {
        return gt_pub.getNumSubscribers() > 0 && est_pub.getNumSubscribers() > 0 &&
               map_pub.getNumSubscribers() > 0 && allConnected(outputs);
      },
      30.0))
      << node << " did not connect";

  auto publishGroundTruth = [&](size_t k) {
    gt_pub.publish(toPoseStamped(groundTruthPose(k), makeHeader(gtStamp(k), "moon")));
  };
  size_t num_estimated = 0;
  for (size_t k = 0; k < kNumPoses; ++k) {
    if (scenario == Scenario::kLive) publishGroundTruth(k);
    if (estimated(k)) {
      est_pub.publish(toPoseStamped(toVoWorld(groundTruthPose(k)), makeHeader(estStamp(k), "vo_world")));
      ++num_estimated;
    }
  }
  map_pub.publish(voMap());
  if (scenario == Scenario::kWorstOrder) {
    // Published later is not enough: the node reads its connections as data comes and would interleave them.
    // Once it has read every estimate and the map, they are queued before any ground truth; the connection of
    // a subscriber is handled after the ground truth the same way.
    ASSERT_TRUE(waitFor(
        [&] {
          return messagesReceived(node, est_pub.getTopic()) == int(num_estimated) &&
                 messagesReceived(node, map_pub.getTopic()) == 1;
        },
        30.0))
        << node << " did not receive the estimates and the map";
    for (size_t k = 0; k < kNumPoses; ++k) publishGroundTruth(k);
    ASSERT_TRUE(waitFor([&] { return messagesReceived(node, gt_pub.getTopic()) == int(kNumPoses); }, 30.0))
        << node << " did not receive the ground truth";
    subscribeOutputs();  // like rviz started after the run: the latched outputs must be up to date
  }
  ASSERT_NO_FATAL_FAILURE(checkPath(received, num_estimated));

  ASSERT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(received.mutex);
        return received.map != nullptr;
      },
      30.0))
      << "no vo/map_points_aligned";
  std::lock_guard<std::mutex> lock(received.mutex);
  const std::vector<Eigen::Vector3d> expected = groundPoints();
  ASSERT_EQ(received.map->width * received.map->height, expected.size());
  EXPECT_EQ(received.map->header.frame_id, "moon");
  sensor_msgs::PointCloud2ConstIterator<float> x(*received.map, "x"), y(*received.map, "y"),
      z(*received.map, "z");
  sensor_msgs::PointCloud2ConstIterator<uint32_t> obs(*received.map, "observations");
  for (size_t i = 0; i < expected.size(); ++i, ++x, ++y, ++z, ++obs) {
    // float32 in and out: about 1e-7 relative of the VO coordinates (tens) times the scale (50)
    EXPECT_LT((Eigen::Vector3d(*x, *y, *z) - expected[i]).norm(), 2e-3) << "point " << i;
    EXPECT_EQ(*obs, i + 2) << "point " << i;  // other fields copied
  }
}

TEST(AlignedPathNode, UndoesTheSimilarityOfTheEstimate) { checkNode("", Scenario::kLive); }

// Without a timer (align_period 0) only a new pose can trigger the alignment: here the last ones are ground
// truth. And nobody subscribed while the outputs were made.
TEST(AlignedPathNode, GroundTruthAfterTheEstimatesAndALateSubscriber) {
  checkNode("worst_order", Scenario::kWorstOrder);
}

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) {
  return planetary_vo::ros_io::runRosTests(argc, argv, "test_aligned_path_node");
}
