/// @file vo_nodelet.cpp
/// The nodelet planetary_vo/VisualOdometryNodelet: camera/image_raw + camera/camera_info in, the pipeline's
/// FrameResult out as pose, odometry, path, map points, status, tf and diagnostics. Topics, frames and
/// parameters: docs/ros_interface.md. Everything here is glue; the conversions are free functions
/// (conversions.h, vo_conversions.h), the parameters come from ros_params.h, the diagnostics from
/// status_reporter.h and the odometry from the ROS-free Pipeline.
///
/// Threading: all callbacks use the nodelet's single-threaded node handles, so they never overlap; the
/// dynamic_reconfigure knobs are handed over under a mutex anyway and applied between two frames.

#include <memory>
#include <mutex>
#include <optional>

#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseStamped.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/Range.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <pluginlib/class_list_macros.hpp>

#include "planetary_vo/VoReconfigureConfig.h"
#include "planetary_vo/VoStatus.h"
#include "planetary_vo/ros_io/conversions.h"
#include "planetary_vo/ros_io/ros_params.h"
#include "planetary_vo/ros_io/status_reporter.h"
#include "planetary_vo/ros_io/vo_conversions.h"
#include "planetary_vo/vo/pipeline.h"

namespace planetary_vo::ros_io {

class VisualOdometryNodelet : public nodelet::Nodelet {
 private:
  using Clock = std::chrono::steady_clock;

  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    params_ = loadNodeletParams(pnh);
    reporter_ =
        std::make_unique<StatusReporter>(nh, pnh, getName(), params_.min_rate_hz, params_.max_rate_hz, 30);
    status_pub_ = nh.advertise<VoStatus>("vo/status", 10);
    watchdog_ = nh.createWallTimer(ros::WallDuration(1.0), &VisualOdometryNodelet::watchdogCb, this);
    try {
      config_ = loadVoConfigFromParams(pnh);
    } catch (const ConfigError& e) {
      config_problem_ = std::string("configuration error: ") + e.what();
      NODELET_ERROR_STREAM(config_problem_ << "\nThe nodelet does not subscribe until it is reloaded.");
      return;
    }
    NODELET_DEBUG_STREAM("pipeline configuration:\n" << config_.dump());
    image_transport::ImageTransport it(nh);
    pose_pub_ = nh.advertise<geometry_msgs::PoseStamped>("vo/pose", 10);
    odom_pub_ = nh.advertise<nav_msgs::Odometry>("vo/odometry", 10);
    path_pub_ = nh.advertise<nav_msgs::Path>("vo/path", 1);
    map_pub_ = nh.advertise<sensor_msgs::PointCloud2>("vo/map_points", 1);
    tracking_pub_ = it.advertise("vo/tracking_image", 1);
    reset_srv_ = nh.advertiseService("vo/reset", &VisualOdometryNodelet::resetCb, this);
    if (!params_.base_frame.empty()) {
      tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
      tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
    }
    reconfigure_ =
        std::make_unique<dynamic_reconfigure::Server<VoReconfigureConfig>>(reconfigure_mutex_, pnh);
    VoReconfigureConfig knobs;
    knobs.num_features = config_.detector.num_features;
    knobs.motion_model = toString(config_.motion.model);
    knobs.bundle_adjustment_enabled = config_.bundle_adjustment.enabled;
    reconfigure_->updateConfig(knobs);
    reconfigure_->setCallback(
        [this](VoReconfigureConfig& knobs, uint32_t level) { reconfigureCb(knobs, level); });
    imu_sub_ = nh.subscribe("imu", 100, &VisualOdometryNodelet::imuCb, this);
    altimeter_sub_ = nh.subscribe("altimeter", 10, &VisualOdometryNodelet::altimeterCb, this);
    info_sub_ = nh.subscribe("camera/camera_info", 1, &VisualOdometryNodelet::infoOnlyCb, this);
    camera_sub_ =
        it.subscribeCamera("camera/image_raw", params_.queue_size, &VisualOdometryNodelet::imageCb, this);
  }

