/// @file vo_nodelet.cpp
/// The nodelet planetary_vo/VisualOdometryNodelet: camera/image_raw + camera/camera_info, imu, altimeter and
/// nav/initial_state in; the pipeline's FrameResult out as pose, odometry, path, map points, status, tf and
/// diagnostics, and the metric navigation output nav/odometry at the image rate and, between images, at the
/// IMU rate (Pipeline::navStateAt). Topics, frames and parameters: docs/ros_interface.md. Everything here is
/// glue; the conversions are free functions (conversions.h, vo_conversions.h), the samples wait in
/// SampleBuffers (sample_buffer.h) until the image they precede, the parameters come from ros_params.h, the
/// diagnostics from status_reporter.h and every estimate from the ROS-free Pipeline.
///
/// Threading: all callbacks use the nodelet's single-threaded node handles, so they never overlap; the
/// dynamic_reconfigure knobs are handed over under a mutex anyway and applied between two frames, in place
/// (Pipeline::reconfigure: the nodelet holds no estimation state of its own). No exception leaves a callback:
/// every pipeline call is guarded, a refused sample or reconfiguration is counted or logged and reported in
/// vo/status.

#include <algorithm>
#include <cmath>
#include <deque>
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
#include <boost/make_shared.hpp>
#include <pluginlib/class_list_macros.hpp>

#include "planetary_vo/VoReconfigureConfig.h"
#include "planetary_vo/VoStatus.h"
#include "planetary_vo/ros_io/containment.h"
#include "planetary_vo/ros_io/conversions.h"
#include "planetary_vo/ros_io/map_event_conversions.h"
#include "planetary_vo/ros_io/ros_params.h"
#include "planetary_vo/ros_io/sample_buffer.h"
#include "planetary_vo/ros_io/status_reporter.h"
#include "planetary_vo/ros_io/vo_conversions.h"
#include "planetary_vo/vo/cpu_budget.h"
#include "planetary_vo/vo/pipeline.h"

namespace planetary_vo::ros_io {

class VisualOdometryNodelet : public nodelet::Nodelet {
 private:
  using Clock = std::chrono::steady_clock;

  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    std::vector<std::string> param_problems;
    params_ = loadNodeletParams(pnh, &param_problems);
    for (const std::string& problem : param_problems) NODELET_ERROR_STREAM("parameter rejected: " << problem);
    reporter_ =
        std::make_unique<StatusReporter>(nh, pnh, getName(), params_.min_rate_hz, params_.max_rate_hz, 30);
    status_pub_ = nh.advertise<VoStatus>("vo/status", 10);
    watchdog_ = nh.createWallTimer(ros::WallDuration(1.0), &VisualOdometryNodelet::watchdogCb, this);
    try {
      config_ = loadVoConfigFromParams(pnh);
      // A misspelt section (~detecter/...) or parameter (~max_path_lenght) would be silently ignored: an
      // error like an unknown key inside a section.
      std::vector<std::string> known = nodeletParamNames();
      known.insert(known.end(), std::begin(kVoConfigSections), std::end(kVoConfigSections));
      for (const auto& knob : VoReconfigureConfig::__getParamDescriptions__()) known.push_back(knob->name);
      const std::vector<std::string> unknown = unknownPrivateNames(pnh, known);
      if (!unknown.empty()) throw ConfigError(unknown);
    } catch (const ConfigError& e) {
      config_problem_ = std::string("configuration error: ") + e.what();
      NODELET_ERROR_STREAM(config_problem_ << "\nThe nodelet does not subscribe until it is reloaded.");
      return;
    }
    mode_ = navigationMode(config_);
    if (mode_ != VoStatus::MODE_VISION) reporter_->enableNavigationRate();
    NODELET_INFO_STREAM("navigation mode " << mode_
                                           << (params_.wait_for_initial_state
                                                   ? ", waiting for the initial state on nav/initial_state"
                                                   : ""));
    NODELET_DEBUG_STREAM("pipeline configuration:\n" << config_.dump());
    image_transport::ImageTransport it(nh);
    pose_pub_ = nh.advertise<geometry_msgs::PoseStamped>("vo/pose", 10);
    odom_pub_ = nh.advertise<nav_msgs::Odometry>("vo/odometry", 10);
    nav_pub_ = nh.advertise<nav_msgs::Odometry>("nav/odometry", 100);
    path_pub_ = nh.advertise<nav_msgs::Path>("vo/path", 1);
    map_pub_ = nh.advertise<sensor_msgs::PointCloud2>("vo/map_points", 1);
    map_events_pub_ = nh.advertise<VoMapEvents>("vo/map_events", 100);
    tracking_pub_ = it.advertise("vo/tracking_image", 1);
    reset_srv_ = nh.advertiseService("vo/reset", &VisualOdometryNodelet::resetCb, this);
    if (!params_.base_frame.empty()) {
      tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
      tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
    }
    reconfigure_ =
        std::make_unique<dynamic_reconfigure::Server<VoReconfigureConfig>>(reconfigure_mutex_, pnh);
    reconfigure_->updateConfig(knobsOf(config_));
    reconfigure_->setCallback(
        [this](VoReconfigureConfig& knobs, uint32_t level) { reconfigureCb(knobs, level); });
    initial_state_sub_ = nh.subscribe("nav/initial_state", 1, &VisualOdometryNodelet::initialStateCb, this);
    imu_sub_ = nh.subscribe("imu", params_.imu_queue_size, &VisualOdometryNodelet::imuCb, this,
                            ros::TransportHints().tcpNoDelay());
    altimeter_sub_ =
        nh.subscribe("altimeter", params_.altimeter_queue_size, &VisualOdometryNodelet::altimeterCb, this);
    info_sub_ = nh.subscribe("camera/camera_info", 1, &VisualOdometryNodelet::infoOnlyCb, this);
    camera_sub_ =
        it.subscribeCamera("camera/image_raw", params_.queue_size, &VisualOdometryNodelet::imageCb, this);
  }

