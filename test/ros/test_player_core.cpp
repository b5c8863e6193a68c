/// The player's message stream and bag writer, on the real KITTI clip and on a synthetic planetary_vo-format
/// dataset with IMU and altimeter (no master).

#include <algorithm>
#include <fstream>
#include <map>
#include <set>

#include <sys/resource.h>

#include <csignal>
#include <cstdio>

#include <gtest/gtest.h>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>

#include <opencv2/core.hpp>

#include "planetary_vo/ros_io/player.h"
#include "synthetic_dataset.h"
#include "test_support.h"

namespace planetary_vo::ros_io {
namespace {

using planetary_vo::test::dataPath;
using planetary_vo::test::outputDir;
using planetary_vo::test::requireDataFile;

constexpr size_t kKittiFrames = 51;

Dataset openKitti() {
  const std::string dir = dataPath("kitti_clip_turn");
  EXPECT_TRUE(requireDataFile(dir + "/poses.txt"));
  return Dataset::open(dir);
}

Dataset openSynthetic(const std::string& name,
                      const test::SyntheticLanding& spec = test::SyntheticLanding()) {
  const std::string dir = outputDir(name) + "/dataset";
  test::writeSyntheticLanding(dir, spec);
  return Dataset::open(dir);
}

std::vector<PlayerMessage> drain(Player& player, size_t max_messages = 1000000) {
  std::vector<PlayerMessage> out;
  PlayerMessage m;
  while (out.size() < max_messages && player.next(&m)) out.push_back(m);
  return out;
}

bool samePixels(const sensor_msgs::Image& msg, const cv::Mat& expected) {
  if (msg.encoding != "mono8" || static_cast<int>(msg.width) != expected.cols ||
      static_cast<int>(msg.height) != expected.rows)
    return false;
  const cv::Mat view(expected.rows, expected.cols, CV_8UC1, const_cast<uint8_t*>(msg.data.data()), msg.step);
  return cv::countNonZero(view != expected) == 0;
}

void expectPoseNear(const geometry_msgs::Pose& msg, const Pose& expected, const std::string& what) {
  const Pose actual = fromPoseMsg(msg);
  EXPECT_LT((actual.translation() - expected.translation()).norm(), 1e-9) << what;
  EXPECT_LT(rotationAngleDeg(actual.rotation().transpose() * expected.rotation()), 1e-6) << what;
}

struct CountingSink : PlayerSink {
  void emit(const PlayerMessage&) override { ++count; }
  size_t count = 0;
};

TEST(PlayerCore, KittiStreamHasEveryImageWithExactStampsIntrinsicsAndGroundTruth) {
  const Dataset dataset = openKitti();
  ASSERT_EQ(dataset.size(), kKittiFrames);
  Player player(dataset, PlayerOptions());
  EXPECT_EQ(player.epoch(), ros::Time(1000000000, 0)) << "KITTI times start at 0: auto epoch 1e9 s";
  EXPECT_NEAR(player.loopPeriod(), 5.1, 1e-12);
  ASSERT_EQ(player.schedule().size(), kKittiFrames);

  const std::vector<PlayerMessage> messages = drain(player);
  ASSERT_EQ(messages.size(), kKittiFrames);
  EXPECT_FALSE(player.nextStamp().has_value());
  CountingSink sink;
  EXPECT_EQ(Player(dataset, PlayerOptions()).drainTo(sink), kKittiFrames);
  EXPECT_EQ(sink.count, kKittiFrames);
  for (size_t k = 0; k < messages.size(); ++k) {
    const PlayerMessage& m = messages[k];
    SCOPED_TRACE("image " + std::to_string(k));
    ASSERT_EQ(m.kind, StreamKind::kImage);
    EXPECT_EQ(m.index, k);
    EXPECT_EQ((m.stamp - player.epoch()).toNSec(), static_cast<int64_t>(k) * 100000000);
    ASSERT_TRUE(m.image && m.camera_info);
    EXPECT_EQ(m.image->header.stamp, m.stamp);
    EXPECT_EQ(m.image->header.frame_id, "camera_optical");
    EXPECT_EQ(m.camera_info->header, m.image->header);
    EXPECT_EQ(m.camera_info->K[0], 718.856);
    EXPECT_EQ(m.camera_info->K[4], 718.856);
    EXPECT_EQ(m.camera_info->K[2], 607.1928);
    EXPECT_EQ(m.camera_info->K[5], 185.2157);
    EXPECT_EQ(m.camera_info->width, 1241u);
    EXPECT_EQ(m.camera_info->height, 376u);
    if (k % 10 == 0) {
      EXPECT_TRUE(samePixels(*m.image, dataset.loadImage(k)));
    }
    ASSERT_TRUE(m.has_ground_truth);
    EXPECT_EQ(m.gt_pose.header.frame_id, "world");
    EXPECT_EQ(m.gt_pose.header.stamp, m.stamp);
    expectPoseNear(m.gt_pose.pose, dataset.groundTruth()[k].T_world_cam, "pose");
    EXPECT_EQ(m.gt_transform.header.frame_id, "world");
    EXPECT_EQ(m.gt_transform.child_frame_id, "camera_gt");
    EXPECT_TRUE(fromTransformMsg(m.gt_transform.transform).isApprox(fromPoseMsg(m.gt_pose.pose), 1e-12));
    ASSERT_TRUE(m.gt_path);
    EXPECT_EQ(m.gt_path->header.frame_id, "world");
    ASSERT_EQ(m.gt_path->poses.size(), k + 1) << "the path grows by one pose per image";
    EXPECT_EQ(m.gt_path->poses.back(), m.gt_pose);
  }
  // The clip turns by about 98 degrees: the poses are real, not identity.
  EXPECT_GT(rotationAngleDeg(fromPoseMsg(messages.back().gt_pose.pose).rotation()), 80.0);
}

TEST(PlayerCore, OptionsFramesStartIndexTimeOffsetAndNoPath) {
  const Dataset dataset = openKitti();
  PlayerOptions options;
  options.world_frame = "moon";
  options.camera_frame = "cam";
  options.ground_truth_frame = "cam_truth";
  options.start_index = 10;
  options.time_offset_s = 42.0;
  options.publish_path = false;
  Player player(dataset, options);
  EXPECT_EQ(player.epoch(), ros::Time(42, 0));
  const std::vector<PlayerMessage> messages = drain(player);
  ASSERT_EQ(messages.size(), kKittiFrames - 10);
  EXPECT_EQ(messages.front().index, 10u);
  EXPECT_EQ(messages.front().stamp, ros::Time(43, 0));
  EXPECT_EQ(messages.front().image->header.frame_id, "cam");
  EXPECT_EQ(messages.front().gt_pose.header.frame_id, "moon");
  EXPECT_EQ(messages.front().gt_transform.child_frame_id, "cam_truth");
  EXPECT_FALSE(messages.front().gt_path);
  options.start_index = kKittiFrames;
  EXPECT_THROW(Player(dataset, options), std::out_of_range);
}

TEST(PlayerCore, LoopingShiftsEachLoopSoStampsNeverGoBackwards) {
  const Dataset dataset = openKitti();
  PlayerOptions options;
  options.loop = true;
  Player player(dataset, options);
  const std::vector<PlayerMessage> messages = drain(player, 3 * kKittiFrames + 1);
  ASSERT_EQ(messages.size(), 3 * kKittiFrames + 1);
  for (size_t i = 1; i < messages.size(); ++i) EXPECT_LT(messages[i - 1].stamp, messages[i].stamp) << i;
  for (size_t i = 0; i < messages.size(); ++i) {
    EXPECT_EQ(messages[i].loop, i / kKittiFrames);
    EXPECT_EQ(messages[i].index, i % kKittiFrames);
    EXPECT_EQ(messages[i].gt_path->poses.size(), i % kKittiFrames + 1) << "the path restarts with each loop";
    EXPECT_EQ(messages[i].stamp, player.stampOf(dataset.timestamp(i % kKittiFrames), i / kKittiFrames));
  }
  // One frame interval between the last image of a loop and the first of the next.
  EXPECT_EQ((messages[kKittiFrames].stamp - messages[kKittiFrames - 1].stamp).toNSec(), 100000000);
  EXPECT_TRUE(player.nextStamp().has_value());
  CountingSink sink;
  EXPECT_THROW(Player(dataset, options).drainTo(sink), std::logic_error);
  EXPECT_EQ(sink.count, 0u);
}

TEST(PlayerCore, SyntheticStreamInterleavesImuAndAltimeterInTimeOrder) {
  const Dataset dataset = openSynthetic("player_core_interleave");
  ASSERT_EQ(dataset.size(), 20u);
  ASSERT_EQ(dataset.imu().size(), 381u);
  ASSERT_EQ(dataset.altimeter().size(), 19u);
  Player player(dataset, PlayerOptions());
  EXPECT_EQ(player.epoch(), ros::Time(1000000000, 0));
  const std::vector<PlayerMessage> messages = drain(player);
  ASSERT_EQ(messages.size(), 20u + 381u + 19u);

  std::map<StreamKind, size_t> next_index;
  for (size_t i = 0; i < messages.size(); ++i) {
    const PlayerMessage& m = messages[i];
    EXPECT_EQ(m.index, next_index[m.kind]++) << "each stream in its own order";
    if (i > 0) {
      const PlayerMessage& prev = messages[i - 1];
      ASSERT_LE(prev.stamp, m.stamp) << "time order at message " << i;
      if (prev.stamp == m.stamp) {
        EXPECT_LT(static_cast<int>(prev.kind), static_cast<int>(m.kind))
            << "at equal times IMU, altimeter, image";
      }
    }
  }
  // Between two images: the 20 IMU samples of (t_{k-1}, t_k] and the altimeter sample at t_{k-1} + 0.05.
  size_t image = 0, imu_since_image = 0, altimeter_since_image = 0;
  for (const PlayerMessage& m : messages) {
    if (m.kind == StreamKind::kImu) ++imu_since_image;
    if (m.kind == StreamKind::kAltimeter) ++altimeter_since_image;
    if (m.kind != StreamKind::kImage) continue;
    EXPECT_EQ(imu_since_image, image == 0 ? 1u : 20u) << "image " << image;
    EXPECT_EQ(altimeter_since_image, image == 0 ? 0u : 1u) << "image " << image;
    imu_since_image = altimeter_since_image = 0;
    ++image;
  }
  // Message content against the reader.
  for (const PlayerMessage& m : messages) {
    switch (m.kind) {
      case StreamKind::kImu: {
        const ImuSample& s = dataset.imu()[m.index];
        EXPECT_EQ(m.stamp, toStamp(player.epoch(), s.timestamp_s));
        EXPECT_EQ(m.imu.header.stamp, m.stamp);
        EXPECT_EQ(m.imu.header.frame_id, "camera_optical");
        EXPECT_EQ(m.imu.angular_velocity.z, s.angular_velocity_radps.z());
        EXPECT_EQ(m.imu.linear_acceleration.x, s.specific_force_mps2.x());
        EXPECT_EQ(m.imu.linear_acceleration.z, s.specific_force_mps2.z());
        break;
      }
      case StreamKind::kAltimeter: {
        const AltimeterSample& s = dataset.altimeter()[m.index];
        EXPECT_EQ(m.stamp, toStamp(player.epoch(), s.timestamp_s));
        EXPECT_EQ(m.altimeter.header.stamp, m.stamp);
        EXPECT_EQ(m.altimeter.range, static_cast<float>(s.slant_range_m));
        EXPECT_GT(m.altimeter.range, 900.0f);
        break;
      }
      case StreamKind::kImage:
        EXPECT_EQ(m.stamp, toStamp(player.epoch(), dataset.timestamp(m.index)));
        EXPECT_TRUE(samePixels(*m.image, dataset.loadImage(m.index)));
        EXPECT_EQ(m.image->data[0], m.index);
        EXPECT_EQ(m.camera_info->distortion_model, "plumb_bob");
        EXPECT_EQ(m.camera_info->D, dataset.camera().distortion());
        expectPoseNear(m.gt_pose.pose, dataset.groundTruth()[m.index].T_world_cam, "pose");
        break;
    }
  }
}

TEST(PlayerCore, SixteenBitImagesPlayAsMono16AndSensorsYamlFillsCovariancesAndRangeLimits) {
  const std::string dir = outputDir("player_core_flight") + "/dataset";
  const PinholeCamera camera(32, 24, 30.0, 30.0, 15.5, 11.5, "plumb_bob", {-0.04, 0.01, 0.0, 0.0, 0.0});
  cv::Mat image(24, 32, CV_16UC1);
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c)
      image.at<uint16_t>(r, c) = static_cast<uint16_t>(16 * (64 + 37 * r + c));
  {
    DatasetWriter writer(dir, camera);
    writer.addFrame(0.0, image, Pose::Identity());
    writer.addFrame(0.1, image, Pose::Identity());
    writer.addImu({0.05, Eigen::Vector3d(0, 0, 0.1), Eigen::Vector3d(0, 0, -1.62)});
    writer.addAltimeter({0.05, 812.5});
    writer.setTextFile("sensors.yaml",
                       "imu:\n  rate_hz: 200\n  gyro_noise_density_radps_per_sqrt_hz: 1e-4\n"
                       "  accel_noise_density_mps2_per_sqrt_hz: 1e-3\naltimeter:\n  min_range_m: 10\n"
                       "  max_range_m: 2000\n  beam_divergence_rad: 0.0005\n");
  }
  const Dataset dataset = Dataset::open(dir);
  for (bool from_dataset : {true, false}) {
    PlayerOptions options;
    options.sensor_spec_from_dataset = from_dataset;
    Player player(dataset, options);
    const std::vector<PlayerMessage> messages = drain(player);
    ASSERT_EQ(messages.size(), 4u);
    for (const PlayerMessage& m : messages) {
      if (m.kind == StreamKind::kImage) {
        ASSERT_EQ(m.image->encoding, "mono16");
        ASSERT_EQ(m.image->step, 64u);
        const cv::Mat view(24, 32, CV_16UC1, const_cast<uint8_t*>(m.image->data.data()), m.image->step);
        EXPECT_EQ(cv::countNonZero(view != image), 0) << "16-bit pixels are published unchanged";
      } else if (m.kind == StreamKind::kImu) {
        EXPECT_NEAR(m.imu.angular_velocity_covariance[0], from_dataset ? 2e-6 : 0.0, 1e-15);
        EXPECT_NEAR(m.imu.linear_acceleration_covariance[8], from_dataset ? 2e-4 : 0.0, 1e-13);
      } else {
        EXPECT_EQ(m.altimeter.range, 812.5f);
        EXPECT_EQ(m.altimeter.max_range,
                  from_dataset ? 2000.0f : static_cast<float>(AltimeterSpec().max_range_m));
        EXPECT_EQ(m.altimeter.min_range,
                  from_dataset ? 10.0f : static_cast<float>(AltimeterSpec().min_range_m));
        EXPECT_FLOAT_EQ(m.altimeter.field_of_view,
                        from_dataset ? 5e-4f : static_cast<float>(AltimeterSpec().field_of_view_rad));
      }
    }
  }
}

TEST(PlayerCore, StartIndexSkipsEarlierInertialSamples) {
  const Dataset dataset = openSynthetic("player_core_start");
  PlayerOptions options;
  options.start_index = 5;
  Player player(dataset, options);
  const std::vector<PlayerMessage> messages = drain(player);
  ASSERT_FALSE(messages.empty());
  EXPECT_EQ(messages.front().kind, StreamKind::kImu);
  EXPECT_EQ(messages.front().stamp, toStamp(player.epoch(), dataset.timestamp(5)));
  EXPECT_EQ(messages.front().index, 100u);  // 200 Hz: the sample at 0.5 s
  EXPECT_EQ(messages[1].kind, StreamKind::kImage);
  EXPECT_EQ(messages[1].index, 5u);
  EXPECT_EQ(std::count_if(messages.begin(), messages.end(),
                          [](const PlayerMessage& m) { return m.kind == StreamKind::kImage; }),
            15);
}

TEST(PlayerCore, EpochIsZeroForDatasetsWithEpochStamps) {
  test::SyntheticLanding spec;
  spec.num_images = 3;
  spec.t0_s = 1403636579.0;
  const Dataset dataset = openSynthetic("player_core_epoch", spec);
  EXPECT_EQ(chooseEpoch(dataset, -1.0), ros::Time(0, 0));
  EXPECT_EQ(chooseEpoch(dataset, 7.5), ros::Time(7, 500000000));
  Player player(dataset, PlayerOptions());
  PlayerMessage m;
  ASSERT_TRUE(player.next(&m));
  EXPECT_EQ(m.stamp.sec, 1403636579u);
  EXPECT_LT(m.stamp.nsec, 1000u);
}

/// Reads every message of a bag written by writeBag and checks it against the dataset, in time order.
void checkBag(const std::string& bag_path, const Dataset& dataset) {
  const Player reference(dataset, PlayerOptions());
  rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
  rosbag::View view(bag);
  std::map<std::string, size_t> count;
  ros::Time last_time;
  for (const rosbag::MessageInstance& mi : view) {
    const std::string& topic = mi.getTopic();
    const size_t i = count[topic]++;
    SCOPED_TRACE(topic + " #" + std::to_string(i));
    EXPECT_LE(last_time, mi.getTime()) << "time order";
    last_time = mi.getTime();
    if (topic == "/camera/image_raw") {
      const auto msg = mi.instantiate<sensor_msgs::Image>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->header.stamp, reference.stampOf(dataset.timestamp(i)));
      EXPECT_EQ(mi.getTime(), msg->header.stamp);
      if (i % 10 == 0) {
        EXPECT_TRUE(samePixels(*msg, dataset.loadImage(i)));
      }
    } else if (topic == "/camera/camera_info") {
      const auto msg = mi.instantiate<sensor_msgs::CameraInfo>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->header.stamp, reference.stampOf(dataset.timestamp(i)));
      EXPECT_EQ(fromCameraInfo(*msg), dataset.camera());
    } else if (topic == "/ground_truth/pose") {
      const auto msg = mi.instantiate<geometry_msgs::PoseStamped>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->header.stamp, reference.stampOf(dataset.timestamp(i)));
      expectPoseNear(msg->pose, dataset.groundTruth()[i].T_world_cam, "pose");
    } else if (topic == "/ground_truth/path") {
      const auto msg = mi.instantiate<nav_msgs::Path>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->poses.size(), i + 1);
    } else if (topic == "/tf") {
      const auto msg = mi.instantiate<tf2_msgs::TFMessage>();
      ASSERT_TRUE(msg);
      ASSERT_EQ(msg->transforms.size(), 1u);
      EXPECT_EQ(msg->transforms[0].header.stamp, reference.stampOf(dataset.timestamp(i)));
      EXPECT_EQ(msg->transforms[0].child_frame_id, "camera_gt");
      EXPECT_TRUE(fromTransformMsg(msg->transforms[0].transform)
                      .isApprox(dataset.groundTruth()[i].T_world_cam, 1e-9));
    } else if (topic == "/imu") {
      const auto msg = mi.instantiate<sensor_msgs::Imu>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->header.stamp, reference.stampOf(dataset.imu()[i].timestamp_s));
      EXPECT_EQ(msg->angular_velocity.z, dataset.imu()[i].angular_velocity_radps.z());
    } else if (topic == "/altimeter") {
      const auto msg = mi.instantiate<sensor_msgs::Range>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->header.stamp, reference.stampOf(dataset.altimeter()[i].timestamp_s));
      EXPECT_EQ(msg->range, static_cast<float>(dataset.altimeter()[i].slant_range_m));
    } else {
      ADD_FAILURE() << "unexpected topic " << topic;
    }
  }
  const size_t n = dataset.size();
  EXPECT_EQ(count["/camera/image_raw"], n);
  EXPECT_EQ(count["/camera/camera_info"], n);
  EXPECT_EQ(count["/ground_truth/pose"], n);
  EXPECT_EQ(count["/ground_truth/path"], n);
  EXPECT_EQ(count["/tf"], n);
  EXPECT_EQ(count["/imu"], dataset.imu().size());
  EXPECT_EQ(count["/altimeter"], dataset.altimeter().size());
}