  void imageCb(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info) {
    const Clock::time_point start = Clock::now();
    last_frame_wall_ = start;
    ++counts_.num_images;
    std_msgs::Header header = image->header;
    header.frame_id = params_.world_frame;
    const std::string child = childFrame(image->header.frame_id);
    cv::Mat gray;
    std::string why = checkCameraInfo(*info);
    if (why.empty() && !toGray8(image, &gray, &why)) {
    } else if (why.empty() && (gray.cols != int(info->width) || gray.rows != int(info->height))) {
      why = "image size " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
            " does not match camera_info " + std::to_string(info->width) + "x" + std::to_string(info->height);
    } else if (why.empty() && last_stamp_ && image->header.stamp <= *last_stamp_) {
      why = image->header.stamp == *last_stamp_
                ? "duplicate image stamp " + std::to_string(image->header.stamp.toSec())
                : "image stamp went backwards by " +
                      std::to_string((*last_stamp_ - image->header.stamp).toSec()) +
                      " s (call vo/reset after restarting a bag)";
    } else if (why.empty()) {
      why = checkExposure(gray, params_.min_exposure_stddev, params_.max_saturated_ratio);
    }
    if (!why.empty()) return reject(why, header);

    const double t = image->header.stamp.toSec();
    std::string note = frameGapNote(t);
    last_stamp_ = image->header.stamp;
    applyPendingConfig(t);
    const PinholeCamera camera = fromCameraInfo(*info);
    if (!pipeline_) {
      pipeline_ = makePipeline(config_, camera);
    } else if (camera != pipeline_->camera()) {
      NODELET_WARN_STREAM("camera changed to " << camera.width() << "x" << camera.height() << ", fx "
                                               << camera.fx()
                                               << ": the pipeline re-initialises from the held pose");
      pipeline_->setCamera(camera);
      note += (note.empty() ? "" : "; ") + std::string("camera_info changed: re-initialising");
    }
    const Clock::time_point process_start = Clock::now();
    FrameResult result;
    try {
      result = pipeline_->process(t, gray);
    } catch (const std::invalid_argument& e) {
      return reject(std::string("pipeline rejected the image: ") + e.what(), header);
    }
    const Clock::duration process_time = Clock::now() - process_start;
    if (!note.empty()) result.message = note + (result.message.empty() ? "" : "; " + result.message);
    const bool published = result.processed && publishPose(result, header, child);
    if (result.processed && tracking_pub_.getNumSubscribers() > 0)
      tracking_pub_.publish(drawTracks(gray, pipeline_->tracks(), result, image->header));
    VoStatus status = toVoStatus(result, image->header);
    status.ros_overhead_ms =
        std::chrono::duration<float, std::milli>(Clock::now() - start - process_time).count();
    publishStatus(status, published);
  }

  /// Pose, odometry, path, map points and tf of a processed frame; false if the pose was not finite (held).
  bool publishPose(const FrameResult& result, const std_msgs::Header& header, const std::string& child) {
    Pose T_world_cam = anchor_.transformPose(result.T_world_cam);
    if (anchor_scale_pending_) {
      if (!result.hasPoseEstimate() || result.T_world_cam.translation().norm() <= 0.0) {
        T_world_cam = last_pose_;
      } else {  // first pose of a rebuilt pipeline: bridge the scale with the speed before the rebuild
        const double travelled = speed_ * (result.timestamp_s - anchor_time_s_);
        anchor_.scale = travelled > 0.0 ? travelled / result.T_world_cam.translation().norm() : 1.0;
        anchor_scale_pending_ = false;
        T_world_cam = anchor_.transformPose(result.T_world_cam);
      }
    }
    if (!T_world_cam.matrix().allFinite()) {
      NODELET_ERROR_THROTTLE(5, "the pipeline returned a non-finite pose: holding the last pose");
      T_world_cam = last_pose_;
    }
    Pose T_world_child = T_world_cam;
    if (!params_.base_frame.empty()) {
      try {
        T_world_child =
            T_world_cam *
            fromTransformMsg(
                tf_buffer_->lookupTransform(child_camera_frame_, params_.base_frame, ros::Time(0)).transform);
      } catch (const tf2::TransformException& e) {
        NODELET_WARN_THROTTLE(5, "no static transform %s -> %s (%s): not publishing",
                              child_camera_frame_.c_str(), params_.base_frame.c_str(), e.what());
        return false;
      }
    }
    const double dt = have_last_pose_ ? result.timestamp_s - last_pose_time_s_ : 0.0;
    if (result.hasPoseEstimate() && have_last_pose_ && dt > 0.0)
      speed_ = (T_world_cam.translation() - last_pose_.translation()).norm() / dt;
    pose_pub_.publish(toPoseStamped(T_world_child, header));
    const OdometrySigma sigma{params_.position_sigma_m, params_.orientation_sigma_rad,
                              params_.lost_sigma_factor, config_.pnp.min_inliers * 4};
    odom_pub_.publish(toOdometry(result, T_world_child, last_child_pose_, dt, header, child, sigma));
    if (params_.publish_tf) tf_broadcaster_.sendTransform(toTransformStamped(T_world_child, header, child));
    path_.header = header;
    path_.poses.push_back(toPoseStamped(T_world_child, header));
    if (params_.max_path_length > 0 && int(path_.poses.size()) > params_.max_path_length)
      path_.poses.erase(path_.poses.begin());
    if (path_pub_.getNumSubscribers() > 0) path_pub_.publish(path_);
    if (map_pub_.getNumSubscribers() > 0) {
      pipeline_->mapPoints(&map_points_);
      map_pub_.publish(toPointCloud(map_points_, header, anchor_));
    }
    last_pose_ = T_world_cam;
    last_child_pose_ = T_world_child;
    last_pose_time_s_ = result.timestamp_s;
    have_last_pose_ = true;
    return true;
  }

