/// @file aligned_path_node.cpp
/// The `aligned_path_node`: a ground-truth overlay for rviz and a running accuracy readout. DISPLAY AND
/// EVALUATION AID ONLY: it uses the ground truth, which a lander does not have, so nothing it publishes is
/// navigation output; never feed vo/path_aligned to a controller.
///
/// It collects vo/pose (VO world frame, up to scale) and ground_truth/pose, associates them by stamp
/// (associateByTimestamp), and estimates the Sim(3) from the VO world into the ground-truth world over all
/// pairs so far (alignTrajectories, sim3; the same as `vo_eval --align sim3` on the trajectories so far). The
/// alignment is recomputed every ~align_every new estimated poses and on a ~align_period wall-clock timer
/// when something arrived since; it is skipped (throttled log, nothing published) until there are 3 pairs
/// that are not collinear. Until then, a ground-truth pose that pairs with an estimate already received tries
/// too: the two topics come over separate connections, so a ground-truth pose may arrive after its estimate
/// (all of them may, on a loaded machine), and without the timer nothing else would align once the estimates
/// have ended.
///
/// The outputs are latched (rviz or a recorder may subscribe later). Nothing is built while nobody
/// subscribes; what was skipped is published when a subscriber connects, so the latched message is never out
/// of date.
///
/// Publishes (frame: the ground truth's header frame, or ~frame_id):
///   vo/path_aligned        nav_msgs/Path       every vo/pose so far, through the current Sim(3)
///   vo/ate_m               std_msgs/Float64    RMSE of |aligned estimate - ground truth| over the pairs,
///   metres vo/map_points_aligned  sensor_msgs/PointCloud2  vo/map_points through the current Sim(3)
///   (~transform_map)
/// Service ~reset (std_srvs/Trigger): forget everything (after vo/reset, or a restarted bag or player).
/// Parameters: ~align_every (int, 10), ~align_period (double s, 1.0; 0 = no timer), ~max_dt (double s, 0.02,
/// association tolerance), ~frame_id (string, "" = ground truth's frame), ~transform_map (bool, true).

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <std_msgs/Float64.h>
#include <std_srvs/Trigger.h>

#include "planetary_vo/eval/trajectory_alignment.h"
#include "planetary_vo/ros_io/containment.h"
#include "planetary_vo/ros_io/conversions.h"

namespace planetary_vo::ros_io {
namespace {

/// ROS-free part: the two trajectories (sorted by stamp) and the Sim(3) over their associated pairs.
class RunningAlignment {
 public:
  explicit RunningAlignment(double max_dt_s) : max_dt_s_(max_dt_s) {}

  /// Appends a pose; false (ignored) if its stamp is not after the last one of that trajectory.
  bool addGroundTruth(const StampedPose& p) { return append(&ground_truth_, p); }
  bool addEstimate(const StampedPose& p) { return append(&estimate_, p); }

  /// Re-associates and re-aligns everything. False, with *why, while the alignment is not observable (fewer
  /// than 3 pairs, or collinear positions); the previous alignment, if any, stays in use.
  bool update(std::string* why) {
    const AssociatedTrajectories pairs = associateByTimestamp(ground_truth_, estimate_, max_dt_s_);
    try {
      transform_ = alignTrajectories(pairs, AlignmentMode::kSim3);
    } catch (const EvalError& e) {
      *why = e.what();
      return false;
    }
    double sum_sq = 0.0;
    for (size_t k = 0; k < pairs.size(); ++k)
      sum_sq += (transform_.transformPoint(pairs.estimate[k].T_world_cam.translation()) -
                 pairs.ground_truth[k].T_world_cam.translation())
                    .squaredNorm();
    ate_rmse_m_ = std::sqrt(sum_sq / static_cast<double>(pairs.size()));
    path_length_m_ = 0.0;
    for (size_t k = 1; k < pairs.size(); ++k)
      path_length_m_ += (pairs.ground_truth[k].T_world_cam.translation() -
                         pairs.ground_truth[k - 1].T_world_cam.translation())
                            .norm();
    num_pairs_ = pairs.size();
    valid_ = true;
    return true;
  }

  bool valid() const { return valid_; }
  const Sim3Transform& transform() const { return transform_; }
  double ateRmseM() const { return ate_rmse_m_; }
  double pathLengthM() const { return path_length_m_; }  ///< ground truth, over the associated pairs
  size_t numPairs() const { return num_pairs_; }
  const Trajectory& estimate() const { return estimate_; }

 private:
  static bool append(Trajectory* trajectory, const StampedPose& p) {
    if (!trajectory->empty() && p.timestamp_s <= trajectory->back().timestamp_s) return false;
    trajectory->push_back(p);
    return true;
  }