  /// Every callback body runs through here: an exception of any type (OpenCV, Ceres, the allocator, ...) is
  /// logged and reported in vo/status with its cause, never let out to the nodelet manager (which would abort
  /// every nodelet it holds). `header` non-null: the frame is rejected (BAD_INPUT on its stamp).
  template <class Body>
  void contained(const char* where, const std_msgs::Header* header, Body&& body) {
    const std::optional<std::string> why = ros_io::runContained(std::forward<Body>(body));
    if (!why) return;
    try {
      const std::string what = std::string(where) + " failed: " + *why;
      NODELET_ERROR_STREAM_THROTTLE(5, what);
      if (header) {
        reject(what + " (frame rejected, the node continues)", *header);
      } else {
        std::lock_guard<std::mutex> lock(pending_mutex_);
        callback_problem_ = what;
      }
    } catch (...) {
    }
  }

  void imageCb(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info) {
    std_msgs::Header header = image->header;
    header.frame_id = params_.world_frame;
    contained("image processing", &header, [&] { processImage(image, info, header); });
  }

  void processImage(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info,
                    const std_msgs::Header& header) {
    const Clock::time_point start = Clock::now();
    last_frame_wall_ = start;
    ++counts_.num_images;
    const std::string child = childFrame(image->header.frame_id);
    cv::Mat gray;
    std::string why = checkCameraInfo(*info);
    if (why.empty() && !toGray8(image, &gray, &why, params_.mono16_significant_bits)) {
    } else if (why.empty() && (gray.cols != int(info->width) || gray.rows != int(info->height))) {
      why = "image size " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
            " does not match camera_info " + std::to_string(info->width) + "x" + std::to_string(info->height);
    }
    std::string stamp_note;
    bool restart_tracking = false;
    // The exposure (black, blank, saturated) and frozen-frame checks are the core's (input_check.h), shared
    // with vo_run: such an image comes back as result.input_rejected with the reason.
    // Last: it may change the stream state (an image that confirms a jump), which only a usable image may do.
    if (why.empty() && last_stamp_) why = checkStamp(image->header.stamp, &stamp_note, &restart_tracking);
    if (!why.empty()) return reject(why, header);

    const double t = timeOf(image->header.stamp);
    std::string note = restart_tracking ? std::string() : frameGapNote(image->header.stamp);
    if (!stamp_note.empty()) note = stamp_note + (note.empty() ? "" : "; " + note);
    if (restart_tracking && pipeline_) pipeline_->restartTracking();
    last_stamp_ = image->header.stamp;
    if (!started_ && !readyToStart(t, &why, &note)) return hold(why, image->header, t);
    const PinholeCamera camera = fromCameraInfo(*info);
    FrameResult result;
    Clock::duration process_time{};
    try {
      // Between two frames: a dynamic_reconfigure change goes into the running pipeline in place (or into
      // the configuration of the pipeline made below).
      applyPendingConfig(&note);
      if (!pipeline_) {
        pipeline_ = makePipeline(config_, camera);
        cpu_budget_ = std::make_unique<CpuBudget>(config_);
        imu_buffer_.restart();
        altimeter_buffer_.restart();
      } else if (camera != pipeline_->camera()) {
        NODELET_WARN_STREAM("camera changed to " << camera.width() << "x" << camera.height() << ", fx "
                                                 << camera.fx()
                                                 << ": the pipeline re-initialises from the held pose");
        pipeline_->setCamera(camera);
        note += (note.empty() ? "" : "; ") + std::string("camera_info changed: re-initialising");
      }
      if (!started_ && pending_state_ && !applyInitialState(&why)) return hold(why, image->header, t);
      giveSamplesUpTo(t);
      const Clock::time_point process_start = Clock::now();
      result = pipeline_->process(t, gray);
      process_time = Clock::now() - process_start;
      applyCpuBudget(std::chrono::duration<double, std::milli>(process_time).count(), &note);
    } catch (const std::invalid_argument& e) {  // documented: the pipeline's state is unchanged
      return reject(std::string("pipeline rejected the image: ") + e.what(), header);
    } catch (const std::exception& e) {
      // Anything else (OpenCV, Ceres, memory) may have stopped the pipeline half-way through the frame: its
      // tracks are dropped and it re-initialises from the current pose at the next image (no jump).
      if (pipeline_) pipeline_->restartTracking();
      return reject(std::string("pipeline failed on the image (") + e.what() +
                        "): frame rejected, tracking restarts from the current pose",
                    header);
    }
    if (!started_) pending_state_.reset();  // consumed by the first image (applyInitialState)
    started_ = true;
    // Refused by the core's input check (e.g. a frozen frame): BAD_INPUT with the core's reason, nothing
    // published; the pipeline coasts and tracks the next fresh image. Without a map yet, camera + IMU: the
    // navigation still goes on, the IMU's dead reckoning from the handed-over state (not confident).
    if (result.input_rejected) {
      if (result.inertial_only) {
        std::string untrusted;
        if (checkOutputPose(result.T_world_cam, &untrusted))
          publishNavAtImage(result, result.T_world_cam, header);
        else
          NODELET_ERROR_STREAM_THROTTLE(5, "dead-reckoned pose not published: " << untrusted);
      }
      return reject(result.message, header);
    }
    if (!note.empty()) result.message = note + (result.message.empty() ? "" : "; " + result.message);
    // The last guard: a pose that is not finite, not rigid (a non-unit quaternion) or absurdly far is never
    // published; the frame is reported LOST with the reason, the outputs keep their last pose.
    std::string untrusted;
    if (result.processed && !checkOutputPose(result.T_world_cam, &untrusted)) {
      NODELET_ERROR_STREAM_THROTTLE(5, "pose not published: " << untrusted);
      result.state = TrackingState::kLost;
      result.message =
          "pose not published: " + untrusted + (result.message.empty() ? "" : "; " + result.message);
      result.processed = false;
    }
    const bool published = result.processed && publishPose(result, header, child);
    if (result.processed && !result.map_events.empty() && map_events_pub_.getNumSubscribers() > 0)
      publishMapEvents(result, header, image->header, gray);
    if (result.processed && tracking_pub_.getNumSubscribers() > 0)
      tracking_pub_.publish(drawTracks(gray, pipeline_->tracks(), result, image->header));
    VoStatus status = toVoStatus(result, image->header);
    status.ros_overhead_ms =
        std::chrono::duration<float, std::milli>(Clock::now() - start - process_time).count();
    publishStatus(status, published);
  }

