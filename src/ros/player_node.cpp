/// @file player_node.cpp
/// The `player` executable. `player --dataset DIR --bag OUT.bag` writes the stream into a bag and exits (no
/// master); otherwise it is the ROS node `player`, publishing the stream of player.h paced by ~rate, with
/// /clock, looping and pause/resume services. Parameters, topics and services: see the README table,
/// docs/ros_interface.md ("Dataset player in a launch") and launch/player.launch.
///
/// For launches that must not lose a frame and must end by themselves (scripts/demo.sh):
/// ~wait_for_subscribers holds the first message until camera/image_raw and camera/camera_info each have that
/// many subscribers (and ground_truth/pose ~wait_for_ground_truth_subscribers, e.g. a recorder);
/// ~exit_when_done ends the node after a non-looping run (so `required="true"` ends roslaunch), after
/// waiting, when ~exit_ack_topic is set, until a message on that topic carries the stamp of the last image
/// (e.g. the VO's vo/status, one per image: every image has been processed). Both waits give up after
/// ~wait_timeout.
///
/// ~publish_initial_state (default false) publishes, latched and once, the dataset's ground-truth state at
/// the first image on nav/initial_state: the guidance handover of the fused navigation modes, and the only
/// ground truth meant for the navigation (player.h initialStateMessage()).

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <iostream>
#include <mutex>
#include <string>
#include <vector>

#include <image_transport/image_transport.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <ros/topic_manager.h>
#include <rosgraph_msgs/Clock.h>
#include <std_msgs/Header.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/transform_broadcaster.h>
#include <topic_tools/shape_shifter.h>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/ros_io/player.h"

namespace planetary_vo::ros_io {
namespace {

/// Publishes the stream on the node's topics.
class LivePublisher : public PlayerSink {
 public:
  LivePublisher(ros::NodeHandle& nh, int queue_size, bool publish_clock) : image_transport_(nh) {
    camera_pub_ = image_transport_.advertiseCamera(player_topics::kImage, queue_size);
    // A CameraPublisher counts image and camera_info subscribers together (the larger count); a
    // CameraSubscriber needs both connections, so the wait asks for each one (see numCameraSubscribers()).
    image_topic_ = nh.resolveName(player_topics::kImage);
    info_topic_ = nh.resolveName(player_topics::kCameraInfo);
    pose_pub_ = nh.advertise<geometry_msgs::PoseStamped>(player_topics::kGroundTruthPose, queue_size);
    path_pub_ = nh.advertise<nav_msgs::Path>(player_topics::kGroundTruthPath, queue_size);
    imu_pub_ = nh.advertise<sensor_msgs::Imu>(player_topics::kImu, queue_size);
    altimeter_pub_ = nh.advertise<sensor_msgs::Range>(player_topics::kAltimeter, queue_size);
    if (publish_clock) clock_pub_ = nh.advertise<rosgraph_msgs::Clock>(player_topics::kClock, queue_size);
  }

  /// The guidance handover, latched: a subscriber that connects later still gets it.
  void publishInitialState(ros::NodeHandle& nh, const nav_msgs::Odometry& state) {
    initial_state_pub_ = nh.advertise<nav_msgs::Odometry>(player_topics::kInitialState, 1, true);
    initial_state_pub_.publish(state);
  }
  size_t numInitialStateSubscribers() const { return initial_state_pub_.getNumSubscribers(); }

  /// Subscribers of the camera: the smaller of the image and camera_info subscriber counts, i.e. how many
  /// subscribers would receive both halves of an image published now.
  size_t numCameraSubscribers() const {
    return std::min(ros::TopicManager::instance()->getNumSubscribers(image_topic_),
                    ros::TopicManager::instance()->getNumSubscribers(info_topic_));
  }

  size_t numGroundTruthSubscribers() const { return pose_pub_.getNumSubscribers(); }

  void emit(const PlayerMessage& m) override {
    if (clock_pub_) {
      rosgraph_msgs::Clock clock;
      clock.clock = m.stamp;
      clock_pub_.publish(clock);
    }
    switch (m.kind) {
      case StreamKind::kImu:
        imu_pub_.publish(m.imu);
        break;
      case StreamKind::kAltimeter:
        altimeter_pub_.publish(m.altimeter);
        break;
      case StreamKind::kImage:
        if (!m.image) {
          ROS_ERROR_STREAM_THROTTLE(5, "player: " << m.skipped << " (the stream goes on)");
          break;
        }
        camera_pub_.publish(m.image, m.camera_info);
        if (m.has_ground_truth) {
          pose_pub_.publish(m.gt_pose);
          if (m.gt_path) path_pub_.publish(m.gt_path);
          tf_broadcaster_.sendTransform(m.gt_transform);
        }
        break;
    }
  }