  double max_dt_s_;
  Trajectory ground_truth_, estimate_;
  Sim3Transform transform_;
  bool valid_ = false;
  double ate_rmse_m_ = 0.0, path_length_m_ = 0.0;
  size_t num_pairs_ = 0;
};

/// The node: messages in, RunningAlignment, messages out.
class AlignedPathNode {
 public:
  AlignedPathNode(ros::NodeHandle& nh, ros::NodeHandle& pnh)
      : align_every_(std::max(1, pnh.param("align_every", 10))),
        frame_id_(pnh.param("frame_id", std::string())),
        max_dt_s_(pnh.param("max_dt", 0.02)),
        alignment_(max_dt_s_) {
    if (!(max_dt_s_ > 0.0)) throw std::invalid_argument("~max_dt must be > 0 s");
    // The connect callbacks run on the spinner like the message callbacks; a subscriber that connects
    // between a skipped publish and the callback gets the stale latched message first, then the current one.
    path_pub_ = nh.advertise<nav_msgs::Path>(
        "vo/path_aligned", 1, [this](const ros::SingleSubscriberPublisher&) { onPathSubscriber(); },
        ros::SubscriberStatusCallback(), ros::VoidConstPtr(), true);
    ate_pub_ = nh.advertise<std_msgs::Float64>("vo/ate_m", 10, true);
    est_sub_ = nh.subscribe("vo/pose", 1000, &AlignedPathNode::onEstimate, this);
    gt_sub_ = nh.subscribe("ground_truth/pose", 1000, &AlignedPathNode::onGroundTruth, this);
    if (pnh.param("transform_map", true)) {
      map_pub_ = nh.advertise<sensor_msgs::PointCloud2>(
          "vo/map_points_aligned", 1, [this](const ros::SingleSubscriberPublisher&) { onMapSubscriber(); },
          ros::SubscriberStatusCallback(), ros::VoidConstPtr(), true);
      map_sub_ = nh.subscribe("vo/map_points", 2, &AlignedPathNode::onMap, this);
    }
    reset_srv_ = pnh.advertiseService("reset", &AlignedPathNode::onReset, this);
    const double period_s = pnh.param("align_period", 1.0);
    if (period_s > 0.0)
      timer_ = nh.createWallTimer(ros::WallDuration(period_s), &AlignedPathNode::onTimer, this);
  }

 private:
  /// No exception leaves a callback (a NaN pose, a failed alignment, an allocation): it is logged, the
  /// message dropped, the node continues.
  template <class Body>
  void contained(const char* where, Body&& body) {
    if (const std::optional<std::string> why = ros_io::runContained(std::forward<Body>(body))) {
      try {
        ROS_ERROR_STREAM_THROTTLE(5, "aligned_path_node: " << where << " failed: " << *why << " (ignored)");
      } catch (...) {
      }
    }
  }

  void onGroundTruth(const geometry_msgs::PoseStampedConstPtr& msg) {
    contained("onGroundTruth", [&] { onGroundTruthBody(msg); });
  }
  void onEstimate(const geometry_msgs::PoseStampedConstPtr& msg) {
    contained("onEstimate", [&] { onEstimateBody(msg); });
  }
  void onMap(const sensor_msgs::PointCloud2ConstPtr& msg) {
    contained("onMap", [&] { onMapBody(msg); });
  }
  void onPathSubscriber() {
    contained("onPathSubscriber", [&] { onPathSubscriberBody(); });
  }
  void onMapSubscriber() {
    contained("onMapSubscriber", [&] { onMapSubscriberBody(); });
  }
  void onTimer(const ros::WallTimerEvent& e) {
    contained("onTimer", [&] { onTimerBody(e); });
  }

  void onGroundTruthBody(const geometry_msgs::PoseStampedConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (gt_frame_.empty()) gt_frame_ = msg->header.frame_id;
    const double t = msg->header.stamp.toSec();
    if (!alignment_.addGroundTruth({t, fromPoseMsg(msg->pose)})) {
      ROS_WARN_THROTTLE(5,
                        "aligned_path_node: ground-truth stamp not increasing, pose ignored (call ~reset "
                        "after restarting the player or a bag)");
      return;
    }
    changed_ = true;
    // This pose came after an estimate it may pair with (see the file comment): while there is no alignment,
    // try now rather than wait for an estimate that may never come.
    const Trajectory& estimate = alignment_.estimate();
    if (!alignment_.valid() && !estimate.empty() && t <= estimate.back().timestamp_s + max_dt_s_) realign();
  }

  void onEstimateBody(const geometry_msgs::PoseStampedConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!alignment_.addEstimate({msg->header.stamp.toSec(), fromPoseMsg(msg->pose)})) {
      ROS_WARN_THROTTLE(5,
                        "aligned_path_node: vo/pose stamp not increasing, pose ignored (call ~reset after "
                        "vo/reset or a restarted bag)");
      return;
    }
    est_stamps_.push_back(msg->header.stamp);
    changed_ = true;
    // Until there is an alignment, try with every pose (cheap while short); then every align_every poses.
    if (!alignment_.valid() || ++since_update_ >= align_every_)
      realign();
    else
      publishPath();
  }

