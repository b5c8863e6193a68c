#pragma once
/// @file status_reporter.h
/// Diagnostics of the VO nodelet through diagnostic_updater (the robot_localization pattern, small):
/// - "<node>: visual odometry": OK while tracking, WARN while initialising / recovered / lost for a few
/// frames
///   / after bad input, ERROR when lost for long or when no usable input arrives; key/values with the counts,
///   per-stage times and the mean ROS-layer overhead per frame.
/// - "<node>: vo/odometry topic status": frequency (and stamp) diagnostic of vo/odometry.
/// - "<node>: nav/odometry topic status": the same for the metric navigation output (fused modes only,
///   enableNavigationRate()); its rate is the IMU's once the inertial state runs.
/// The key/values also give the navigation mode, metric / inertial / scale source, the IMU velocity and bias
/// estimates and the IMU and altimeter counters (used, rejected, without a range).
///
/// Threading: update() and tick() may be called from different threads (callback and timer); a mutex guards
/// the snapshot.

#include <memory>
#include <mutex>
#include <string>

#include <diagnostic_updater/diagnostic_updater.h>
#include <diagnostic_updater/publisher.h>
#include <ros/node_handle.h>

#include "planetary_vo/VoStatus.h"

namespace planetary_vo::ros_io {

class StatusReporter {
 public:
  /// @param lost_error_frames consecutive lost frames from which the level is ERROR
  StatusReporter(ros::NodeHandle& nh, ros::NodeHandle& private_nh, const std::string& hardware_id,
                 double min_rate_hz, double max_rate_hz, int lost_error_frames);

  /// Records the status of a frame (processed or rejected) and ticks the odometry frequency diagnostic when
  /// odometry was published for it.
  void update(const VoStatus& status, bool published_odometry);
  /// Sets a problem that is not tied to a frame (e.g. "no camera_info"), "" to clear it.
  void setInputProblem(const std::string& problem);
  /// Adds the nav/odometry frequency diagnostic (a fused mode publishes nav/odometry).
  void enableNavigationRate();
  /// One nav/odometry message was published.
  void tickNavigation();
  /// Publishes on /diagnostics when the updater's period has passed (call it from a timer).
  void tick();

 private:
  void produce(diagnostic_updater::DiagnosticStatusWrapper& stat);

  diagnostic_updater::Updater updater_;
  double min_rate_hz_, max_rate_hz_;
  std::unique_ptr<diagnostic_updater::HeaderlessTopicDiagnostic> odometry_rate_, navigation_rate_;
  int lost_error_frames_;

  std::mutex mutex_;
  VoStatus last_;
  bool have_status_ = false;
  int consecutive_lost_ = 0;
  std::string input_problem_;
  double overhead_sum_ms_ = 0.0, pipeline_sum_ms_ = 0.0;
  uint64_t timed_frames_ = 0;
};

}  // namespace planetary_vo::ros_io