TEST(PlayerBag, KittiBagReadsBackWithEveryStampAndPose) {
  const Dataset dataset = openKitti();
  const std::string bag = outputDir("player_bag_kitti") + "/kitti.bag";
  EXPECT_EQ(writeBag(dataset, PlayerOptions(), bag), 5 * kKittiFrames);
  checkBag(bag, dataset);
}

TEST(PlayerBag, SyntheticBagCarriesImuAndAltimeter) {
  const Dataset dataset = openSynthetic("player_bag_synthetic");
  const std::string bag = outputDir("player_bag_synthetic_out") + "/synthetic.bag";
  EXPECT_EQ(writeBag(dataset, PlayerOptions(), bag), 5 * 20u + 381u + 19u);
  checkBag(bag, dataset);
}

TEST(PlayerCore, CorruptImageFileIsSkippedAndTheStreamGoesOn) {
  // Issue 12: a corrupt PNG ended a live player run (the DatasetError left the publishing loop). The frame is
  // dropped with its reason, every other message of the stream (and of the next loop) still comes.
  const Dataset dataset = openSynthetic("player_corrupt_png");
  const size_t bad = 2;
  {
    std::ofstream corrupt(dataset.imagePath(bad), std::ios::binary | std::ios::trunc);
    corrupt << "\x89PNG\r\n\x1a\n this is not an image";
  }
  PlayerOptions options;
  options.loop = true;
  Player player(dataset, options);
  const size_t per_loop = player.schedule().size();
  const std::vector<PlayerMessage> messages = drain(player, 2 * per_loop);
  size_t images = 0, skipped = 0;
  for (const PlayerMessage& m : messages) {
    if (m.kind != StreamKind::kImage) continue;
    if (m.index == bad) {
      EXPECT_FALSE(m.image);
      EXPECT_NE(m.skipped.find("image 2 skipped"), std::string::npos) << m.skipped;
      ++skipped;
    } else {
      ASSERT_TRUE(m.image) << m.skipped;
      EXPECT_TRUE(m.skipped.empty());
      ++images;
    }
  }
  EXPECT_EQ(skipped, 2u) << "once per loop";
  EXPECT_EQ(images, 2 * (dataset.size() - 1));
  EXPECT_EQ(player.skippedImages(), 2u);
  // The bag writer drops the frame the same way.
  const std::string bag = outputDir("player_corrupt_png_out") + "/corrupt.bag";
  EXPECT_EQ(writeBag(dataset, PlayerOptions(), bag), 5 * 20u + 381u + 19u - 5u);
}