  void onMapBody(const sensor_msgs::PointCloud2ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    map_ = msg;
    publishMap();
  }

  void onPathSubscriberBody() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (path_skipped_) publishPath();
  }

  void onMapSubscriberBody() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (map_skipped_) publishMap();
  }

  void onTimerBody(const ros::WallTimerEvent&) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (changed_) realign();
  }

  bool onReset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res) {
    res.success = false;
    contained("onReset", [&] { onResetBody(req, res); });
    return true;
  }
  bool onResetBody(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    std::lock_guard<std::mutex> lock(mutex_);
    alignment_ = RunningAlignment(max_dt_s_);
    est_stamps_.clear();
    map_.reset();
    gt_frame_.clear();
    since_update_ = 0;
    changed_ = false;
    path_skipped_ = map_skipped_ = false;
    res.success = true;
    res.message = "aligned_path_node: trajectories and alignment cleared";
    return true;
  }

  /// Caller holds mutex_.
  void realign() {
    since_update_ = 0;
    changed_ = false;
    std::string why;
    if (!alignment_.update(&why)) {
      ROS_INFO_STREAM_THROTTLE(5, "aligned_path_node: no alignment yet: " << why);
      return;
    }
    std_msgs::Float64 ate;
    ate.data = alignment_.ateRmseM();
    ate_pub_.publish(ate);
    const Sim3Transform& S = alignment_.transform();
    ROS_INFO_STREAM_THROTTLE(
        10, "aligned_path_node: Sim(3) over "
                << alignment_.numPairs() << " pairs: scale " << S.scale << ", ATE " << ate.data << " m ("
                << 100.0 * ate.data / std::max(1e-9, alignment_.pathLengthM()) << " % of path)");
    publishPath();
    publishMap();
  }

  std::string outputFrame() const { return frame_id_.empty() ? gt_frame_ : frame_id_; }

  /// Caller holds mutex_.
  void publishPath() {
    if (!alignment_.valid()) return;
    path_skipped_ = path_pub_.getNumSubscribers() == 0;
    if (path_skipped_) return;
    const Trajectory& estimate = alignment_.estimate();
    nav_msgs::Path path;
    path.header.frame_id = outputFrame();
    path.header.stamp = est_stamps_.back();
    path.poses.reserve(estimate.size());
    for (size_t k = 0; k < estimate.size(); ++k)
      path.poses.push_back(toPoseStamped(alignment_.transform().transformPose(estimate[k].T_world_cam),
                                         makeHeader(est_stamps_[k], path.header.frame_id)));
    path_pub_.publish(path);
  }

  /// The map through the current Sim(3): x y z transformed, every other field copied. Caller holds mutex_.
  void publishMap() {
    if (!map_ || !alignment_.valid()) return;
    map_skipped_ = map_pub_.getNumSubscribers() == 0;
    if (map_skipped_) return;
    sensor_msgs::PointCloud2 cloud = *map_;
    cloud.header.frame_id = outputFrame();
    // No iterator over an empty cloud (the VO's map before its first points): it takes data.front() (UB).
    if (cloud.data.empty()) return map_pub_.publish(cloud);
    sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
    for (; x != x.end(); ++x, ++y, ++z) {
      const Eigen::Vector3d p = alignment_.transform().transformPoint(Eigen::Vector3d(*x, *y, *z));
      *x = static_cast<float>(p.x());
      *y = static_cast<float>(p.y());
      *z = static_cast<float>(p.z());
    }
    map_pub_.publish(cloud);
  }

  const int align_every_;
  const std::string frame_id_;
  const double max_dt_s_;
  std::mutex mutex_;  ///< the callbacks may run on several spinner threads
  RunningAlignment alignment_;
  std::vector<ros::Time> est_stamps_;  ///< exact stamps of alignment_.estimate()
  sensor_msgs::PointCloud2ConstPtr map_;
  std::string gt_frame_;
  int since_update_ = 0;
  bool changed_ = false;  ///< a pose arrived since the last realign()
  /// The last publishPath() / publishMap() found no subscriber: the latched message is out of date.
  bool path_skipped_ = false, map_skipped_ = false;
  ros::Publisher path_pub_, ate_pub_, map_pub_;
  ros::Subscriber est_sub_, gt_sub_, map_sub_;
  ros::ServiceServer reset_srv_;
  ros::WallTimer timer_;
};

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) {
  ros::init(argc, argv, "aligned_path_node");
  ros::NodeHandle nh, pnh("~");
  try {
    planetary_vo::ros_io::AlignedPathNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("aligned_path_node: " << e.what());
    return 1;
  }
  return 0;
}
