#pragma once
/// @file player.h
/// Core of the dataset player: turns any Dataset the reader opens into one time-ordered stream of ROS
/// messages. The live node (src/ros/player_node.cpp) and the bag writer consume the same stream through
/// PlayerSink, so a bag written with `player --dataset DIR --bag OUT.bag` and played with `rosbag play` gives
/// what the node publishes.
///
/// Stream: every image (with its CameraInfo and, when the dataset has ground truth, a PoseStamped, the Path
/// so far and a world -> ground-truth-frame transform), every IMU sample and every altimeter sample, sorted
/// by dataset time. At equal times: IMU first, then altimeter, then the image, so a consumer has the inertial
/// data up to an image when the image arrives.
///
/// Stamps: stamp = epoch + dataset time, epoch = PlayerOptions::time_offset_s. A negative offset (the
/// default) means "auto": 1.0e9 s (2001-09-09) when the dataset's first time is below 1.0e6 s (a relative
/// clock, as KITTI's index / 10 Hz, where ros::Time(0) would be an invalid stamp for tf), otherwise 0 (the
/// dataset already carries epoch stamps, as EuRoC does). Loop n (n = 0, 1, ...) adds n * loopPeriod() to
/// every dataset time, so stamps never go backwards when looping.

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Range.h>
#include <opencv2/core.hpp>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/ros_io/conversions.h"

namespace planetary_vo::ros_io {

/// Topic names, relative to the node's namespace. The bag writer records them under "/" + name, and ground
/// truth tf goes to /tf (tf2_msgs/TFMessage), as a tf2_ros::TransformBroadcaster sends it.
namespace player_topics {
inline constexpr const char* kImage = "camera/image_raw";             ///< sensor_msgs/Image (mono8 or mono16)
inline constexpr const char* kCameraInfo = "camera/camera_info";      ///< sensor_msgs/CameraInfo
inline constexpr const char* kGroundTruthPose = "ground_truth/pose";  ///< geometry_msgs/PoseStamped
inline constexpr const char* kGroundTruthPath = "ground_truth/path";  ///< nav_msgs/Path
inline constexpr const char* kImu = "imu";                            ///< sensor_msgs/Imu
inline constexpr const char* kAltimeter = "altimeter";                ///< sensor_msgs/Range
inline constexpr const char* kTf = "/tf";                             ///< tf2_msgs/TFMessage
/// nav_msgs/Odometry, latched, once: the guidance handover (PlayerOptions::publish_initial_state)
inline constexpr const char* kInitialState = "nav/initial_state";
inline constexpr const char* kClock = "/clock";  ///< rosgraph_msgs/Clock (live node only)
}  // namespace player_topics

struct PlayerOptions {
  std::string world_frame = "world";
  /// frame_id of image, camera_info and imu (for the Lunar sequences, IMU body = camera optical frame).
  std::string camera_frame = "camera_optical";
  /// frame_id of the altimeter Range; "" means camera_frame (the range is along the optical z axis, the
  /// boresight).
  std::string altimeter_frame;
  /// Child frame of the ground-truth tf (world -> this). Distinct from camera_frame so the VO can publish its
  /// own world -> camera_frame estimate without a conflict.
  std::string ground_truth_frame = "camera_gt";
  double time_offset_s = -1.0;  ///< epoch added to dataset times; < 0: auto (see the file comment)
  size_t start_index = 0;       ///< first image played; IMU/altimeter samples before its time are skipped
  bool loop = false;            ///< replay forever, each loop shifted by loopPeriod()
  bool publish_path = true;     ///< include the growing ground-truth Path with every image
  /// Keep every image decoded in memory after its first read, so that a looping replay reads and decodes
  /// each file once (the soak benchmark: a camera delivers raw pixels, the disk and the PNG decoder are the
  /// stand-in's cost, not the navigation's). Memory: one raw image per frame (0.26 MB at 512x512 mono8).
  bool cache_images = false;
  /// Range limits of the altimeter messages; replaced by the dataset's own (sensors.yaml) when
  /// sensor_spec_from_dataset and the dataset describes its altimeter.
  AltimeterSpec altimeter;
  /// Fill the IMU covariances and the Range limits from the dataset's sensors.yaml (data-sheet values).
  bool sensor_spec_from_dataset = true;
  /// Publish (live: latched, once, before the first message; bag: the first message, latched) the
  /// ground-truth state at the first image as the guidance handover on nav/initial_state: see
  /// initialStateMessage(). Off by default.
  bool publish_initial_state = false;
};

enum class StreamKind { kImu = 0, kAltimeter = 1, kImage = 2 };  ///< order at equal times
const char* toString(StreamKind kind);

struct StreamEvent {
  double time_s = 0.0;  ///< dataset time
  StreamKind kind = StreamKind::kImage;
  size_t index = 0;  ///< into Dataset::timestamps(), imu() or altimeter()
};

/// Events from image `start_index` on (IMU/altimeter samples at or after its time), sorted by (time, kind,
/// index). Throws std::out_of_range if start_index >= dataset.size().
std::vector<StreamEvent> buildSchedule(const Dataset& dataset, size_t start_index = 0);

/// The epoch of the stamps (see the file comment for the auto rule, time_offset_s < 0).
ros::Time chooseEpoch(const Dataset& dataset, double time_offset_s);

/// The messages of one event. Only the members of `kind` are set: kImage: image, camera_info and, when the
/// dataset has ground truth, gt_pose, gt_transform and gt_path (null when publish_path is off); kImu: imu;
/// kAltimeter: altimeter.
struct PlayerMessage {
  StreamKind kind = StreamKind::kImage;
  ros::Time stamp;
  size_t index = 0;  ///< index of the sample in its stream
  size_t loop = 0;
  /// kImage: null (and nothing else set) when the image file could not be read (a corrupt or missing PNG):
  /// `skipped` says why. A camera that cannot deliver a frame drops it; the stream goes on.
  sensor_msgs::ImagePtr image;
  std::string skipped;
  sensor_msgs::CameraInfoPtr camera_info;
  bool has_ground_truth = false;
  geometry_msgs::PoseStamped gt_pose;
  geometry_msgs::TransformStamped gt_transform;
  nav_msgs::PathPtr gt_path;  ///< a fresh copy per image: a sink may keep or publish it
  sensor_msgs::Imu imu;
  sensor_msgs::Range altimeter;
};

/// Where the stream goes (the live publisher, the bag writer, a test).
class PlayerSink {
 public:
  virtual ~PlayerSink() = default;
  virtual void emit(const PlayerMessage& message) = 0;
};

/// Walks the schedule, building the messages one at a time (images are loaded on demand). Not thread-safe.
class Player {
 public:
  /// Throws std::invalid_argument for an empty dataset and std::out_of_range for a bad start index.
  Player(const Dataset& dataset, const PlayerOptions& options);

