/// @file player.cpp
/// The time-ordered message stream of a dataset, the bag writer and the command line (see player.h).

#include "planetary_vo/ros_io/player.h"

#include <algorithm>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <tuple>

#include <cmath>

#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>

#include "planetary_vo/eval/evaluation_inputs.h"

namespace planetary_vo::ros_io {

namespace {

constexpr double kAutoEpochThresholdS = 1.0e6;  // dataset times below this are a relative clock
constexpr uint32_t kAutoEpochS = 1000000000;    // 2001-09-09T01:46:40Z
constexpr double kSingleImageIntervalS = 0.1;

std::string absoluteTopic(const char* topic) { return topic[0] == '/' ? topic : std::string("/") + topic; }

}  // namespace

const char* toString(StreamKind kind) {
  switch (kind) {
    case StreamKind::kImu:
      return "imu";
    case StreamKind::kAltimeter:
      return "altimeter";
    case StreamKind::kImage:
      return "image";
  }
  return "?";
}

std::vector<StreamEvent> buildSchedule(const Dataset& dataset, size_t start_index) {
  if (start_index >= dataset.size())
    throw std::out_of_range("start index " + std::to_string(start_index) + " but the dataset has " +
                            std::to_string(dataset.size()) + " images");
  const double t_start = dataset.timestamp(start_index);
  std::vector<StreamEvent> events;
  events.reserve(dataset.size() - start_index + dataset.imu().size() + dataset.altimeter().size());
  for (size_t i = start_index; i < dataset.size(); ++i)
    events.push_back({dataset.timestamp(i), StreamKind::kImage, i});
  for (size_t i = 0; i < dataset.imu().size(); ++i)
    if (dataset.imu()[i].timestamp_s >= t_start)
      events.push_back({dataset.imu()[i].timestamp_s, StreamKind::kImu, i});
  for (size_t i = 0; i < dataset.altimeter().size(); ++i)
    if (dataset.altimeter()[i].timestamp_s >= t_start)
      events.push_back({dataset.altimeter()[i].timestamp_s, StreamKind::kAltimeter, i});
  std::sort(events.begin(), events.end(), [](const StreamEvent& a, const StreamEvent& b) {
    return std::make_tuple(a.time_s, static_cast<int>(a.kind), a.index) <
           std::make_tuple(b.time_s, static_cast<int>(b.kind), b.index);
  });
  return events;
}

ros::Time chooseEpoch(const Dataset& dataset, double time_offset_s) {
  if (time_offset_s >= 0.0) return ros::Time().fromSec(time_offset_s);
  const double t0 = dataset.size() > 0 ? dataset.timestamp(0) : 0.0;
  return t0 < kAutoEpochThresholdS ? ros::Time(kAutoEpochS, 0) : ros::Time(0, 0);
}

Player::Player(const Dataset& dataset, const PlayerOptions& options)
    : dataset_(dataset), options_(options), epoch_(chooseEpoch(dataset, options.time_offset_s)) {
  if (dataset.size() == 0) throw std::invalid_argument("the dataset " + dataset.directory() + " is empty");
  if (options_.altimeter_frame.empty()) options_.altimeter_frame = options_.camera_frame;
  if (options_.sensor_spec_from_dataset) {
    options_.altimeter = altimeterSpec(dataset.sensorSpecification(), options_.altimeter);
    imu_noise_ = imuNoiseSpec(dataset.sensorSpecification());
  }
  schedule_ = buildSchedule(dataset, options_.start_index);
  const size_t num_images = dataset.size() - options_.start_index;
  const double image_interval =
      num_images > 1
          ? (dataset.timestamps().back() - dataset.timestamp(options_.start_index)) / (num_images - 1)
          : kSingleImageIntervalS;
  loop_period_s_ = (schedule_.back().time_s - schedule_.front().time_s) + image_interval;
  path_.header.frame_id = options_.world_frame;
  if (options_.cache_images) image_cache_.resize(dataset.size());
}

ros::Time Player::stampOf(double dataset_time_s, size_t loop) const {
  return toStamp(epoch_, dataset_time_s + static_cast<double>(loop) * loop_period_s_);
}

std::optional<ros::Time> Player::nextStamp() const {
  if (position_ >= schedule_.size()) {
    if (!options_.loop) return std::nullopt;
    return stampOf(schedule_.front().time_s, loop_ + 1);
  }
  return stampOf(schedule_[position_].time_s, loop_);
}

bool Player::next(PlayerMessage* message) {
  if (position_ >= schedule_.size()) {
    if (!options_.loop) return false;
    position_ = 0;
    ++loop_;
    path_.poses.clear();
  }
  const StreamEvent& event = schedule_[position_++];
  PlayerMessage& m = *message;
  m = PlayerMessage();
  m.kind = event.kind;
  m.index = event.index;
  m.loop = loop_;
  m.stamp = stampOf(event.time_s, loop_);
  switch (event.kind) {
    case StreamKind::kImu:
      m.imu = toImu(dataset_.imu()[event.index], makeHeader(m.stamp, options_.camera_frame), imu_noise_);
      break;
    case StreamKind::kAltimeter:
      m.altimeter = toRange(dataset_.altimeter()[event.index], makeHeader(m.stamp, options_.altimeter_frame),
                            options_.altimeter);
      break;
    case StreamKind::kImage: {
      const std_msgs::Header camera_header = makeHeader(m.stamp, options_.camera_frame);
      // As the camera gives it: a 16-bit raw frame (the flight camera's MSB-aligned 10/12-bit pixels) as
      // mono16, 8-bit gray as mono8; colour datasets are converted to gray.
      try {
        cv::Mat pixels = options_.cache_images ? image_cache_[event.index] : cv::Mat();
        if (pixels.empty()) {
          pixels = dataset_.loadImageUnchanged(event.index);
          if (pixels.type() != CV_8UC1 && pixels.type() != CV_16UC1) pixels = dataset_.loadImage(event.index);
          if (options_.cache_images) image_cache_[event.index] = pixels;
        }
        m.image = toImageMsg(pixels, camera_header);
      } catch (const std::exception& e) {  // a corrupt or missing file: this frame is dropped, not the run
        m.skipped = std::string("image ") + std::to_string(event.index) + " skipped: " + e.what();
        ++skipped_images_;
        return true;
      }
      m.camera_info =
          boost::make_shared<sensor_msgs::CameraInfo>(toCameraInfo(dataset_.camera(), camera_header));
      if (dataset_.hasGroundTruth()) {
        const Pose& T_world_cam = dataset_.groundTruth().at(event.index).T_world_cam;
        const std_msgs::Header world_header = makeHeader(m.stamp, options_.world_frame);
        m.has_ground_truth = true;
        m.gt_pose = toPoseStamped(T_world_cam, world_header);
        m.gt_transform = toTransformStamped(T_world_cam, world_header, options_.ground_truth_frame);
        if (options_.publish_path) {
          path_.header.stamp = m.stamp;
          path_.poses.push_back(m.gt_pose);
          m.gt_path = boost::make_shared<nav_msgs::Path>(path_);
        }
      }
      break;
    }
  }
  return true;
}

size_t Player::drainTo(PlayerSink& sink) {
  if (options_.loop) throw std::logic_error("Player::drainTo on a looping player would never end");
  size_t count = 0;
  PlayerMessage message;
  while (next(&message)) {
    sink.emit(message);
    ++count;
  }
  return count;
}

namespace {

/// Keeps a Bag that failed to write, never destroyed (BagSink): reachable from this static until the process
/// exits, so it is not a leak either (LeakSanitizer reported the released pointer's Bag and rosbag's buffers
/// in the sanitizer stage, issue 12).
void abandon(std::unique_ptr<rosbag::Bag> bag) {
  static auto* const abandoned = new std::vector<std::unique_ptr<rosbag::Bag>>();
  abandoned->push_back(std::move(bag));
}

/// Records the stream with the topic names the live node publishes (absolute, from the root namespace).
/// A write error (disk full: rosbag::BagIOException) is thrown once, as a runtime_error naming the file; the
/// Bag is then abandoned, never destroyed: rosbag::Bag::~Bag() would retry the close, throw again from a
/// destructor and std::terminate the process. The OS closes the file at exit; the bag is incomplete.
class BagSink : public PlayerSink {
 public:
  explicit BagSink(const std::string& path) : path_(path), bag_(std::make_unique<rosbag::Bag>()) {
    try {
      guarded([&] { bag_->open(path, rosbag::bagmode::Write); });
    } catch (...) {
      abandon(std::move(bag_));  // no destructor of this object runs: abandon the Bag here (class comment)
      throw;
    }
  }
  ~BagSink() override {
    if (failed_) {
      abandon(std::move(bag_));  // see the class comment: a Bag that failed to write cannot be destroyed
      return;
    }
    try {
      bag_.reset();
    } catch (...) {
    }
  }

