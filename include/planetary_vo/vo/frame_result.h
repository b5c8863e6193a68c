#pragma once
/// @file frame_result.h
/// What the pipeline says about every frame: one plain value type that the offline runner (vo_run), the ROS
/// nodelet (pose, odometry, status, diagnostics) and the tests all read, so live and offline runs share one
/// path.

#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "planetary_vo/fusion/nav_state.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/map_events.h"

namespace planetary_vo {

/// Where the chain stands. Ordered from best to worst only loosely: kRecovered is a good pose on a
/// re-initialised map (scale bridged), kLost a predicted (coasting) pose.
enum class TrackingState : uint8_t {
  kInitialising =
      0,           ///< no map (or no reference frame) yet; T_world_cam is the reference pose, not an estimate
  kTracking = 1,   ///< pose estimated from the map (map mode) or from an accepted two-view model (unit steps)
  kLost = 2,       ///< this frame gave no pose; T_world_cam coasts from the last good pose (map mode:
                   ///< the IMU's state, else constant velocity; frame-to-frame mode: held)
  kRecovered = 3,  ///< first pose after a re-initialisation; the new map was attached to the old trajectory
};
/// "initialising", "tracking", "lost", "recovered".
const char* toString(TrackingState state);

/// Which estimator produced this frame's pose.
enum class MotionEstimate : uint8_t {
  kNone = 0,         ///< no pose estimated this frame
  kFundamental = 1,  ///< two-view: eight-point F, then E = K^T F K
  kEssential = 2,    ///< two-view: five-point E
  kHomography = 3,   ///< two-view: plane-induced homography
  kPnp = 4,          ///< frame-to-map: EPnP in RANSAC + refinement
};
/// "none", "fundamental", "essential", "homography", "pnp".
const char* toString(MotionEstimate motion);

/// What made the map's positions metres (FrameResult::scale_source).
enum class ScaleSource : uint8_t {
  kNone = 0,       ///< not metric: vision only, the unit is the first two-view baseline
  kAltimeter = 1,  ///< the altimeter's range against the range the map predicts
  kImu = 2,        ///< the IMU baseline of the first map, propagated from the handed-over state
};
/// "none", "altimeter", "imu".
const char* toString(ScaleSource source);

/// Wall-clock time spent per stage on this frame, in milliseconds.
struct StageTimesMs {
  double tracking_ms = 0.0;  ///< image pyramid, KLT, anchor refinement, replenishment detection, undistortion
  double pyramid_ms = 0.0;   ///< part of tracking_ms: building the new image's LK pyramid
  double klt_ms = 0.0;       ///< part of tracking_ms: forward and backward LK
  double refine_ms = 0.0;    ///< part of tracking_ms: anchor refinement of the tracks
  double detect_ms = 0.0;    ///< part of tracking_ms: replenishment (or restart) detection
  double motion_ms =
      0.0;  ///< two-view estimation (initialisation, unit steps) or PnP + motion-only refinement
  double mapping_ms = 0.0;  ///< keyframe insertion, triangulation, culling, window management
  /// The map-only features of a keyframe (map.keyframe_features; keyframe_tracker.h). With a synchronous
  /// optimiser, this keyframe's, part of mapping_ms. With the optimiser in its own thread they are tracked in
  /// the background: the time of the last keyframe's, reported by the next keyframe, which joins them to the
  /// map (its wait for them, if they were not done yet, is part of its mapping_ms).
  double keyframe_tracking_ms = 0.0;
  double ba_ms = 0.0;  ///< synchronous bundle adjustment, or applying an asynchronous result
  /// The bundle adjustment's own CPU time (BaSummary::solve_cpu_ms) of the adjustment this frame ran or
  /// applied: in the optimiser thread when asynchronous (not part of this frame's other times, except as far
  /// as the frame waited for it); 0 on frames without one. CPU, not wall time: a background solve sharing
  /// the core with the tracking and the image loading takes longer on the clock.
  double optimiser_ms = 0.0;
  double total_ms = 0.0;  ///< the whole process() call
  /// Image in, pose out: from entering process() until this frame's pose is known (input checks, tracking,
  /// applying the background bundle adjustment or waiting for it, motion). Tracking against the map: before
  /// the keyframe decision and mapping, which follow within the same call; otherwise the whole call.
  double pose_ms = 0.0;
};

/// The motion filter's rates at a frame (vo/motion_filter.h; vision only and vision + altimeter): its velocity
/// is the published pose's, not a difference of two poses.
struct FilteredMotion {
  bool valid = false;  ///< the filter runs and published this frame's pose (false: the frame's own pose)
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();  ///< camera centre velocity, map units/s (m/s when metric)
  Eigen::Matrix3d v_covariance = Eigen::Matrix3d::Zero();
  Eigen::Vector3d omega_world = Eigen::Vector3d::Zero();  ///< angular rate, world frame, rad/s
  Eigen::Matrix3d omega_covariance = Eigen::Matrix3d::Zero();
  Eigen::Vector3d a_world = Eigen::Vector3d::Zero();  ///< acceleration (constant_acceleration), units/s^2
  /// A metric map's drift that v_covariance carries besides the filter's own (vo/map_drift.h; both 0 before
  /// the map is metric): the relative 1-sigma of its scale and the 1-sigma per axis of its attitude.
  double map_scale_relative_sigma = 0.0;
  double map_attitude_sigma_rad = 0.0;
};

/// Per-frame output of Pipeline::process().
struct FrameResult {
  int64_t frame_index = -1;  ///< 0-based index of the image given to process()
  double timestamp_s = 0.0;
  /// False when the frame was skipped by keyframe.process_every_n_frames; then nothing else below changed.
  bool processed = false;
  /// Camera optical frame in the VO world frame (the first keyframe's camera at the origin). Never NaN: while
  /// lost it is the last good pose moved on at the last keyframe velocity (map mode) or the last pose held
  /// (unit-step chain, whose steps have no common scale), so it does not jump when the chain recovers.
  Pose T_world_cam = Pose::Identity();
  TrackingState state = TrackingState::kInitialising;
  MotionEstimate motion = MotionEstimate::kNone;
  bool is_keyframe = false;