 private:
  image_transport::ImageTransport image_transport_;
  image_transport::CameraPublisher camera_pub_;
  std::string image_topic_, info_topic_;
  ros::Publisher pose_pub_, path_pub_, imu_pub_, altimeter_pub_, clock_pub_, initial_state_pub_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
};

PlayerOptions readOptions(ros::NodeHandle& pnh, const PlayerCommandLine& cl) {
  PlayerOptions o;
  pnh.param("world_frame", o.world_frame, o.world_frame);
  pnh.param("camera_frame", o.camera_frame, o.camera_frame);
  pnh.param("altimeter_frame", o.altimeter_frame, o.altimeter_frame);
  pnh.param("ground_truth_frame", o.ground_truth_frame, o.ground_truth_frame);
  pnh.param("time_offset", o.time_offset_s, o.time_offset_s);
  int start = 0;
  pnh.param("start", start, start);
  if (start < 0) throw std::invalid_argument("~start must be >= 0, got " + std::to_string(start));
  o.start_index = static_cast<size_t>(start);
  pnh.param("loop", o.loop, o.loop);
  pnh.param("publish_path", o.publish_path, o.publish_path);
  pnh.param("cache_images", o.cache_images, o.cache_images);
  pnh.param("sensor_spec_from_dataset", o.sensor_spec_from_dataset, o.sensor_spec_from_dataset);
  pnh.param("publish_initial_state", o.publish_initial_state, o.publish_initial_state);
  applyCommandLine(cl, &o);
  return o;
}

std::string datasetDirectory(ros::NodeHandle& pnh, const PlayerCommandLine& cl) {
  if (cl.dataset) return *cl.dataset;
  std::string directory;
  if (!pnh.getParam("dataset", directory) || directory.empty())
    throw std::invalid_argument("no dataset: set ~dataset or pass --dataset DIR");
  return directory;
}

/// The live node: paces the Player's stream on the wall clock and serves ~pause / ~resume.
class PlayerNode {
 public:
  using Clock = std::chrono::steady_clock;

  explicit PlayerNode(const PlayerCommandLine& cl)
      : pnh_("~"),
        dataset_(Dataset::open(datasetDirectory(pnh_, cl))),
        player_(dataset_, readOptions(pnh_, cl)),
        rate_(pnh_.param("rate", 1.0)),
        sink_(nh_, std::max(1, pnh_.param("queue_size", 100)), pnh_.param("publish_clock", false)),
        paused_(pnh_.param("start_paused", false)),
        exit_when_done_(pnh_.param("exit_when_done", false)),
        wait_for_subscribers_(pnh_.param("wait_for_subscribers", 0)),
        wait_for_gt_subscribers_(pnh_.param("wait_for_ground_truth_subscribers", 0)),
        wait_timeout_s_(pnh_.param("wait_timeout", 30.0)) {
    if (!(rate_ >= 0.0)) throw std::invalid_argument("~rate must be >= 0 (0: as fast as possible)");
    if (wait_for_subscribers_ < 0 || wait_for_gt_subscribers_ < 0)
      throw std::invalid_argument(
          "~wait_for_subscribers and ~wait_for_ground_truth_subscribers must be >= 0");
    if (!(wait_timeout_s_ >= 0.0)) throw std::invalid_argument("~wait_timeout must be >= 0 s");
    if (exit_when_done_ && player_.options().loop) {
      ROS_WARN("player: ~exit_when_done is ignored with ~loop (the stream never ends)");
      exit_when_done_ = false;
    }
    const std::string ack_topic = pnh_.param("exit_ack_topic", std::string());
    if (exit_when_done_ && !ack_topic.empty())
      ack_sub_ = nh_.subscribe(ack_topic, 100, &PlayerNode::onAck, this);
    if (player_.options().publish_initial_state) {
      std::string why;
      initial_state_ = initialStateMessage(player_, &why);
      if (!initial_state_) throw std::invalid_argument("~publish_initial_state: " + why);
      // At once, latched: the navigation connects while the player waits for its subscribers, so the state
      // is there before the first image (which it belongs to).
      sink_.publishInitialState(nh_, *initial_state_);
      ROS_INFO_STREAM("player: initial state (ground truth at the first image, the guidance handover) on "
                      << ros::names::resolve(player_topics::kInitialState));
    }
    origin_ = Clock::now();
    pause_started_ = origin_;
    pause_srv_ = pnh_.advertiseService("pause", &PlayerNode::onPause, this);
    resume_srv_ = pnh_.advertiseService("resume", &PlayerNode::onResume, this);
    ROS_INFO_STREAM("player: " << dataset_.name() << " (" << toString(dataset_.format()) << ", "
                               << dataset_.size() << " images, " << dataset_.imu().size() << " IMU, "
                               << dataset_.altimeter().size() << " altimeter samples), stamps = "
                               << player_.epoch().toSec() << " s + dataset time, rate " << rate_
                               << (player_.options().loop ? ", looping" : "") << (paused_ ? ", paused" : ""));
  }