  void emit(const PlayerMessage& m) override {
    guarded([&] { emitToBag(m); });
  }

  void emitToBag(const PlayerMessage& m) {
    switch (m.kind) {
      case StreamKind::kImu:
        write(player_topics::kImu, m.stamp, m.imu);
        break;
      case StreamKind::kAltimeter:
        write(player_topics::kAltimeter, m.stamp, m.altimeter);
        break;
      case StreamKind::kImage:
        if (!m.image) {
          std::cerr << "player: " << m.skipped << "\n";
          break;
        }
        write(player_topics::kImage, m.stamp, *m.image);
        write(player_topics::kCameraInfo, m.stamp, *m.camera_info);
        if (m.has_ground_truth) {
          write(player_topics::kGroundTruthPose, m.stamp, m.gt_pose);
          if (m.gt_path) write(player_topics::kGroundTruthPath, m.stamp, *m.gt_path);
          tf2_msgs::TFMessage tf;
          tf.transforms.push_back(m.gt_transform);
          write(player_topics::kTf, m.stamp, tf);
        }
        break;
    }
  }

  size_t count() const { return count_; }
  void close() {
    guarded([&] { bag_->close(); });
  }

  /// A message `rosbag play` republishes latched (the connection header says so).
  template <class Msg>
  void writeLatched(const char* topic, const ros::Time& stamp, const Msg& msg) {
    // The whole connection header, as a recorder writes it: rosbag reads type and md5sum back from it.
    auto header = boost::make_shared<ros::M_string>();
    (*header)["type"] = ros::message_traits::datatype<Msg>();
    (*header)["md5sum"] = ros::message_traits::md5sum<Msg>();
    (*header)["message_definition"] = ros::message_traits::definition<Msg>();
    (*header)["latching"] = "1";
    (*header)["callerid"] = "/player";
    guarded([&] { bag_->write(absoluteTopic(topic), stamp, msg, header); });
    ++count_;
  }