  /// Seconds since the stream's epoch (the whole second of the first stamp seen): the pipeline's clock. Small
  /// numbers keep the IMU's 5 ms steps exact in a double.
  double timeOf(const ros::Time& stamp) {
    if (!have_epoch_ && !stamp.isZero()) {
      epoch_ = ros::Time(stamp.sec, 0);
      have_epoch_ = true;
    }
    return toDatasetTime(epoch_, stamp);
  }
  const ros::Time& epochFor(const ros::Time& stamp) {
    timeOf(stamp);
    return epoch_;
  }

  /// Before the first image of a trajectory: whether this image may start it (the handed-over state fits its
  /// stamp, or no state is awaited). *why says why not; *note gets what the status should mention anyway.
  bool readyToStart(double t, std::string* why, std::string* note) {
    if (pending_state_) {
      const double t_state = pending_state_->header.stamp.isZero() ? t : timeOf(pending_state_->header.stamp);
      if (t < t_state - params_.initial_state_tolerance_s) {
        *why = "image " + std::to_string(t_state - t) +
               " s before the stamp of the handed-over initial state: skipped";
        return false;
      }
      if (t > t_state + params_.initial_state_tolerance_s) {
        const std::string stale =
            "initial state stamped " + std::to_string(t - t_state) +
            " s before the first image (more than ~initial_state_tolerance): not applied";
        NODELET_WARN_STREAM(stale);
        *note += (note->empty() ? "" : "; ") + stale;
        pending_state_.reset();
      } else {
        return true;
      }
    }
    if (params_.wait_for_initial_state) {
      *why = "waiting for the initial state on " + initial_state_sub_.getTopic() +
             (note->empty() ? "" : " (" + *note + ")");
      return false;
    }
    return true;
  }

  /// An image that does not start the trajectory yet: a status (initialising, not processed), and the samples
  /// up to it forgotten (they precede the trajectory).
  void hold(const std::string& why, const std_msgs::Header& image_header, double t) {
    NODELET_INFO_STREAM_THROTTLE(5, why);
    imu_buffer_.discardUpTo(t + config_.imu.time_offset_s);
    altimeter_buffer_.discardUpTo(t);
    VoStatus status = badInputStatus(why, image_header);
    status.state = VoStatus::STATE_INITIALISING;
    status.state_name = toString(TrackingState::kInitialising);
    publishStatus(status, false);
  }

  /// The pending handover into the fresh pipeline (setInitialState). False, with *why, when it is refused.
  bool applyInitialState(std::string* why) {
    InitialState state;
    if (!fromInitialStateMsg(*pending_state_, pipeline_->T_cam_imu(), &state, why)) {
      pending_state_.reset();
      return false;
    }
    try {
      pipeline_->setInitialState(state.T_world_cam, state.v_world_imu_mps);
    } catch (const std::exception& e) {
      *why = std::string("initial state refused by the pipeline: ") + e.what();
      pending_state_.reset();
      return false;
    }
    if (!pending_state_->child_frame_id.empty() && !child_camera_frame_.empty() &&
        pending_state_->child_frame_id != child_camera_frame_)
      NODELET_WARN_STREAM("the initial state's child_frame_id is '"
                          << pending_state_->child_frame_id << "', the camera frame '" << child_camera_frame_
                          << "': it is taken as the pose of the camera optical frame");
    initial_state_applied_ = true;
    NODELET_INFO_STREAM("initial state applied: camera at "
                        << state.T_world_cam.translation().transpose() << " m, IMU velocity "
                        << state.v_world_imu_mps.transpose() << " m/s (" << params_.world_frame << ")");
    return true;
  }

  /// Every buffered sample up to the image at t (IMU: on its own clock, t + imu.time_offset_s), in stamp
  /// order.
  void giveSamplesUpTo(double t) {
    altimeter_buffer_.giveUpTo(t, [this](const AltimeterSample& s) { giveAltimeter(s); });
    imu_buffer_.giveUpTo(t + config_.imu.time_offset_s, [this](const ImuSample& s) { giveImu(s); });
  }

  void giveImu(const ImuSample& s) {
    try {
      pipeline_->addImu(s);
    } catch (const std::exception& e) {
      return rejectImu(std::string("refused by the pipeline: ") + e.what());
    }
    ++counts_.num_imu_used;
    last_gyro_radps_ = s.angular_velocity_radps;
    have_gyro_ = true;
  }

  void giveAltimeter(const AltimeterSample& s) {
    try {
      pipeline_->addAltimeter(s);
    } catch (const std::exception& e) {
      return rejectAltimeter(std::string("refused by the pipeline: ") + e.what());
    }
    if (s.hasReturn())
      ++counts_.num_altimeter_used;
    else
      ++counts_.num_altimeter_no_range;
  }

  void rejectImu(const std::string& why) {
    ++counts_.num_imu_rejected;
    NODELET_WARN_STREAM_THROTTLE(5, "IMU sample rejected: " << why);
    if (imu_problem_.empty()) imu_problem_ = why;
  }
  void rejectAltimeter(const std::string& why) {
    ++counts_.num_altimeter_rejected;
    NODELET_WARN_STREAM_THROTTLE(5, "altimeter reading rejected: " << why);
    if (altimeter_problem_.empty()) altimeter_problem_ = why;
  }