TEST(PlayerCore, CachedImagesAreReadOncePerRunAndReplayIdentically) {
  // The soak benchmark's player (~cache_images): each file is read and decoded in the first loop only; the
  // later loops publish the same pixels from memory. Removing the files after the first loop shows it: with
  // the cache every image of loop 2 still comes, identical; without it each one is skipped.
  for (const bool cache : {true, false}) {
    const Dataset dataset = openSynthetic(cache ? "player_cache_on" : "player_cache_off");
    PlayerOptions options;
    options.loop = true;
    options.cache_images = cache;
    Player player(dataset, options);
    const size_t per_loop = player.schedule().size();
    const std::vector<PlayerMessage> first = drain(player, per_loop);
    for (size_t i = 0; i < dataset.size(); ++i) std::remove(dataset.imagePath(i).c_str());
    const std::vector<PlayerMessage> second = drain(player, per_loop);
    ASSERT_EQ(first.size(), second.size());
    size_t images = 0;
    for (size_t k = 0; k < first.size(); ++k) {
      if (first[k].kind != StreamKind::kImage) continue;
      ASSERT_TRUE(first[k].image) << first[k].skipped;
      EXPECT_EQ(second[k].loop, 1u);
      if (!cache) {
        EXPECT_FALSE(second[k].image) << "without the cache loop 2 reads the (removed) file again";
        continue;
      }
      ASSERT_TRUE(second[k].image) << second[k].skipped;
      EXPECT_EQ(second[k].image->data, first[k].image->data) << "image " << first[k].index;
      EXPECT_EQ(second[k].image->encoding, first[k].image->encoding);
      EXPECT_GT(second[k].image->header.stamp, first[k].image->header.stamp) << "fresh stamps per loop";
      ++images;
    }
    EXPECT_EQ(images, cache ? dataset.size() : 0u);
    EXPECT_EQ(player.skippedImages(), cache ? 0u : dataset.size());
  }
}

