/// gtest node of the VO end-to-end rostests (vo_end_to_end.test: player node; vo_bag.test: rosbag play of a
/// bag written by `player --bag`). Collects vo/pose, vo/status, vo/map_points, vo/map_events (checked with
/// fromMsg: points added, every keyframe message with its image) and ground_truth/pose while a
/// rendered Lunar sequence streams through the VO nodelet, then checks the accuracy after Sim(3) alignment,
/// the map, the tf world -> camera and the status stream.
///
/// Private parameters:
///   ~dataset (string)            the rendered dataset the stream comes from (image count and stamps)
///   ~live (bool, true)           the player runs with ~start_paused: wait until the nodelet and this node
///   are
///                                connected, then call /player/resume
///   ~max_ate_percent (double, 5) bound on the ATE RMSE in percent of the ground-truth path length
///   ~world_frame, ~camera_frame  frames of the tf lookup ("world", "camera_optical")
///   ~manager, ~player (string)   node names of the nodelet manager and the player ("/vo_manager", "/player")
///   ~timeout (double, 120)       seconds to wait for the whole stream
///   ~reconfigure (bool, false)   vo_reconfigure.test: once 15 frames are tracked, change the
///                                dynamic_reconfigure knobs five times three frames apart
///                                (~node/set_parameters) and check that the pipeline is changed in place:
///                                every frame tracked after the first, full scale confidence, and the scale
///                                of the part before the first change fitting every later step
///   ~node (string, "/vo")        the VO nodelet's name (its set_parameters service)
///   ~cpu_budget_steps (int, 0)   vo_reconfigure.test runs the nodelet with a CPU budget it cannot meet
///                                (cpu_budget/frame_budget_ms): its status must report the budget's steps
///                                down to this one, the lightest, and never a refused step

#include <algorithm>
#include <cmath>
#include <functional>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <dynamic_reconfigure/Reconfigure.h>
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "planetary_vo/VoMapEvents.h"
#include "planetary_vo/VoStatus.h"
#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/eval/trajectory_metrics.h"
#include "planetary_vo/ros_io/conversions.h"
#include "planetary_vo/ros_io/map_event_conversions.h"
#include "planetary_vo/ros_io/ros_params.h"
#include "test_ros_helpers.h"