  /// Pose, odometry, path, map points and tf of a processed frame; false if the pose was not finite (held).
  bool publishPose(const FrameResult& result, const std_msgs::Header& header, const std::string& child) {
    const Pose& T_world_cam = result.T_world_cam;
    Pose T_world_child = T_world_cam;
    if (!params_.base_frame.empty()) {
      try {
        T_cam_child_ = fromTransformMsg(
            tf_buffer_->lookupTransform(child_camera_frame_, params_.base_frame, ros::Time(0)).transform);
        T_world_child = T_world_cam * T_cam_child_;
      } catch (const tf2::TransformException& e) {
        NODELET_WARN_THROTTLE(5, "no static transform %s -> %s (%s): not publishing",
                              child_camera_frame_.c_str(), params_.base_frame.c_str(), e.what());
        nav_active_ = false;
        return false;
      }
    }
    nav_child_ = child;
    const double dt = have_last_pose_ ? result.timestamp_s - last_pose_time_s_ : 0.0;
    pose_pub_.publish(toPoseStamped(T_world_child, header));
    const OdometrySigma sigma{params_.position_sigma_m, params_.orientation_sigma_rad,
                              params_.lost_sigma_factor, config_.pnp.min_inliers * 4};
    odom_pub_.publish(toOdometry(result, T_world_child, last_child_pose_, dt, header, child, sigma));
    // One transform per stamp: between images the IMU-rate output may already have sent this one.
    if (params_.publish_tf && header.stamp > last_tf_stamp_) {
      tf_broadcaster_.sendTransform(toTransformStamped(T_world_child, header, child));
      last_tf_stamp_ = header.stamp;
    }
    publishNavAtImage(result, T_world_cam, header);
    path_poses_.push_back(toPoseStamped(T_world_child, header));
    if (params_.max_path_length > 0 && int(path_poses_.size()) > params_.max_path_length)
      path_poses_.pop_front();
    publishPath(header, false);
    if (map_pub_.getNumSubscribers() > 0) {
      pipeline_->mapPoints(&map_points_);
      map_pub_.publish(toPointCloud(map_points_, header));
    }
    last_pose_ = T_world_cam;
    last_child_pose_ = T_world_child;
    last_pose_time_s_ = result.timestamp_s;
    have_last_pose_ = true;
    return true;
  }

  /// vo/path: the kept poses, at most every ~path_publish_period_s (wall clock) unless `now`, and only while
  /// subscribed (the whole path is a large message: 10000 poses are about 1 MB).
  void publishPath(const std_msgs::Header& header, bool now) {
    if (path_pub_.getNumSubscribers() == 0) return;
    const ros::WallTime wall = ros::WallTime::now();
    if (!now && (wall - last_path_publish_).toSec() < params_.path_publish_period_s) return;
    last_path_publish_ = wall;
    nav_msgs::PathPtr path(new nav_msgs::Path);
    path->header = header;
    path->poses.assign(path_poses_.begin(), path_poses_.end());
    path_pub_.publish(path);
  }

  /// vo/map_events of a processed frame, as a shared pointer (no copy inside a manager), with the gray image
  /// given to the pipeline when a keyframe was added. A conversion failure is logged, never thrown.
  void publishMapEvents(const FrameResult& result, const std_msgs::Header& header,
                        const std_msgs::Header& image_header, const cv::Mat& gray) {
    try {
      map_events_pub_.publish(boost::make_shared<VoMapEvents>(
          toMsg(result.map_events, result.metric_scale, header, epoch_, &gray, image_header)));
    } catch (const std::exception& e) {
      NODELET_ERROR_STREAM_THROTTLE(5, "vo/map_events not published: " << e.what());
    }
  }

  /// nav/odometry of a processed frame (metric modes only), and whether the IMU-rate output may follow it.
  void publishNavAtImage(const FrameResult& r, const Pose& T_world_cam, const std_msgs::Header& header) {
    const OdometrySigma sigma{params_.position_sigma_m, params_.orientation_sigma_rad,
                              params_.lost_sigma_factor, config_.pnp.min_inliers * 4};
    nav_covariance_ = navCovariance(r, sigma, params_.velocity_sigma_mps);
    // Between images only from a state the pipeline vouches for: a pose estimate, IMU factors holding the
    // map, or (no map yet) the IMU alone from the last inertial state; never from the held pose of a chain
    // without one. Dead reckoning is metric but not confident: navCovariance() inflates it.
    const bool metric = r.metric_scale || r.inertial_only;
    nav_active_ = metric && r.has_velocity && (r.hasPoseEstimate() || r.inertial || r.inertial_only);
    if (!metric) {
      have_nav_prev_ = false;
      return;
    }
    NavSolution s;
    s.T_world_cam = T_world_cam;
    s.covariance = nav_covariance_;
    if (r.has_velocity) {
      T_cam_body_ = pipeline_->T_cam_imu();
      s.v_world_mps = r.v_world_mps;
      s.w_body_radps =
          have_gyro_ ? Eigen::Vector3d(last_gyro_radps_ - r.imu_bias.gyro_radps) : Eigen::Vector3d::Zero();
      s.w_covariance = gyroCovariance();
    } else if (r.filtered_motion.valid) {  // vision + altimeter: the motion filter's rates
      T_cam_body_ = Pose::Identity();
      const Eigen::Matrix3d R_cam_world = T_world_cam.rotation().transpose();
      s.v_world_mps = r.filtered_motion.v_world;
      s.w_body_radps = R_cam_world * r.filtered_motion.omega_world;
      s.covariance.bottomRightCorner<3, 3>() = r.filtered_motion.v_covariance;
      s.w_covariance = R_cam_world * r.filtered_motion.omega_covariance * R_cam_world.transpose();
    } else {  // vision + altimeter without the filter: the camera's motion since the previous metric frame
      T_cam_body_ = Pose::Identity();
      const double dt = r.timestamp_s - nav_prev_time_s_;
      Eigen::Vector3d v, w;
      if (have_nav_prev_ && differentiatePoses(nav_prev_pose_, T_world_cam, dt, &v, &w)) {
        s.v_world_mps = v;
        s.w_body_radps = w;
        s.covariance.bottomRightCorner<3, 3>() =
            2.0 * s.covariance.topLeftCorner<3, 3>() / (dt * dt);  // two position errors over dt
        s.w_covariance = 2.0 * s.covariance.block<3, 3>(3, 3) / (dt * dt);
      } else {
        s.covariance.bottomRightCorner<3, 3>() = kUnknownVariance * Eigen::Matrix3d::Identity();
        s.w_covariance = kUnknownVariance * Eigen::Matrix3d::Identity();
      }
    }
    publishNav(s, header.stamp, false);
    nav_prev_pose_ = T_world_cam;
    nav_prev_time_s_ = r.timestamp_s;
    have_nav_prev_ = true;
  }