TEST(PlayerBag, DiskFullIsAnErrorNotATerminate) {
  // Issue 12: when the disk fills, rosbag throws BagIOException and Bag::~Bag() throws again while closing
  // the unfinished bag: std::terminate. /dev/full fails every write with ENOSPC, as a full disk does (a real
  // full filesystem needs a mount, which CI cannot do). writeBag must throw one error that says what failed.
  const Dataset dataset = openKitti();
  try {
    writeBag(dataset, PlayerOptions(), "/dev/full");
    ADD_FAILURE() << "writing to /dev/full succeeded";
  } catch (const std::exception& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/dev/full"), std::string::npos) << what;
    EXPECT_NE(what.find("writing the bag failed"), std::string::npos) << what;
  }
  // Mid-stream: the file may not grow past 64 kB (RLIMIT_FSIZE; writes then fail with EFBIG, SIGXFSZ
  // ignored), so the header is written and a later chunk fails, as when the disk fills during a recording.
  const std::string limited = outputDir("player_bag_fsize") + "/kitti.bag";
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  const sighandler_t old_handler = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = saved;
  small.rlim_cur = 64 * 1024;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string error;
  try {
    writeBag(dataset, PlayerOptions(), limited);
  } catch (const std::exception& e) {
    error = e.what();
  }
  setrlimit(RLIMIT_FSIZE, &saved);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(error.find("writing the bag failed: " + limited), std::string::npos) << error;
  // The process is still usable: the next bag is written normally.
  const std::string bag = outputDir("player_bag_after_full") + "/kitti.bag";
  EXPECT_EQ(writeBag(dataset, PlayerOptions(), bag), 5 * kKittiFrames);
}