  std::string childFrame(const std::string& image_frame) {
    child_camera_frame_ = params_.camera_frame.empty() ? image_frame : params_.camera_frame;
    return params_.base_frame.empty() ? child_camera_frame_ : params_.base_frame;
  }

  /// A note when the gap to the previous image is much longer than the usual period (dropped frames).
  std::string frameGapNote(double t) {
    std::string note;
    if (last_stamp_) {
      const double dt = t - last_stamp_->toSec();
      if (period_s_ > 0.0 && dt > params_.max_frame_gap_factor * period_s_)
        note = "about " + std::to_string(int(dt / period_s_ + 0.5) - 1) + " frames dropped (gap " +
               std::to_string(dt) + " s, period " + std::to_string(period_s_) + " s)";
      else
        period_s_ = period_s_ > 0.0 ? 0.9 * period_s_ + 0.1 * dt : dt;
    }
    return note;
  }

  void reject(const std::string& why, const std_msgs::Header& header) {
    ++counts_.num_bad_images;
    NODELET_WARN_STREAM_THROTTLE(5, "bad input, frame skipped: " << why);
    publishStatus(badInputStatus(why, header), false);
  }

  void publishStatus(VoStatus status, bool published_odometry) {
    status.num_images = counts_.num_images;
    status.num_bad_images = counts_.num_bad_images;
    status.num_imu_msgs = counts_.num_imu_msgs;
    status.num_altimeter_msgs = counts_.num_altimeter_msgs;
    status.header.frame_id = params_.world_frame;
    reporter_->update(status, published_odometry);
    status_pub_.publish(status);
  }

  std::unique_ptr<Pipeline> makePipeline(const VoConfig& config, const PinholeCamera& camera) {
    // The homography's plane prior comes from the configuration (~motion/plane_normal_prior), like every
    // other pipeline setting: one default, in the core struct.
    return std::make_unique<Pipeline>(config, camera);
  }

  /// Between two frames: a changed configuration rebuilds the pipeline, attached to the last pose (the new
  /// pipeline starts at its own origin; its scale is bridged with the last speed, see publishPose()).
  void applyPendingConfig(double t) {
    std::optional<VoConfig> pending;
    {
      std::lock_guard<std::mutex> lock(pending_mutex_);
      pending.swap(pending_config_);
    }
    if (!pending || *pending == config_) return;
    config_ = *pending;
    if (!pipeline_) return;
    const PinholeCamera camera = pipeline_->camera();
    pipeline_ = makePipeline(config_, camera);
    if (have_last_pose_) {
      anchor_ = Sim3Transform();
      anchor_.R_gt_est = last_pose_.rotation();
      anchor_.t_gt_est_m = last_pose_.translation();
      anchor_scale_pending_ = true;
      anchor_time_s_ = t;
    }
    NODELET_INFO("reconfigured: num_features %d, motion model %s, bundle adjustment %s",
                 config_.detector.num_features, toString(config_.motion.model),
                 config_.bundle_adjustment.enabled ? "on" : "off");
  }