namespace planetary_vo::ros_io {
namespace {

class VoEndToEndTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::NodeHandle pnh("~");
    ASSERT_TRUE(pnh.getParam("dataset", dataset_dir_));
    live_ = pnh.param("live", true);
    max_ate_percent_ = pnh.param("max_ate_percent", 5.0);
    world_frame_ = pnh.param<std::string>("world_frame", "world");
    camera_frame_ = pnh.param<std::string>("camera_frame", "camera_optical");
    timeout_s_ = pnh.param("timeout", 120.0);
    manager_ = pnh.param<std::string>("manager", "/vo_manager");
    player_ = pnh.param<std::string>("player", "/player");
    reconfigure_ = pnh.param("reconfigure", false);
    cpu_budget_steps_ = pnh.param("cpu_budget_steps", 0);
    node_ = pnh.param<std::string>("node", "/vo");
    dataset_ = std::make_unique<Dataset>(Dataset::open(dataset_dir_));
    subs_.push_back(nh_.subscribe("vo/pose", 1000, &VoEndToEndTest::onPose, this));
    subs_.push_back(nh_.subscribe("vo/status", 1000, &VoEndToEndTest::onStatus, this));
    subs_.push_back(nh_.subscribe("vo/map_points", 10, &VoEndToEndTest::onMap, this));
    subs_.push_back(nh_.subscribe("vo/map_events", 1000, &VoEndToEndTest::onMapEvents, this));
    subs_.push_back(nh_.subscribe("ground_truth/pose", 1000, &VoEndToEndTest::onGroundTruth, this));
    subs_.push_back(nh_.subscribe("vo/path", 1000, &VoEndToEndTest::onPath, this));
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_, nh_);
  }

  void onPose(const geometry_msgs::PoseStampedConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    poses_.push_back(*m);
  }
  void onStatus(const VoStatusConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!m->header.stamp.isZero()) statuses_.push_back(*m);  // zero stamp: the watchdog's "no input" status
  }
  void onMap(const sensor_msgs::PointCloud2ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    max_map_points_ = std::max<size_t>(max_map_points_, m->width * m->height);
    map_fields_ = m->fields.size();
  }
  /// vo/map_events: counts, and every message must pass fromMsg's checks.
  void onMapEvents(const VoMapEventsConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++map_events_.messages;
    try {
      cv::Mat image;
      const MapEvents e = fromMsg(*m, ros::Time(), &image);
      map_events_.points_added += e.points_added.size();
      map_events_.keyframes += e.keyframes_added.size();
      if (!e.keyframes_added.empty()) ++map_events_.keyframe_messages;
      // The image is the frame's, which added the last keyframe of the message.
      if (!image.empty() && m->keyframe_image.header.stamp == m->header.stamp &&
          m->keyframe_stamps.back() == m->header.stamp)
        ++map_events_.images;
      if (m->header.frame_id != world_frame_) ++map_events_.bad;
    } catch (const std::invalid_argument& e) {
      ++map_events_.bad;
      ADD_FAILURE() << e.what();
    }
  }
  void onPath(const nav_msgs::PathConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    path_sizes_.push_back(m->poses.size());
    path_wall_s_.push_back(ros::WallTime::now().toSec());
    last_path_ = *m;
  }
  void onGroundTruth(const geometry_msgs::PoseStampedConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    ground_truth_.push_back(*m);
  }

  /// True once the status of the last image of the dataset arrived.
  bool streamDone() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (ground_truth_.size() < dataset_->size()) return false;
    const ros::Time last = ground_truth_.back().header.stamp;
    return !statuses_.empty() && statuses_.back().header.stamp >= last;
  }

  size_t numStatuses() {
    std::lock_guard<std::mutex> lock(mutex_);
    return statuses_.size();
  }
  size_t numTracked() {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::count_if(statuses_.begin(), statuses_.end(),
                         [](const VoStatus& s) { return s.state == VoStatus::STATE_TRACKING; });
  }

  /// Five knob changes three frames apart through ~node/set_parameters; the stamp of the last status before
  /// the first change goes to *before.
  void changeKnobs(ros::Time* before) {
    using Edit = std::function<void(dynamic_reconfigure::Config*)>;
    auto intKnob = [](const char* name, int value) {
      return Edit([=](dynamic_reconfigure::Config* c) {
        dynamic_reconfigure::IntParameter p;
        p.name = name;
        p.value = value;
        c->ints.push_back(p);
      });
    };
    auto strKnob = [](const char* name, const char* value) {
      return Edit([=](dynamic_reconfigure::Config* c) {
        dynamic_reconfigure::StrParameter p;
        p.name = name;
        p.value = value;
        c->strs.push_back(p);
      });
    };
    auto boolKnob = [](const char* name, bool value) {
      return Edit([=](dynamic_reconfigure::Config* c) {
        dynamic_reconfigure::BoolParameter p;
        p.name = name;
        p.value = value;
        c->bools.push_back(p);
      });
    };
    const std::vector<Edit> edits = {intKnob("num_features", 600), strKnob("motion_model", "essential"),
                                     boolKnob("bundle_adjustment_enabled", false),
                                     intKnob("num_features", 200),
                                     boolKnob("bundle_adjustment_enabled", true)};
    ASSERT_TRUE(ros::service::waitForService(node_ + "/set_parameters", ros::Duration(30.0)));
    ASSERT_TRUE(waitFor([&] { return numTracked() >= 15; }, timeout_s_)) << "15 frames never tracked";
    {
      std::lock_guard<std::mutex> lock(mutex_);
      *before = statuses_.back().header.stamp;
    }
    for (const Edit& edit : edits) {
      dynamic_reconfigure::Reconfigure srv;
      edit(&srv.request.config);
      ASSERT_TRUE(ros::service::call(node_ + "/set_parameters", srv));
      const size_t seen = numStatuses();
      ASSERT_TRUE(waitFor([&] { return numStatuses() >= seen + 3; }, timeout_s_));
    }
  }

  ros::NodeHandle nh_;
  std::string dataset_dir_, world_frame_, camera_frame_, manager_, player_, node_;
  bool live_ = true, reconfigure_ = false;
  int cpu_budget_steps_ = 0;
  double max_ate_percent_ = 5.0, timeout_s_ = 120.0;
  std::unique_ptr<Dataset> dataset_;
  std::vector<ros::Subscriber> subs_;
  tf2_ros::Buffer tf_buffer_{ros::Duration(600.0)};
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::mutex mutex_;
  std::vector<size_t> path_sizes_;
  std::vector<double> path_wall_s_;
  nav_msgs::Path last_path_;
  std::vector<geometry_msgs::PoseStamped> poses_, ground_truth_;
  std::vector<VoStatus> statuses_;
  size_t max_map_points_ = 0, map_fields_ = 0;
  struct {
    size_t messages = 0, points_added = 0, keyframes = 0, keyframe_messages = 0, images = 0, bad = 0;
  } map_events_;
};