  const Dataset& dataset() const { return dataset_; }
  const PlayerOptions& options() const { return options_; }
  const std::vector<StreamEvent>& schedule() const { return schedule_; }
  ros::Time epoch() const { return epoch_; }
  /// Dataset seconds added per loop: the span of the schedule plus one mean image interval (0.1 s for a
  /// single image), so the first image of a loop comes one frame interval after the last event of the
  /// previous one.
  double loopPeriod() const { return loop_period_s_; }

  /// Stamp of the next message; empty when the stream is over (never with options.loop).
  std::optional<ros::Time> nextStamp() const;
  /// Builds the next message and advances. Returns false when the stream is over. The ground-truth path is
  /// cleared at the start of each loop.
  bool next(PlayerMessage* message);
  /// Emits every remaining message into `sink` (must not be used with options.loop). Returns how many.
  size_t drainTo(PlayerSink& sink);

  /// Stamp of a dataset time in loop `loop`.
  ros::Time stampOf(double dataset_time_s, size_t loop = 0) const;
  /// Images that could not be read (PlayerMessage::skipped), over all loops.
  size_t skippedImages() const { return skipped_images_; }

 private:
  const Dataset& dataset_;
  PlayerOptions options_;
  ImuNoiseSpec imu_noise_;  ///< per-sample IMU noise written into the Imu covariances
  std::vector<StreamEvent> schedule_;
  ros::Time epoch_;
  double loop_period_s_ = 0.0;
  size_t position_ = 0;
  size_t loop_ = 0;
  size_t skipped_images_ = 0;
  nav_msgs::Path path_;
  std::vector<cv::Mat>
      image_cache_;  ///< options_.cache_images: decoded images by index (empty: not read yet)
};

/// @brief The guidance handover the player stands in for: the dataset's ground-truth state at the first
/// image played (start_index), as nav/initial_state carries it (conversions.h toInitialStateMsg: camera pose
/// T_world_cam from groundtruth.txt, world-frame velocity from groundtruth_state.txt, stamp = that image's
/// stamp, frame_id = world_frame, child = camera_frame). The velocity is the IMU body's, which is the
/// camera's for the Lunar datasets (body = camera optical frame). This is the ONLY ground truth a navigation
/// subscriber of the player receives; everything else it publishes as ground truth is for displays and
/// evaluators.
/// @return nullopt, with *why, when the dataset has no ground-truth pose or no groundtruth_state.txt line at
/// that image time (within 1 ms).
std::optional<nav_msgs::Odometry> initialStateMessage(const Player& player, std::string* why);

/// Writes the whole stream (no loop) into a new bag at `bag_path`, topics as in player_topics with a leading
/// '/', bag times = header stamps. Needs no master (calls ros::Time::init()). Returns the number of bag
/// messages. Throws rosbag::BagException or DatasetError.
size_t writeBag(const Dataset& dataset, const PlayerOptions& options, const std::string& bag_path);

/// The command line of the `player` executable (after ros::init has removed remappings in live mode).
struct PlayerCommandLine {
  bool help = false;
  std::optional<std::string> dataset;   ///< --dataset DIR
  std::optional<std::string> bag;       ///< --bag FILE: write a bag and exit
  std::optional<size_t> start_index;    ///< --start N
  std::optional<double> time_offset_s;  ///< --time-offset S
  std::optional<std::string> world_frame, camera_frame, ground_truth_frame;  ///< --world-frame ... --gt-frame
  bool no_path = false;                                                      ///< --no-path
  bool initial_state = false;  ///< --initial-state: PlayerOptions::publish_initial_state
};
/// Parses arguments (without argv[0]). Throws std::invalid_argument naming the bad or unknown argument.
PlayerCommandLine parsePlayerCommandLine(const std::vector<std::string>& args);
/// Overrides the options given on the command line.
void applyCommandLine(const PlayerCommandLine& command_line, PlayerOptions* options);
const char* playerUsage();

}  // namespace planetary_vo::ros_io
