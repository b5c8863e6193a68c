/// @file status_reporter.cpp
/// VoStatus -> diagnostics (see status_reporter.h).

#include "planetary_vo/ros_io/status_reporter.h"

#include <cstdio>

#include <diagnostic_msgs/DiagnosticStatus.h>

namespace planetary_vo::ros_io {

StatusReporter::StatusReporter(ros::NodeHandle& nh, ros::NodeHandle& private_nh,
                               const std::string& hardware_id, double min_rate_hz, double max_rate_hz,
                               int lost_error_frames)
    : updater_(nh, private_nh),
      min_rate_hz_(min_rate_hz),
      max_rate_hz_(max_rate_hz),
      lost_error_frames_(lost_error_frames) {
  updater_.setHardwareID(hardware_id);
  updater_.add("visual odometry", this, &StatusReporter::produce);
  odometry_rate_ = std::make_unique<diagnostic_updater::HeaderlessTopicDiagnostic>(
      "vo/odometry", updater_,
      diagnostic_updater::FrequencyStatusParam(&min_rate_hz_, &max_rate_hz_, 0.1, 10));
}

void StatusReporter::update(const VoStatus& status, bool published_odometry) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_ = status;
    have_status_ = true;
    if (status.state == VoStatus::STATE_LOST)
      ++consecutive_lost_;
    else if (status.processed)
      consecutive_lost_ = 0;
    if (status.processed) {
      input_problem_.clear();
      overhead_sum_ms_ += status.ros_overhead_ms;
      pipeline_sum_ms_ += status.total_ms;
      ++timed_frames_;
    }
  }
  if (published_odometry) odometry_rate_->tick();
}

void StatusReporter::enableNavigationRate() {
  if (navigation_rate_) return;
  navigation_rate_ = std::make_unique<diagnostic_updater::HeaderlessTopicDiagnostic>(
      "nav/odometry", updater_,
      diagnostic_updater::FrequencyStatusParam(&min_rate_hz_, &max_rate_hz_, 0.1, 10));
}

void StatusReporter::tickNavigation() {
  if (navigation_rate_) navigation_rate_->tick();
}

void StatusReporter::setInputProblem(const std::string& problem) {
  std::lock_guard<std::mutex> lock(mutex_);
  input_problem_ = problem;
}

void StatusReporter::tick() { updater_.update(); }

void StatusReporter::produce(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  using diagnostic_msgs::DiagnosticStatus;
  std::lock_guard<std::mutex> lock(mutex_);
  if (!input_problem_.empty()) {
    stat.summary(DiagnosticStatus::ERROR, "no usable input: " + input_problem_);
  } else if (!have_status_) {
    stat.summary(DiagnosticStatus::WARN, "waiting for camera/image_raw + camera/camera_info");
  } else if (last_.state == VoStatus::STATE_INITIALISING && !last_.processed) {
    stat.summary(DiagnosticStatus::WARN, "not started: " + last_.message);
  } else if (last_.state == VoStatus::STATE_BAD_INPUT) {
    stat.summary(DiagnosticStatus::WARN, "bad input: " + last_.message);
  } else if (last_.state == VoStatus::STATE_LOST) {
    stat.summary(consecutive_lost_ >= lost_error_frames_ ? DiagnosticStatus::ERROR : DiagnosticStatus::WARN,
                 "lost for " + std::to_string(consecutive_lost_) + " frames: " + last_.message);
  } else if (last_.state == VoStatus::STATE_TRACKING) {
    stat.summary(DiagnosticStatus::OK, "tracking");
  } else {
    stat.summary(DiagnosticStatus::WARN,
                 last_.state_name + (last_.message.empty() ? "" : ": " + last_.message));
  }
  if (!have_status_) return;
  stat.add("state", last_.state_name);
  stat.add("tracked features", last_.num_features_tracked);
  stat.add("inliers", last_.num_inliers);
  stat.add("map points", last_.num_map_points);
  stat.add("keyframes", last_.num_keyframes);
  stat.add("scale confidence", last_.scale_confidence);
  stat.add("pipeline time last frame [ms]", last_.total_ms);
  stat.add("images received", last_.num_images);
  stat.add("images rejected (bad input)", last_.num_bad_images);
  stat.add("mode", last_.mode);
  stat.add("metric", last_.metric ? "yes" : "no");
  stat.add("scale source", last_.scale_source);
  stat.add("inertial (IMU factors hold the map)", last_.inertial ? "yes" : "no");
  stat.add("initial state applied", last_.initial_state_applied ? "yes" : "no");
  if (last_.has_velocity) {
    auto vec = [](const boost::array<double, 3>& v) {
      char text[96];
      std::snprintf(text, sizeof(text), "%.6g %.6g %.6g", v[0], v[1], v[2]);
      return std::string(text);
    };
    stat.add("velocity (world) [m/s]", vec(last_.velocity_world_mps));
    stat.add("gyro bias [rad/s]", vec(last_.gyro_bias_radps));
    stat.add("accelerometer bias [m/s^2]", vec(last_.accel_bias_mps2));
  }
  stat.add("imu messages", last_.num_imu_msgs);
  stat.add("imu samples used", last_.num_imu_used);
  stat.add("imu samples rejected", last_.num_imu_rejected);
  stat.add("altimeter messages", last_.num_altimeter_msgs);
  stat.add("altimeter ranges used", last_.num_altimeter_used);
  stat.add("altimeter readings without a range", last_.num_altimeter_no_range);
  stat.add("altimeter readings rejected", last_.num_altimeter_rejected);
  if (timed_frames_ > 0) {
    stat.add("mean pipeline time [ms]", pipeline_sum_ms_ / double(timed_frames_));
    stat.add("mean ROS-layer overhead [ms]", overhead_sum_ms_ / double(timed_frames_));
  }
}

}  // namespace planetary_vo::ros_io