  /// Publishes until the stream ends (never with ~loop) or ROS shuts down.
  void run() {
    const std::chrono::milliseconds kPoll(100);  // bound on the reaction to a shutdown request
    const std::optional<ros::Time> first = player_.nextStamp();
    std::unique_lock<std::mutex> lock(mutex_);
    waitForSubscribers(lock);
    origin_ = Clock::now();  // the schedule starts once the subscribers are there
    if (paused_) pause_started_ = origin_;
    PlayerMessage message;
    while (ros::ok()) {
      const std::optional<ros::Time> stamp = player_.nextStamp();
      if (!stamp) break;
      if (paused_) {
        resumed_.wait_for(lock, kPoll);
        continue;
      }
      if (rate_ > 0.0) {
        const auto due = origin_ + std::chrono::duration_cast<Clock::duration>(
                                       std::chrono::duration<double>((*stamp - *first).toSec() / rate_));
        const auto now = Clock::now();
        if (now < due) {
          resumed_.wait_until(lock, std::min(due, now + kPoll));
          continue;
        }
      }
      player_.next(&message);
      sink_.emit(message);
      if (message.kind == StreamKind::kImage && message.image) {
        ++images_published_;
        last_image_stamp_ = message.stamp;
      }
    }
    if (!ros::ok()) return;
    if (!exit_when_done_) {
      ROS_INFO_STREAM("player: done, " << images_published_
                                       << " images published; the node stays up until shutdown");
      return;
    }
    waitForAck(lock);
    ROS_INFO_STREAM("player: done, " << images_published_ << " images published; exiting (~exit_when_done)");
  }

  bool exitWhenDone() const { return exit_when_done_; }

 private:
  bool onPause(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    // Taken while no message is being emitted: once this returns, nothing more is published until ~resume.
    std::lock_guard<std::mutex> lock(mutex_);
    if (!paused_) {
      paused_ = true;
      pause_started_ = Clock::now();
    }
    res.success = true;
    res.message = "paused after " + std::to_string(images_published_) + " images";
    return true;
  }

  bool onResume(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (paused_) {
      paused_ = false;
      origin_ += Clock::now() - pause_started_;  // the schedule continues where it stopped
      resumed_.notify_all();
    }
    res.success = true;
    res.message = "resumed after " + std::to_string(images_published_) + " images";
    return true;
  }

  /// Holds the first message until the camera has ~wait_for_subscribers subscribers and ground_truth/pose
  /// ~wait_for_ground_truth_subscribers (or ~wait_timeout passed).
  void waitForSubscribers(std::unique_lock<std::mutex>& lock) {
    const size_t camera = static_cast<size_t>(wait_for_subscribers_);
    const size_t ground_truth = static_cast<size_t>(wait_for_gt_subscribers_);
    // With ~publish_initial_state, the camera's subscribers are the navigation: they need the handover too.
    const size_t initial_state = initial_state_ ? camera : 0;
    auto connected = [&] {
      return sink_.numCameraSubscribers() >= camera && sink_.numGroundTruthSubscribers() >= ground_truth &&
             sink_.numInitialStateSubscribers() >= initial_state;
    };
    if (connected()) return;
    const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(wait_timeout_s_));
    ROS_INFO_STREAM("player: waiting for " << camera << " subscriber(s) of "
                                           << ros::names::resolve(player_topics::kImage)
                                           << " and camera_info, " << ground_truth << " of "
                                           << ros::names::resolve(player_topics::kGroundTruthPose));
    // Connections are made by roscpp's own threads; nothing notifies us, so the counts are polled.
    while (ros::ok() && !connected() && Clock::now() < deadline)
      resumed_.wait_for(lock, std::chrono::milliseconds(20));
    if (ros::ok() && !connected())
      ROS_WARN_STREAM("player: after "
                      << wait_timeout_s_ << " s (~wait_timeout) only " << sink_.numCameraSubscribers()
                      << " of " << camera << " camera subscriber(s) and " << sink_.numGroundTruthSubscribers()
                      << " of " << ground_truth << " ground-truth subscriber(s); publishing anyway");
  }