TEST_F(VoEndToEndTest, TracksTheRenderedDescent) {
  if (live_) {
    // Start the paused player once the nodelet is connected to the camera and this node to the outputs, as
    // the publishers see it: whatever they publish before they have accepted a subscriber is lost for it
    // (see allConnected()), and a lost ground-truth pose would leave the stream incomplete.
    ASSERT_TRUE(
        resumePlayerWhenConnected(player_, manager_, {"/camera/image_raw", "/camera/camera_info"}, subs_));
  }
  ros::Time before_change;
  if (reconfigure_) {
    ASSERT_NO_FATAL_FAILURE(changeKnobs(&before_change));
  }
  ASSERT_TRUE(waitFor([&] { return streamDone(); }, timeout_s_))
      << "stream incomplete: " << ground_truth_.size() << " ground-truth poses, " << statuses_.size()
      << " statuses of " << dataset_->size() << " images";

  std::lock_guard<std::mutex> lock(mutex_);
  // Status: one per image, stamped with the image stamp, none rejected as bad input.
  std::set<ros::Time> image_stamps;
  for (const auto& gt : ground_truth_) image_stamps.insert(gt.header.stamp);
  std::set<ros::Time> tracked;
  for (const VoStatus& s : statuses_) {
    EXPECT_TRUE(image_stamps.count(s.header.stamp)) << "status stamp is not an image stamp";
    EXPECT_NE(s.state, VoStatus::STATE_BAD_INPUT) << s.message;
    if (s.state == VoStatus::STATE_TRACKING || s.state == VoStatus::STATE_RECOVERED)
      tracked.insert(s.header.stamp);
  }
  EXPECT_GE(statuses_.size(), dataset_->size() * 9 / 10);
  EXPECT_GE(tracked.size(), dataset_->size() / 2) << "the pipeline tracked too few frames";
  EXPECT_GT(statuses_.back().num_imu_msgs + statuses_.back().num_altimeter_msgs, 0u)
      << "imu / altimeter not counted";

  // Accuracy: vo/pose of tracked frames against the ground truth, Sim(3)-aligned.
  Trajectory estimate, ground_truth;
  for (const auto& p : poses_) {
    const Pose T = fromPoseMsg(p.pose);
    ASSERT_TRUE(T.matrix().allFinite()) << "NaN pose at " << p.header.stamp;
    EXPECT_EQ(p.header.frame_id, world_frame_);
    if (tracked.count(p.header.stamp)) estimate.push_back({p.header.stamp.toSec(), T});
  }
  for (const auto& g : ground_truth_) ground_truth.push_back({g.header.stamp.toSec(), fromPoseMsg(g.pose)});
  EvaluationOptions options;
  options.max_dt_s = 1e-3;
  const TrajectoryEvaluation eval = evaluateTrajectory(ground_truth, estimate, options);
  std::printf("end-to-end: %zu images, %zu tracked, ATE RMSE %.3f m = %.2f %% of %.1f m path, scale %.3f\n",
              dataset_->size(), estimate.size(), eval.ate_m.rmse, eval.ate_rmse_percent,
              eval.gt_path_length_m, eval.alignment.scale);
  EXPECT_LT(eval.ate_rmse_percent, max_ate_percent_);
  EXPECT_GE(eval.num_associated, dataset_->size() / 2);

  // Map: x y z + observation count, not empty.
  EXPECT_GT(max_map_points_, 0u);
  EXPECT_EQ(map_fields_, 4u);

  // Map events: keyframes with their image, points added, in the world frame, all valid.
  EXPECT_GT(map_events_.messages, 0u);
  EXPECT_GT(map_events_.points_added, 0u);
  EXPECT_GT(map_events_.keyframes, 0u);
  EXPECT_EQ(map_events_.images, map_events_.keyframe_messages) << "a keyframe came without its image";
  EXPECT_EQ(map_events_.bad, 0u);
  std::printf("map events: %zu messages, %zu keyframes (%zu images), %zu points added\n",
              map_events_.messages, map_events_.keyframes, map_events_.images, map_events_.points_added);

  // tf world -> camera at the last pose's stamp equals that pose.
  const geometry_msgs::PoseStamped& last = poses_.back();
  geometry_msgs::TransformStamped tf;
  ASSERT_NO_THROW(
      tf = tf_buffer_.lookupTransform(world_frame_, camera_frame_, last.header.stamp, ros::Duration(5.0)));
  EXPECT_NEAR(tf.transform.translation.x, last.pose.position.x, 1e-9);
  EXPECT_NEAR(tf.transform.translation.z, last.pose.position.z, 1e-9);

  // vo/path (issue 12: it grew without bound and went out with every frame): at most ~max_path_length
  // poses, at most one message per ~path_publish_period_s, and its poses are the last vo/pose messages.
  NodeletParams defaults;
  const int max_path = ros::param::param(node_ + "/max_path_length", defaults.max_path_length);
  const double path_period_s =
      ros::param::param(node_ + "/path_publish_period_s", defaults.path_publish_period_s);
  ASSERT_GE(path_sizes_.size(), 1u) << "no vo/path";
  for (size_t n : path_sizes_) EXPECT_LE(int(n), max_path);
  const double path_span_s = path_wall_s_.back() - path_wall_s_.front();
  EXPECT_LE(double(path_sizes_.size()), path_span_s / path_period_s + 2.0)
      << path_sizes_.size() << " vo/path messages in " << path_span_s << " s";
  ASSERT_FALSE(last_path_.poses.empty());
  const auto in_poses = std::find_if(poses_.begin(), poses_.end(), [&](const geometry_msgs::PoseStamped& p) {
    return p.header.stamp == last_path_.poses.back().header.stamp;
  });
  EXPECT_NE(in_poses, poses_.end()) << "the path's last pose is not a vo/pose";
  std::printf("vo/path: %zu messages in %.1f s (period %.2f s), at most %zu poses (limit %d)\n",
              path_sizes_.size(), path_span_s, path_period_s,
              *std::max_element(path_sizes_.begin(), path_sizes_.end()), max_path);

  if (cpu_budget_steps_ > 0) {
    // The budget's steps went into the running pipeline (the checks below and above hold with them).
    int steps = 0, lightest = 0;
    for (const VoStatus& s : statuses_) {
      EXPECT_EQ(s.message.find("cpu budget step refused"), std::string::npos) << s.message;
      if (s.message.find("cpu budget:") != std::string::npos) ++steps;
      if (s.message.find("step " + std::to_string(cpu_budget_steps_) + " (") != std::string::npos) ++lightest;
    }
    EXPECT_GE(steps, cpu_budget_steps_) << "the CPU budget's steps did not reach the pipeline";
    EXPECT_GE(lightest, 1) << "never reached the lightest step, " << cpu_budget_steps_;
    std::printf("cpu budget: %d steps reported, %d to the lightest\n", steps, lightest);
  }
  if (!reconfigure_) return;
  // The knob changes went into the running pipeline: no re-initialisation (every status after the first
  // tracked one is TRACKING at full scale confidence), the changes were applied and none refused, and the
  // scale of the trajectory before the first change (Sim(3) alignment of that part) fits every later step.
  bool started = false;
  int applied = 0;
  for (const VoStatus& s : statuses_) {
    started = started || s.state == VoStatus::STATE_TRACKING;
    if (started) {
      EXPECT_EQ(s.state, VoStatus::STATE_TRACKING) << s.header.stamp << ": " << s.message;
      EXPECT_EQ(s.scale_confidence, 1.0f) << s.header.stamp << ": " << s.message;
    }
    EXPECT_EQ(s.message.find("reconfigure rejected"), std::string::npos) << s.message;
    if (s.message.find("reconfigured:") != std::string::npos) ++applied;
  }
  EXPECT_GE(applied, 4) << "the knob changes did not reach the pipeline";
  options.align_num_pairs =
      static_cast<size_t>(std::count_if(estimate.begin(), estimate.end(), [&](const StampedPose& p) {
        return p.timestamp_s <= before_change.toSec();
      }));
  ASSERT_GE(options.align_num_pairs, 10u);
  const TrajectoryEvaluation first_part = evaluateTrajectory(ground_truth, estimate, options);
  auto truthAt = [&](double t) -> Eigen::Vector3d {
    for (const StampedPose& g : ground_truth)
      if (std::abs(g.timestamp_s - t) < 1e-3) return g.T_world_cam.translation();
    ADD_FAILURE() << "no ground truth at " << t;
    return Eigen::Vector3d::Zero();
  };
  double worst = 1.0;
  for (size_t k = options.align_num_pairs; k < estimate.size(); ++k) {
    const double step =
        first_part.alignment.scale *
        (estimate[k].T_world_cam.translation() - estimate[k - 1].T_world_cam.translation()).norm();
    const double truth = (truthAt(estimate[k].timestamp_s) - truthAt(estimate[k - 1].timestamp_s)).norm();
    const double ratio = step / truth;
    if (std::max(ratio, 1.0 / ratio) > std::max(worst, 1.0 / worst)) worst = ratio;
    EXPECT_LT(std::max(ratio, 1.0 / ratio), 1.5)
        << "step at t = " << estimate[k].timestamp_s << " is x" << ratio
        << " the true one with the scale before the changes";
  }
  std::printf("reconfigure: %d changes applied, worst step ratio after them %.3f\n", applied, worst);
}

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) { return planetary_vo::ros_io::runRosTests(argc, argv, "test_vo_node"); }