TEST(PlayerCore, InitialStateIsTheGroundTruthAtTheFirstImagePlayed) {
  const std::string dir = outputDir("player_core_initial_state") + "/dataset";
  const PinholeCamera camera(32, 24, 30.0, 30.0, 15.5, 11.5);
  Pose T0 = Pose::Identity(), T1 = Pose::Identity();
  T0.translation() = Eigen::Vector3d(-250.0, -2400.0, 650.0);
  T1.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T1.translation() = Eigen::Vector3d(-249.4, -2392.5, 648.6);
  {
    DatasetWriter writer(dir, camera);
    writer.addFrame(0.0, cv::Mat(24, 32, CV_8UC1, cv::Scalar(80)), T0);
    writer.addFrame(0.1, cv::Mat(24, 32, CV_8UC1, cv::Scalar(90)), T1);
    for (int i = 0; i <= 20; ++i) {
      GroundTruthState state;
      state.timestamp_s = 0.005 * i;
      state.T_world_body = i < 20 ? T0 : T1;
      state.velocity_world_mps = Eigen::Vector3d(6.0, 75.0 - i, -14.0);
      writer.addGroundTruthState(state);
    }
  }
  const Dataset dataset = Dataset::open(dir);
  PlayerOptions options;
  options.start_index = 1;
  options.world_frame = "moon";
  const Player player(dataset, options);
  std::string why;
  const std::optional<nav_msgs::Odometry> state = initialStateMessage(player, &why);
  ASSERT_TRUE(state) << why;
  EXPECT_EQ(state->header.stamp, player.stampOf(0.1));
  EXPECT_EQ(state->header.frame_id, "moon");
  EXPECT_EQ(state->child_frame_id, "camera_optical");
  expectPoseNear(state->pose.pose, T1, "the camera pose at image 1");
  EXPECT_EQ(state->twist.twist.linear.y, 55.0);  // groundtruth_state.txt at 0.1 s, world frame
  EXPECT_EQ(state->twist.twist.linear.z, -14.0);

  // In a bag (player --bag --initial-state): the first message, latched for rosbag play.
  const std::string bag_path = outputDir("player_core_initial_state_bag") + "/with_state.bag";
  options.publish_initial_state = true;
  writeBag(dataset, options, bag_path);
  rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
  rosbag::View view(bag);
  ASSERT_GT(view.size(), 0u);
  rosbag::View::iterator it = view.begin();
  const rosbag::MessageInstance& first = *it;
  EXPECT_EQ(first.getTopic(), "/nav/initial_state");  // 1 ms before the first image: played first
  EXPECT_EQ(first.getTime(), player.stampOf(0.1) - ros::Duration(0.001));
  ASSERT_TRUE(first.getConnectionHeader());
  EXPECT_EQ(first.getConnectionHeader()->at("latching"), "1");
  const auto msg = first.instantiate<nav_msgs::Odometry>();
  ASSERT_TRUE(msg);
  EXPECT_EQ(msg->twist.twist.linear.y, 55.0);

  // No ground-truth state: no handover (and the bag writer refuses rather than inventing one).
  const Dataset synthetic = openSynthetic("player_core_no_state");
  EXPECT_FALSE(initialStateMessage(Player(synthetic, PlayerOptions()), &why));
  EXPECT_NE(why.find("groundtruth_state"), std::string::npos) << why;
  PlayerOptions with_state;
  with_state.publish_initial_state = true;
  EXPECT_THROW(writeBag(synthetic, with_state, outputDir("player_core_no_state") + "/x.bag"),
               std::runtime_error);
}