  /// Between images: nav/odometry and tf from the last frame's inertial state moved on to the IMU sample's
  /// time (Pipeline::navStateAt), with the last frame's covariance.
  void publishNavAtImu(const ros::Time& imu_stamp) {
    const ros::Time stamp = imu_stamp - ros::Duration(config_.imu.time_offset_s);
    if (stamp <= last_nav_stamp_) return;
    std::optional<NavState> state;
    try {
      state = pipeline_->navStateAt(timeOf(stamp));
    } catch (const std::exception& e) {
      NODELET_WARN_STREAM_THROTTLE(5, "Pipeline::navStateAt failed: " << e.what());
      return;
    }
    if (!state || !isFinite(*state)) return;
    NavSolution s;
    s.T_world_cam = state->T_world_body * pipeline_->T_cam_imu().inverse();
    s.v_world_mps = state->v_world_mps;
    s.w_body_radps = last_gyro_radps_ - state->gyro_bias_radps;
    s.covariance = nav_covariance_;
    s.w_covariance = gyroCovariance();
    publishNav(s, stamp, true);
  }

  void publishNav(const NavSolution& s, const ros::Time& stamp, bool send_tf) {
    const std_msgs::Header header = makeHeader(stamp, params_.world_frame);
    nav_pub_.publish(toNavOdometry(s, T_cam_body_, T_cam_child_, header, nav_child_));
    reporter_->tickNavigation();
    if (stamp > last_nav_stamp_) last_nav_stamp_ = stamp;
    if (send_tf && params_.publish_tf && stamp > last_tf_stamp_) {
      tf_broadcaster_.sendTransform(toTransformStamped(s.T_world_cam * T_cam_child_, header, nav_child_));
      last_tf_stamp_ = stamp;
    }
  }

  /// Covariance of one gyro sample: the message's when it gives one, else the configured noise density at
  /// the measured sample rate.
  Eigen::Matrix3d gyroCovariance() const {
    if (have_gyro_covariance_) return gyro_covariance_;
    const double rate_hz = imu_period_s_ > 0.0 ? 1.0 / imu_period_s_ : 200.0;
    const double sigma = config_.imu.gyro_noise_density_radps_per_sqrt_hz;
    return sigma * sigma * rate_hz * Eigen::Matrix3d::Identity();
  }

  std::string childFrame(const std::string& image_frame) {
    child_camera_frame_ = !params_.camera_frame.empty() ? params_.camera_frame
                          : !image_frame.empty()        ? image_frame
                                                        : std::string(kFallbackCameraFrame);
    return params_.base_frame.empty() ? child_camera_frame_ : params_.base_frame;
  }

  /// The stamp of an image against the last accepted one (last_stamp_ set). A jump (more than
  /// stampJumpLimit() ahead, or backwards) is refused once as suspect: one bad stamp must not poison
  /// last_stamp_ (issue 12: one image stamped 5 s ahead made every later frame "backwards"). The next image
  /// decides: on the old timeline, the suspect was an outlier; just after the suspect, the stream really
  /// jumped: forward, tracking restarts from the current pose (*restart_tracking, no extrapolation over the
  /// gap); backward (e.g. a restarted bag), the trajectory restarts as after vo/reset. Empty = accepted,
  /// *note says what happened; else why the image is refused.
  std::string checkStamp(const ros::Time& stamp, std::string* note, bool* restart_tracking) {
    const double limit_s = stampJumpLimit();
    const double since_last_s = secondsBetween(stamp, *last_stamp_);
    if (since_last_s > 0.0 && since_last_s <= limit_s) {  // the timeline goes on
      if (suspect_stamp_) {
        const double off_s = secondsBetween(*suspect_stamp_, *last_stamp_);
        *note = "the image stamped " + std::to_string(std::abs(off_s)) + " s " +
                (off_s > 0.0 ? "ahead" : "back") + " was an outlier: rejected, the stream goes on";
        suspect_stamp_.reset();
      }
      return "";
    }
    if (suspect_stamp_ && stamp > *suspect_stamp_ && secondsBetween(stamp, *suspect_stamp_) <= limit_s) {
      const double jump_s = secondsBetween(*suspect_stamp_, *last_stamp_);
      suspect_stamp_.reset();
      NODELET_WARN_STREAM("image stamps jumped " << (jump_s > 0.0 ? "forward" : "back") << " by "
                                                 << std::abs(jump_s) << " s, confirmed by the next image");
      if (jump_s > 0.0) {
        *note = "image stamps jumped forward by " + std::to_string(jump_s) +
                " s and the next image confirmed it: tracking restarts from the current pose";
        *restart_tracking = true;
        return "";
      }
      std_srvs::Trigger::Request req;
      std_srvs::Trigger::Response res;
      resetBody(req, res);
      // Samples buffered so far are on the old timeline, in the old epoch's seconds: none belongs to the
      // restarted stream.
      imu_buffer_.clear();
      altimeter_buffer_.clear();
      have_epoch_ = false;   // the pipeline's clock starts again at this stream
      ++counts_.num_images;  // this image, counted before the reset
      *note = "image stamps jumped back by " + std::to_string(-jump_s) +
              " s and the next image confirmed it (a restarted stream?): the trajectory restarts as after "
              "vo/reset";
      return "";
    }
    if (stamp == *last_stamp_) return "duplicate image stamp " + std::to_string(stamp.toSec());
    suspect_stamp_ = stamp;
    if (since_last_s < 0.0)
      return "image stamp went backwards by " + std::to_string(-since_last_s) +
             " s: refused as suspect (the next image decides: on the old timeline it was an outlier, just "
             "after this one the trajectory restarts)";
    return "image stamp jumped forward by " + std::to_string(since_last_s) + " s (more than " +
           std::to_string(limit_s) +
           " s): refused as suspect (the next image decides: on the old timeline it was an outlier, just "
           "after "
           "this one the stream really jumped)";
  }
  /// Largest forward step between two images that is not a jump: 1 s, or ~max_frame_gap_factor periods of
  /// a slower camera.
  double stampJumpLimit() const { return std::max(1.0, params_.max_frame_gap_factor * period_s_); }