  int num_new_features = 0;  ///< features detected this frame (replenishment or restart)
  /// The tracks were found by anchor alignment (tracker.method anchor_alignment, or auto on a plane-like
  /// view), not by LK; lk_rescue: auto's anchor alignment found fewer than half and LK tracked them again.
  bool anchor_alignment = false;
  bool lk_rescue = false;
  /// The pose against the map was refined from the motion model's prediction without RANSAC
  /// (pnp.from_prediction; pnp_tracker.h).
  bool pose_from_prediction = false;
  int num_tracked = 0;     ///< tracks carried over from the previous processed frame
  int num_inliers = 0;     ///< inliers of the model or PnP that produced the pose
  int num_map_points = 0;  ///< points in the (windowed) map after this frame
  int num_keyframes = 0;   ///< keyframes in the window after this frame

  /// How far the current scale can be trusted to equal the scale of the first map, in [0, 1]: 1 for a map
  /// that has grown continuously from its initialisation, lowered by each re-initialisation (more when the
  /// bridge had to assume constant speed than when shared points fixed it); 0 without a map (unit-step
  /// chain).
  double scale_confidence = 0.0;
  /// Positions are in metres: the map's scale was fixed by the altimeter (vision + altimeter mode). False in
  /// vision-only mode, whose unit is the first two-view baseline.
  bool metric_scale = false;

  /// Camera + IMU mode: v_world_mps (the IMU body's velocity, world frame, m/s) and imu_bias are the newest
  /// keyframe's estimate moved on to this frame's time by the IMU (has_velocity); inertial says that IMU
  /// factors hold the current map (false while the IMU cannot be used: no handed-over state, no metric map,
  /// or a gap; the message says why).
  ScaleSource scale_source = ScaleSource::kNone;
  bool has_velocity = false;
  Eigen::Vector3d v_world_mps = Eigen::Vector3d::Zero();
  ImuBias imu_bias;
  bool inertial = false;
  /// Camera + IMU, no map yet (initialising: before the first map, or after a map was lost): T_world_cam and
  /// v_world_mps are the last inertial state (the handed-over one at first) moved on by the IMU alone. Metric
  /// and in the world frame, but no vision in it: dead reckoning, not a pose estimate (hasPoseEstimate() is
  /// false).
  bool inertial_only = false;
  /// Camera + IMU mode, and vision + altimeter with the motion filter once the map is metric (has_covariance):
  /// covariance of the navigation error [position (world, m), attitude (rotation vector of the world-frame
  /// error, rad), velocity (world, m/s)], 9x9; see docs/fusion/README.md for how the first is obtained and
  /// what it does not contain, vo/map_drift.h and docs/visual_core.md step 20 for the second (its velocity
  /// block: 1e6 (m/s)^2, unknown, before the filter gives a velocity).
  bool has_covariance = false;
  Eigen::Matrix<double, 9, 9> covariance = Eigen::Matrix<double, 9, 9>::Zero();
  /// Vision only and vision + altimeter, with the motion filter on: its velocity and angular rate.
  FilteredMotion filtered_motion;
  /// What changed in the map during this frame (map_events.h): the feed of the terrain map.
  MapEvents map_events;
  StageTimesMs times;
  /// The input check refused the image (input_check.h, e.g. a frozen frame: the same image as the previous
  /// one): the chain did not see it, state is kLost, T_world_cam the last good pose moved on by the motion
  /// prior (map mode), and message names the cause. The nodelet reports such a frame as BAD_INPUT.
  bool input_rejected = false;
  /// Human-readable detail: why a model was rejected, why tracking failed, what the keyframe policy decided.
  std::string message;

  /// True when T_world_cam is an estimate of this frame (tracking or recovered), not a reference or held
  /// pose.
  bool hasPoseEstimate() const {
    return processed && (state == TrackingState::kTracking || state == TrackingState::kRecovered);
  }
};

/// A map point as the ROS layer publishes it (sensor_msgs/PointCloud2: x y z + observation count).
struct MapPointView {
  uint64_t id = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  int num_observations = 0;  ///< keyframes in the window that observe it
};

}  // namespace planetary_vo