  /// With ~exit_ack_topic: waits until a message on it carries the stamp of the last image (or later).
  void waitForAck(std::unique_lock<std::mutex>& lock) {
    if (!ack_sub_ || images_published_ == 0) return;
    const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(wait_timeout_s_));
    // Polled at 100 ms only to notice a shutdown request; an ack wakes the wait at once.
    while (ros::ok() && ack_stamp_ < last_image_stamp_ && Clock::now() < deadline)
      acked_.wait_until(lock, std::min(deadline, Clock::now() + std::chrono::milliseconds(100)));
    if (ros::ok() && ack_stamp_ < last_image_stamp_)
      ROS_WARN_STREAM("player: no message on " << ack_sub_.getTopic() << " with the last image stamp "
                                               << last_image_stamp_ << " after " << wait_timeout_s_
                                               << " s (~wait_timeout); exiting anyway");
  }

  /// Any message type whose first field is a std_msgs/Header (as every stamped message): its stamp.
  void onAck(const topic_tools::ShapeShifter::ConstPtr& msg) {
    try {  // no exception leaves a callback
      onAckBody(msg);
    } catch (const std::exception& e) {
      ROS_ERROR_STREAM_THROTTLE(5, "player: " << ack_sub_.getTopic() << " message ignored: " << e.what());
    } catch (...) {
      ROS_ERROR_STREAM_THROTTLE(5,
                                "player: " << ack_sub_.getTopic() << " message ignored: unknown exception");
    }
  }
  void onAckBody(const topic_tools::ShapeShifter::ConstPtr& msg) {
    std::vector<uint8_t> buffer(msg->size());
    ros::serialization::OStream out(buffer.data(), static_cast<uint32_t>(buffer.size()));
    msg->write(out);
    std_msgs::Header header;
    try {
      ros::serialization::IStream in(buffer.data(), static_cast<uint32_t>(buffer.size()));
      ros::serialization::deserialize(in, header);
    } catch (const ros::serialization::StreamOverrunException&) {
      ROS_WARN_STREAM_THROTTLE(5, "player: " << ack_sub_.getTopic() << " (" << msg->getDataType()
                                             << ") does not start with a std_msgs/Header; ignored");
      return;
    }
    std::lock_guard<std::mutex> guard(mutex_);
    if (header.stamp > ack_stamp_) ack_stamp_ = header.stamp;
    acked_.notify_all();
  }

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  Dataset dataset_;
  Player player_;
  double rate_;
  LivePublisher sink_;
  std::mutex mutex_;
  std::condition_variable resumed_;
  bool paused_;
  Clock::time_point origin_;  ///< wall time of the first message, shifted by the time spent paused
  Clock::time_point pause_started_;
  size_t images_published_ = 0;
  bool exit_when_done_;
  int wait_for_subscribers_;
  int wait_for_gt_subscribers_;
  double wait_timeout_s_;
  ros::Subscriber ack_sub_;        ///< ~exit_ack_topic
  std::condition_variable acked_;  ///< ack_stamp_ moved
  ros::Time ack_stamp_;            ///< latest stamp seen on ~exit_ack_topic
  ros::Time last_image_stamp_;     ///< of the last image published
  ros::ServiceServer pause_srv_, resume_srv_;
  std::optional<nav_msgs::Odometry> initial_state_;  ///< ~publish_initial_state
};

}  // namespace
}  // namespace planetary_vo::ros_io

int main(int argc, char** argv) {
  using namespace planetary_vo::ros_io;
  const bool bag_mode =
      std::any_of(argv + 1, argv + argc, [](const char* a) { return std::strcmp(a, "--bag") == 0; });
  if (!bag_mode) ros::init(argc, argv, "player");  // removes remappings and _param:=value from argv
  try {
    const PlayerCommandLine cl = parsePlayerCommandLine(std::vector<std::string>(argv + 1, argv + argc));
    if (cl.help) {
      std::cout << playerUsage();
      return 0;
    }
    if (bag_mode) {
      if (!cl.dataset) throw std::invalid_argument("--bag needs --dataset DIR");
      const planetary_vo::Dataset dataset = planetary_vo::Dataset::open(*cl.dataset);
      PlayerOptions options;
      applyCommandLine(cl, &options);
      const size_t count = writeBag(dataset, options, *cl.bag);
      std::cout << "player: wrote " << count << " messages of " << dataset.name() << " to " << *cl.bag
                << "\n";
      return 0;
    }
    PlayerNode node(cl);
    ros::AsyncSpinner spinner(1);  // services
    spinner.start();
    node.run();
    if (!node.exitWhenDone()) ros::waitForShutdown();
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "player: " << e.what() << "\n" << playerUsage();
    return 1;
  }
}