  /// A note when the gap to the previous image is much longer than the usual period (dropped frames).
  std::string frameGapNote(const ros::Time& stamp) {
    std::string note;
    if (last_stamp_) {
      const double dt = secondsBetween(stamp, *last_stamp_);
      if (period_s_ > 0.0 && dt > params_.max_frame_gap_factor * period_s_)
        note = ros_io::frameGapNote(dt, period_s_);
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
    status.num_imu_used = counts_.num_imu_used;
    status.num_imu_rejected = counts_.num_imu_rejected;
    status.num_altimeter_msgs = counts_.num_altimeter_msgs;
    status.num_altimeter_used = counts_.num_altimeter_used;
    status.num_altimeter_no_range = counts_.num_altimeter_no_range;
    status.num_altimeter_rejected = counts_.num_altimeter_rejected;
    status.mode = mode_;
    status.initial_state_applied = initial_state_applied_;
    if (status.scale_source.empty()) status.scale_source = toString(ScaleSource::kNone);
    // Rejected samples since the last status: the first reason of each stream.
    auto append = [&status](const std::string& text) {
      status.message += (status.message.empty() ? "" : "; ") + text;
    };
    if (!imu_problem_.empty())
      append("IMU sample rejected: " + imu_problem_ + " (" + std::to_string(counts_.num_imu_rejected) +
             " so far)");
    if (!altimeter_problem_.empty())
      append("altimeter reading rejected: " + altimeter_problem_ + " (" +
             std::to_string(counts_.num_altimeter_rejected) + " so far)");
    if (!initial_state_problem_.empty()) append(initial_state_problem_);
    {
      std::lock_guard<std::mutex> lock(pending_mutex_);
      if (!reconfigure_problem_.empty()) append(reconfigure_problem_);
      reconfigure_problem_.clear();
      if (!callback_problem_.empty()) append(callback_problem_);
      callback_problem_.clear();
    }
    imu_problem_.clear();
    altimeter_problem_.clear();
    initial_state_problem_.clear();
    status.header.frame_id = params_.world_frame;
    reporter_->update(status, published_odometry);
    status_pub_.publish(status);
  }

  std::unique_ptr<Pipeline> makePipeline(const VoConfig& config, const PinholeCamera& camera) {
    // The homography's plane prior comes from the configuration (~motion/plane_normal_prior), like every
    // other pipeline setting: one default, in the core struct.
    applyOpenCvThreads(config.cpu_budget);
    return std::make_unique<Pipeline>(config, camera);
  }

  /// The knobs of a configuration.
  static VoReconfigureConfig knobsOf(const VoConfig& config) {
    VoReconfigureConfig knobs;
    knobs.num_features = config.detector.num_features;
    knobs.motion_model = toString(config.motion.model);
    knobs.bundle_adjustment_enabled = config.bundle_adjustment.enabled;
    return knobs;
  }

  /// Between two frames: a changed configuration goes into the running pipeline in place
  /// (Pipeline::reconfigure keeps tracks, map, trajectory, scale and inertial state), or becomes the
  /// configuration of the next pipeline when there is none yet. A refused change is logged, reported in
  /// vo/status and the knobs are set back; the pipeline runs on unchanged. *note gets what was changed.
  void applyPendingConfig(std::string* note) {
    std::optional<VoConfig> pending;
    {
      std::lock_guard<std::mutex> lock(pending_mutex_);
      pending.swap(pending_config_);
    }
    if (!pending || *pending == config_) return;
    if (pipeline_) {
      try {
        pipeline_->reconfigure(*pending);
      } catch (const std::exception& e) {
        const std::string why = std::string("reconfigure rejected, configuration unchanged: ") + e.what();
        NODELET_ERROR_STREAM(why);
        {
          std::lock_guard<std::mutex> lock(pending_mutex_);
          reconfigure_problem_ = why;
        }
        if (reconfigure_) reconfigure_->updateConfig(knobsOf(config_));
        return;
      }
    }
    config_ = *pending;
    cpu_budget_ = std::make_unique<CpuBudget>(config_);  // the new configuration is its step 0
    const std::string what = "reconfigured: num_features " + std::to_string(config_.detector.num_features) +
                             ", motion model " + toString(config_.motion.model) + ", bundle adjustment " +
                             (config_.bundle_adjustment.enabled ? "on" : "off");
    NODELET_INFO_STREAM(what << (pipeline_ ? " (in place, the trajectory continues)" : ""));
    if (pipeline_) *note += (note->empty() ? "" : "; ") + what;
  }

  /// After a frame: the CPU budget (cpu_budget section, vo/cpu_budget.h) may make the tracking one step
  /// lighter, or undo a step, in the running pipeline (in place, like a reconfigure). config_ stays the
  /// configured one.
  void applyCpuBudget(double process_ms, std::string* note) {
    if (!cpu_budget_ || !cpu_budget_->enabled()) return;
    const std::optional<VoConfig> next = cpu_budget_->observe(process_ms);
    if (!next) return;
    try {
      pipeline_->reconfigure(*next);     // only runtime fields differ (test_cpu_budget)
    } catch (const std::exception& e) {  // not expected; the pipeline is unchanged when it throws
      const std::string why = std::string("cpu budget step refused, budget off: ") + e.what();
      NODELET_ERROR_STREAM(why);
      cpu_budget_.reset();
      *note += (note->empty() ? "" : "; ") + why;
      return;
    }
    const std::string what = "cpu budget: median frame time " + std::to_string(cpu_budget_->lastMedianMs()) +
                             " ms against " + std::to_string(config_.cpu_budget.frame_budget_ms) +
                             " ms, step " + std::to_string(cpu_budget_->step()) + " (" +
                             cpu_budget_->describe(cpu_budget_->step()) + ")";
    NODELET_WARN_STREAM(what);
    *note += (note->empty() ? "" : "; ") + what;
  }

  void reconfigureCb(VoReconfigureConfig& knobs, uint32_t level) {
    contained("reconfigure", nullptr, [&] { reconfigureBody(knobs, level); });
  }
  void reconfigureBody(VoReconfigureConfig& knobs, uint32_t /*level*/) {
    try {
      VoConfig next = config_;
      next.detector.num_features = knobs.num_features;
      next.bundle_adjustment.enabled = knobs.bundle_adjustment_enabled;
      for (MotionModel m :
           {MotionModel::kAuto, MotionModel::kEssential, MotionModel::kFundamental, MotionModel::kHomography})
        if (knobs.motion_model == toString(m)) next.motion.model = m;
      const std::vector<std::string> errors = next.validationErrors();
      if (!errors.empty()) {
        std::lock_guard<std::mutex> lock(pending_mutex_);
        reconfigure_problem_ = "reconfigure rejected, configuration unchanged: " + errors.front();
        NODELET_ERROR_STREAM(reconfigure_problem_);
        knobs = knobsOf(config_);  // the server reports the knobs in effect
        return;
      }
      std::lock_guard<std::mutex> lock(pending_mutex_);
      pending_config_ = next;
    } catch (const std::exception& e) {
      NODELET_ERROR_STREAM("reconfigure: " << e.what());
    }
  }

  bool resetCb(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res) {
    res.success = false;
    contained("vo/reset", nullptr, [&] { resetBody(req, res); });
    if (!res.success && res.message.empty()) res.message = "vo/reset failed (see vo/status)";
    return true;
  }
  void resetBody(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    // A fresh pipeline at the next image: no handed-over state survives a reset (a new one may be sent).
    pipeline_.reset();
    cpu_budget_.reset();
    started_ = false;
    initial_state_applied_ = false;
    nav_active_ = have_nav_prev_ = false;
    last_nav_stamp_ = last_tf_stamp_ = ros::Time();
    imu_buffer_.restart();
    altimeter_buffer_.restart();
    have_gyro_ = false;
    have_last_pose_ = false;
    last_pose_ = last_child_pose_ = Pose::Identity();
    last_stamp_.reset();
    suspect_stamp_.reset();
    period_s_ = 0.0;
    path_poses_.clear();
    counts_ = VoStatus();
    res.success = true;
    res.message =
        "visual odometry reset: the next image starts a new trajectory at the origin (or at a state handed "
        "over on nav/initial_state since)";
    NODELET_INFO_STREAM(res.message);
  }

  /// Once a second: diagnostics, and a BAD_INPUT status while no synchronised image + camera_info arrives.
  void watchdogCb(const ros::WallTimerEvent& event) {
    contained("watchdog", nullptr, [&] { watchdogBody(event); });
  }
  void watchdogBody(const ros::WallTimerEvent&) {
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

  void infoOnlyCb(const sensor_msgs::CameraInfoConstPtr&) noexcept { ++info_count_; }

  /// Buffered until the image it precedes; once the pipeline has an inertial state it vouches for, given at
  /// once and followed by the IMU-rate nav/odometry.
  void imuCb(const sensor_msgs::ImuConstPtr& msg) {
    contained("IMU callback", nullptr, [&] { imuBody(msg); });
  }
  void imuBody(const sensor_msgs::ImuConstPtr& msg) {
    ++counts_.num_imu_msgs;
    if (!config_.imu.enabled || !config_problem_.empty()) return;
    try {
      ImuSample sample;
      std::string why;
      if (!fromImu(*msg, epochFor(msg->header.stamp), &sample, &why)) return rejectImu(why);
      const std::optional<double> last_given = imu_buffer_.lastGiven();
      switch (imu_buffer_.insert(sample)) {
        case SampleBuffer<ImuSample>::Insert::kDuplicate:
          return rejectImu("duplicate stamp " + std::to_string(msg->header.stamp.toSec()));
        case SampleBuffer<ImuSample>::Insert::kTooOld:
          return rejectImu("out of order: " + std::to_string(*last_given - sample.timestamp_s) +
                           " s older than a sample already given to the pipeline");
        case SampleBuffer<ImuSample>::Insert::kSuspect:
          return rejectImu("stamp jumped " + std::to_string(sample.timestamp_s - newestImu(last_given)) +
                           " s ahead of the stream: refused as suspect (the next sample decides)");
        case SampleBuffer<ImuSample>::Insert::kBuffered:
          break;
      }
      if (have_last_imu_time_ && sample.timestamp_s > last_imu_time_s_) {
        const double dt = sample.timestamp_s - last_imu_time_s_;
        imu_period_s_ = imu_period_s_ > 0.0 ? 0.95 * imu_period_s_ + 0.05 * dt : dt;
      }
      last_imu_time_s_ = std::max(last_imu_time_s_, sample.timestamp_s);
      have_last_imu_time_ = true;
      const auto& c = msg->angular_velocity_covariance;
      // Issue 12 (fuzz test): an infinite or huge covariance (inf, 1.8e308) made nav/odometry's twist
      // covariance infinite. Only a finite one below kUnknownVariance is used.
      have_gyro_covariance_ =
          c[0] > 0.0 && c[4] > 0.0 && c[8] > 0.0 &&
          std::all_of(c.begin(), c.end(), [](double v) { return std::abs(v) < kUnknownVariance; });
      if (have_gyro_covariance_) gyro_covariance_ = Eigen::Map<const Eigen::Matrix3d>(c.data()).transpose();
      if (pipeline_ && started_ && nav_active_) {
        imu_buffer_.giveAll([this](const ImuSample& s) { giveImu(s); });
        publishNavAtImu(msg->header.stamp);
      }
    } catch (const std::exception& e) {
      rejectImu(std::string("unexpected error: ") + e.what());
    }
  }

  /// The newest IMU stamp known before a suspect one (for its message).
  double newestImu(const std::optional<double>& last_given) const {
    return std::max(last_given.value_or(-1e300), last_imu_time_s_);
  }

  /// Buffered until the image it precedes (the pipeline reads the altimeter causally per image).
  void altimeterCb(const sensor_msgs::RangeConstPtr& msg) {
    contained("altimeter callback", nullptr, [&] { altimeterBody(msg); });
  }
  void altimeterBody(const sensor_msgs::RangeConstPtr& msg) {
    ++counts_.num_altimeter_msgs;
    if (!config_.altimeter.enabled || !config_problem_.empty()) return;
    try {
      AltimeterSample sample;
      std::string why;
      if (fromRange(*msg, epochFor(msg->header.stamp), &sample, &why) == RangeReading::kInvalid)
        return rejectAltimeter(why);
      const std::optional<double> last_given = altimeter_buffer_.lastGiven();
      switch (altimeter_buffer_.insert(sample)) {
        case SampleBuffer<AltimeterSample>::Insert::kDuplicate:
          return rejectAltimeter("duplicate stamp " + std::to_string(msg->header.stamp.toSec()));
        case SampleBuffer<AltimeterSample>::Insert::kTooOld:
          return rejectAltimeter("out of order: " + std::to_string(*last_given - sample.timestamp_s) +
                                 " s older than a reading already given to the pipeline");
        case SampleBuffer<AltimeterSample>::Insert::kSuspect:
          return rejectAltimeter("stamp jumped more than " + std::to_string(altimeter_buffer_.maxJumpS()) +
                                 " s ahead of the stream: refused as suspect (the next reading decides)");
        case SampleBuffer<AltimeterSample>::Insert::kBuffered:
          break;
      }
    } catch (const std::exception& e) {
      rejectAltimeter(std::string("unexpected error: ") + e.what());
    }
  }

  /// The guidance handover: kept until the first image of the next trajectory (now, or after vo/reset).
  void initialStateCb(const nav_msgs::OdometryConstPtr& msg) {
    contained("initial state callback", nullptr, [&] { initialStateBody(msg); });
  }
  void initialStateBody(const nav_msgs::OdometryConstPtr& msg) {
    try {
      std::string why;
      InitialState checked;
      if (!msg->header.frame_id.empty() && msg->header.frame_id != params_.world_frame)
        why = "initial state in frame '" + msg->header.frame_id + "', but ~world_frame is '" +
              params_.world_frame + "': ignored";
      else
        fromInitialStateMsg(*msg, Pose::Identity(), &checked, &why);
      if (!why.empty()) {
        NODELET_ERROR_STREAM(why);
        initial_state_problem_ = why;
        return;
      }
      timeOf(msg->header.stamp);
      pending_state_ = *msg;
      if (started_)
        NODELET_WARN_STREAM("initial state received while a trajectory runs: it applies after vo/reset");
      else
        NODELET_INFO_STREAM("initial state received, stamp " << msg->header.stamp);
    } catch (const std::exception& e) {
      NODELET_ERROR_STREAM("initial state: " << e.what());
    }
  }

  NodeletParams params_;
  VoConfig config_;
  std::string config_problem_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<CpuBudget> cpu_budget_;  ///< the degradation steps of config_ (off unless configured)
  std::unique_ptr<StatusReporter> reporter_;

  image_transport::CameraSubscriber camera_sub_;
  image_transport::Publisher tracking_pub_;
  ros::Subscriber info_sub_, imu_sub_, altimeter_sub_, initial_state_sub_;
  ros::Publisher pose_pub_, odom_pub_, nav_pub_, path_pub_, map_pub_, status_pub_;
  ros::Publisher map_events_pub_;
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
  /// An image refused for a stamp jump (checkStamp()): the next image decides whether it was an outlier.
  std::optional<ros::Time> suspect_stamp_;
  double period_s_ = 0.0;  ///< smoothed image period
  Clock::time_point last_frame_wall_ = Clock::now();
  int info_count_ = 0;
  VoStatus counts_;  ///< only the counters are used
  std::string child_camera_frame_;
  Pose last_pose_ = Pose::Identity(), last_child_pose_ = Pose::Identity();
  double last_pose_time_s_ = 0.0;
  bool have_last_pose_ = false;
  std::deque<geometry_msgs::PoseStamped> path_poses_;  ///< vo/path (~max_path_length)
  ros::WallTime last_path_publish_;
  std::vector<MapPointView> map_points_;

  // Fusion inputs (buffers and conversions only: every estimate is the pipeline's).
  static constexpr double kUnknownVariance = 1e6;  ///< a covariance entry nothing constrains
  std::string mode_ = VoStatus::MODE_VISION;
  ros::Time epoch_;  ///< the pipeline's clock: seconds since this stamp
  bool have_epoch_ = false;
  bool started_ = false;  ///< the pipeline has processed an image of this trajectory
  std::optional<nav_msgs::Odometry> pending_state_;  ///< nav/initial_state not applied yet
  bool initial_state_applied_ = false;
  SampleBuffer<ImuSample> imu_buffer_;
  SampleBuffer<AltimeterSample> altimeter_buffer_;
  std::string imu_problem_, altimeter_problem_, initial_state_problem_;  ///< since the last status
  std::string reconfigure_problem_;  ///< a refused reconfiguration, until the next status (pending_mutex_)
  std::string callback_problem_;     ///< an exception contained in a callback, until the next status (same)
  Eigen::Vector3d last_gyro_radps_ = Eigen::Vector3d::Zero();  ///< latest gyro sample given
  bool have_gyro_ = false;
  Eigen::Matrix3d gyro_covariance_ = Eigen::Matrix3d::Identity();
  bool have_gyro_covariance_ = false;
  double imu_period_s_ = 0.0, last_imu_time_s_ = 0.0;
  bool have_last_imu_time_ = false;
  // Navigation output.
  bool nav_active_ = false;  ///< the last frame allows the IMU-rate output
  Eigen::Matrix<double, 9, 9> nav_covariance_ = Eigen::Matrix<double, 9, 9>::Identity();
  Pose T_cam_body_ = Pose::Identity();   ///< IMU in the camera (identity without the IMU)
  Pose T_cam_child_ = Pose::Identity();  ///< output child frame in the camera (~base_frame)
  std::string nav_child_;
  Pose nav_prev_pose_ = Pose::Identity();
  double nav_prev_time_s_ = 0.0;
  bool have_nav_prev_ = false;
  ros::Time last_nav_stamp_, last_tf_stamp_;
};

}  // namespace planetary_vo::ros_io

PLUGINLIB_EXPORT_CLASS(planetary_vo::ros_io::VisualOdometryNodelet, nodelet::Nodelet)