  void reconfigureCb(VoReconfigureConfig& knobs, uint32_t /*level*/) {
    VoConfig next = config_;
    next.detector.num_features = knobs.num_features;
    next.bundle_adjustment.enabled = knobs.bundle_adjustment_enabled;
    for (MotionModel m :
         {MotionModel::kAuto, MotionModel::kEssential, MotionModel::kFundamental, MotionModel::kHomography})
      if (knobs.motion_model == toString(m)) next.motion.model = m;
    const std::vector<std::string> errors = next.validationErrors();
    if (!errors.empty()) {
      NODELET_ERROR_STREAM("reconfigure rejected: " << errors.front());
      return;
    }
    std::lock_guard<std::mutex> lock(pending_mutex_);
    pending_config_ = next;
  }

  bool resetCb(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    if (pipeline_) pipeline_->reset();
    anchor_ = Sim3Transform();
    anchor_scale_pending_ = false;
    have_last_pose_ = false;
    last_pose_ = last_child_pose_ = Pose::Identity();
    last_stamp_.reset();
    period_s_ = speed_ = 0.0;
    path_.poses.clear();
    counts_ = VoStatus();
    res.success = true;
    res.message = "visual odometry reset: the next image starts a new trajectory at the origin";
    NODELET_INFO_STREAM(res.message);
    return true;
  }

  /// Once a second: diagnostics, and a BAD_INPUT status while no synchronised image + camera_info arrives.
  void watchdogCb(const ros::WallTimerEvent&) {
    const double idle_s = std::chrono::duration<double>(Clock::now() - last_frame_wall_).count();
    std::string problem = config_problem_;
    if (problem.empty() && idle_s > 2.0) {
      problem = info_count_ > 0 ? "camera_info arrives but no image with the same stamp"
                                : "no camera_info received: images are ignored until it arrives (waiting for "
                                  "camera/image_raw + camera/camera_info)";
      info_count_ = 0;
    }
    reporter_->setInputProblem(problem);
    if (!problem.empty()) {
      NODELET_WARN_STREAM_THROTTLE(10, problem);
      publishStatus(badInputStatus(problem, std_msgs::Header()), false);
    }
    reporter_->tick();
  }

  void infoOnlyCb(const sensor_msgs::CameraInfoConstPtr&) { ++info_count_; }
  void imuCb(const sensor_msgs::ImuConstPtr&) { ++counts_.num_imu_msgs; }
  void altimeterCb(const sensor_msgs::RangeConstPtr&) { ++counts_.num_altimeter_msgs; }

  NodeletParams params_;
  VoConfig config_;
  std::string config_problem_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<StatusReporter> reporter_;

  image_transport::CameraSubscriber camera_sub_;
  image_transport::Publisher tracking_pub_;
  ros::Subscriber info_sub_, imu_sub_, altimeter_sub_;
  ros::Publisher pose_pub_, odom_pub_, path_pub_, map_pub_, status_pub_;
  ros::ServiceServer reset_srv_;
  ros::WallTimer watchdog_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<VoReconfigureConfig>> reconfigure_;
  std::mutex pending_mutex_;
  std::optional<VoConfig> pending_config_;

  // Stream state.
  std::optional<ros::Time> last_stamp_;
  double period_s_ = 0.0;  ///< smoothed image period
  Clock::time_point last_frame_wall_ = Clock::now();
  int info_count_ = 0;
  VoStatus counts_;  ///< only the counters are used
  std::string child_camera_frame_;
  Sim3Transform anchor_;  ///< pipeline world -> output world (identity until a reconfigure rebuild)
  bool anchor_scale_pending_ = false;
  double anchor_time_s_ = 0.0, speed_ = 0.0;
  Pose last_pose_ = Pose::Identity(), last_child_pose_ = Pose::Identity();
  double last_pose_time_s_ = 0.0;
  bool have_last_pose_ = false;
  nav_msgs::Path path_;
  std::vector<MapPointView> map_points_;
};

}  // namespace planetary_vo::ros_io

PLUGINLIB_EXPORT_CLASS(planetary_vo::ros_io::VisualOdometryNodelet, nodelet::Nodelet)