TEST(PlayerCommandLine, ParsesOptionsAndRejectsUnknownOnes) {
  const PlayerCommandLine cl = parsePlayerCommandLine(
      {"--dataset", "/d", "--bag", "o.bag", "--start", "3", "--time-offset", "12.5", "--world-frame", "moon",
       "--camera-frame", "cam", "--gt-frame", "truth", "--no-path"});
  EXPECT_FALSE(cl.help);
  EXPECT_EQ(cl.dataset, "/d");
  EXPECT_EQ(cl.bag, "o.bag");
  PlayerOptions options;
  applyCommandLine(cl, &options);
  EXPECT_EQ(options.start_index, 3u);
  EXPECT_EQ(options.time_offset_s, 12.5);
  EXPECT_EQ(options.world_frame, "moon");
  EXPECT_EQ(options.camera_frame, "cam");
  EXPECT_EQ(options.ground_truth_frame, "truth");
  EXPECT_FALSE(options.publish_path);
  EXPECT_FALSE(options.publish_initial_state);
  applyCommandLine(parsePlayerCommandLine({"--initial-state"}), &options);
  EXPECT_TRUE(options.publish_initial_state);

  PlayerOptions untouched;
  applyCommandLine(parsePlayerCommandLine({}), &untouched);
  EXPECT_EQ(untouched.start_index, 0u);
  EXPECT_EQ(untouched.time_offset_s, -1.0);
  EXPECT_TRUE(untouched.publish_path);
  EXPECT_TRUE(parsePlayerCommandLine({"-h"}).help);

  EXPECT_THROW(parsePlayerCommandLine({"--dataset"}), std::invalid_argument);
  EXPECT_THROW(parsePlayerCommandLine({"--start", "-1"}), std::invalid_argument);
  EXPECT_THROW(parsePlayerCommandLine({"--start", "2.5"}), std::invalid_argument);
  EXPECT_THROW(parsePlayerCommandLine({"--time-offset", "12x"}), std::invalid_argument);
  EXPECT_THROW(parsePlayerCommandLine({"--rate", "2"}), std::invalid_argument);
  EXPECT_THROW(parsePlayerCommandLine({"_rate:=2"}), std::invalid_argument);
}

}  // namespace
}  // namespace planetary_vo::ros_io