 private:
  template <class Msg>
  void write(const char* topic, const ros::Time& stamp, const Msg& msg) {
    bag_->write(absoluteTopic(topic), stamp, msg);
    ++count_;
  }

  /// Runs a Bag operation; its failure becomes one runtime_error, and every later operation is refused.
  template <class Op>
  void guarded(Op&& op) {
    if (failed_) throw std::runtime_error("writing the bag " + path_ + " failed earlier");
    try {
      op();
    } catch (const std::exception& e) {
      failed_ = true;
      throw std::runtime_error("writing the bag failed: " + path_ + ": " + e.what() +
                               " (disk full?); the bag is incomplete");
    }
  }

  std::string path_;
  std::unique_ptr<rosbag::Bag> bag_;
  bool failed_ = false;
  size_t count_ = 0;
};

}  // namespace

std::optional<nav_msgs::Odometry> initialStateMessage(const Player& player, std::string* why) {
  const Dataset& dataset = player.dataset();
  const size_t index = player.options().start_index;
  if (!dataset.hasGroundTruth()) {
    *why = "the dataset has no ground truth";
    return std::nullopt;
  }
  const double t = dataset.timestamp(index);
  const std::string path = dataset.directory() + "/groundtruth_state.txt";
  std::vector<GroundTruthState> states;
  try {
    states = readGroundTruthStates(path);
  } catch (const std::exception& e) {
    *why = std::string("no ground-truth velocity: ") + e.what();
    return std::nullopt;
  }
  const auto at = std::min_element(states.begin(), states.end(), [t](const auto& a, const auto& b) {
    return std::abs(a.timestamp_s - t) < std::abs(b.timestamp_s - t);
  });
  if (at == states.end() || std::abs(at->timestamp_s - t) > 1e-3) {
    *why = path + " has no state at the first image time " + std::to_string(t) + " s";
    return std::nullopt;
  }
  const ros::Time stamp = player.stampOf(t);
  return toInitialStateMsg(dataset.groundTruth().at(index).T_world_cam, at->velocity_world_mps,
                           makeHeader(stamp, player.options().world_frame), player.options().camera_frame);
}

size_t writeBag(const Dataset& dataset, const PlayerOptions& options, const std::string& bag_path) {
  ros::Time::init();
  PlayerOptions no_loop = options;
  no_loop.loop = false;
  Player player(dataset, no_loop);
  std::optional<nav_msgs::Odometry> initial_state;
  if (options.publish_initial_state) {
    std::string why;
    initial_state = initialStateMessage(player, &why);
    if (!initial_state) throw std::runtime_error("no initial state to write: " + why);
  }
  BagSink sink(bag_path);
  // 1 ms before the first image in bag time (the header keeps the image's stamp), so that rosbag play sends
  // it first, and latched, so that a late subscriber still gets it.
  if (initial_state)
    sink.writeLatched(player_topics::kInitialState, initial_state->header.stamp - ros::Duration(0.001),
                      *initial_state);
  player.drainTo(sink);
  sink.close();
  return sink.count();
}

const char* playerUsage() {
  return "usage: player [--dataset DIR] [--bag OUT.bag] [--start N] [--time-offset S] [--world-frame F]\n"
         "              [--camera-frame F] [--gt-frame F] [--no-path] [--initial-state]\n"
         "              [ROS remappings and _param:=value]\n"
         "  --bag OUT.bag    write the stream into a bag and exit (no master needed); otherwise run as a ROS "
         "node\n"
         "                   (node parameters ~dataset ~rate ~loop ~publish_clock ..., command line options "
         "win)\n"
         "  --initial-state  also publish the ground-truth state at the first image on nav/initial_state\n"
         "                   (latched, once): the guidance handover, the only ground truth meant for the\n"
         "                   navigation (~publish_initial_state)\n";
}

PlayerCommandLine parsePlayerCommandLine(const std::vector<std::string>& args) {
  PlayerCommandLine cl;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw std::invalid_argument(a + " needs a value");
      return args[++i];
    };
    auto number = [&](const std::string& text) {
      size_t used = 0;
      double v = 0.0;
      try {
        v = std::stod(text, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != text.size()) throw std::invalid_argument(a + ": not a number: " + text);
      return v;
    };
    if (a == "-h" || a == "--help") {
      cl.help = true;
    } else if (a == "--dataset") {
      cl.dataset = value();
    } else if (a == "--bag") {
      cl.bag = value();
    } else if (a == "--start") {
      const std::string& text = value();
      const double v = number(text);
      // Range first: converting 1e308 to size_t is undefined (UBSan, issue 12 tools fuzz test).
      if (!(v >= 0.0 && v <= 9007199254740992.0 && v == std::floor(v)))  // 2^53: every integer exact
        throw std::invalid_argument("--start needs an image index, got " + text);
      cl.start_index = static_cast<size_t>(v);
    } else if (a == "--time-offset") {
      cl.time_offset_s = number(value());
    } else if (a == "--world-frame") {
      cl.world_frame = value();
    } else if (a == "--camera-frame") {
      cl.camera_frame = value();
    } else if (a == "--gt-frame") {
      cl.ground_truth_frame = value();
    } else if (a == "--no-path") {
      cl.no_path = true;
    } else if (a == "--initial-state") {
      cl.initial_state = true;
    } else {
      throw std::invalid_argument("unknown argument '" + a + "'");
    }
  }
  return cl;
}

void applyCommandLine(const PlayerCommandLine& cl, PlayerOptions* options) {
  if (cl.start_index) options->start_index = *cl.start_index;
  if (cl.time_offset_s) options->time_offset_s = *cl.time_offset_s;
  if (cl.world_frame) options->world_frame = *cl.world_frame;
  if (cl.camera_frame) options->camera_frame = *cl.camera_frame;
  if (cl.ground_truth_frame) options->ground_truth_frame = *cl.ground_truth_frame;
  if (cl.no_path) options->publish_path = false;
  if (cl.initial_state) options->publish_initial_state = true;
}

}  // namespace planetary_vo::ros_io
