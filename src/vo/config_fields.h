#pragma once
/// @file config_fields.h
/// Private to src/vo: the one table of YAML keys, members and valid ranges of VoConfig. Parsing, dumping,
/// range validation and operator== all walk this table, so a key is named, and its range stated, in one place
/// only.
///
/// A visitor V provides:
///   void beginSection(const char* name);
///   template <class T, class L> void operator()(const char* key, T& value, L lo, L hi);  // int / double,
///   [lo, hi] void operator()(const char* key, bool& value); template <class E> void enumeration(const char*
///   key, E& value);                   // enum listed below
/// `C` is the struct or its const version, so the same table serves readers and writers.

#include <array>
#include <cstring>
#include <utility>

#include "planetary_vo/vo/config.h"

namespace planetary_vo::config_detail {

/// YAML spelling of each enumerator; toString() and the parser both use these tables.
template <class E>
struct EnumNames;
template <>
struct EnumNames<MotionModel> {
  static constexpr std::array<std::pair<MotionModel, const char*>, 4> kValues{
      {{MotionModel::kFundamental, "fundamental"},
       {MotionModel::kEssential, "essential"},
       {MotionModel::kHomography, "homography"},
       {MotionModel::kAuto, "auto"}}};
};
template <>
struct EnumNames<PlaneNormalPrior> {
  static constexpr std::array<std::pair<PlaneNormalPrior, const char*>, 3> kValues{
      {{PlaneNormalPrior::kNone, "none"},
       {PlaneNormalPrior::kOpticalAxis, "optical_axis"},
       {PlaneNormalPrior::kImageDown, "image_down"}}};
};
template <>
struct EnumNames<KeyframeMode> {
  static constexpr std::array<std::pair<KeyframeMode, const char*>, 2> kValues{
      {{KeyframeMode::kFixedRate, "fixed_rate"}, {KeyframeMode::kParallax, "parallax"}}};
};
template <>
struct EnumNames<RobustLoss> {
  static constexpr std::array<std::pair<RobustLoss, const char*>, 3> kValues{
      {{RobustLoss::kNone, "none"}, {RobustLoss::kHuber, "huber"}, {RobustLoss::kCauchy, "cauchy"}}};
};
template <>
struct EnumNames<TrajectoryMode> {
  static constexpr std::array<std::pair<TrajectoryMode, const char*>, 2> kValues{
      {{TrajectoryMode::kUnitStepConcatenation, "unit_step_concatenation"}, {TrajectoryMode::kMap, "map"}}};
};
template <>
struct EnumNames<ReplenishStrategy> {
  static constexpr std::array<std::pair<ReplenishStrategy, const char*>, 2> kValues{
      {{ReplenishStrategy::kEmptyCells, "empty_cells"},
       {ReplenishStrategy::kRestartBelowMin, "restart_below_min"}}};
};

template <>
struct EnumNames<TrackingMethod> {
  static constexpr std::array<std::pair<TrackingMethod, const char*>, 3> kValues{
      {{TrackingMethod::kKlt, "klt"},
       {TrackingMethod::kAnchorAlignment, "anchor_alignment"},
       {TrackingMethod::kAuto, "auto"}}};
};

template <class E>
const char* enumName(E value) {
  for (const auto& [v, name] : EnumNames<E>::kValues)
    if (v == value) return name;
  return "?";
}

/// Finds the enumerator spelled `name`; false when there is none.
template <class E>
bool enumFromName(const char* name, E* value) {
  for (const auto& [v, n] : EnumNames<E>::kValues) {
    if (std::strcmp(n, name) == 0) {
      *value = v;
      return true;
    }
  }
  return false;
}

// Ranges are deliberately wide: they catch typos and unit mistakes (a confidence of 99, a negative
// threshold), not tuning choices.

template <class C, class V>
void detectorFields(C& c, V& v) {
  v("num_features", c.num_features, 1, 100000);
  v("scale_factor", c.scale_factor, 1.01, 4.0);
  v("num_levels", c.num_levels, 1, 16);
  v("patch_size_px", c.patch_size_px, 2, 255);
  v("fast_threshold", c.fast_threshold, 1, 254);
  v("fast_threshold_fallback", c.fast_threshold_fallback, 0, 254);
  v("edge_threshold_px", c.edge_threshold_px, 0, 1000);
  v("grid_cols", c.grid_cols, 1, 64);
  v("grid_rows", c.grid_rows, 1, 64);
  v("min_distance_px", c.min_distance_px, 0.0, 1000.0);
  v("redistribute_budget", c.redistribute_budget);
  v("compute_descriptors", c.compute_descriptors);
}

template <class C, class V>
void trackerFields(C& c, V& v) {
  v.enumeration("method", c.method);
  v("window_size_px", c.window_size_px, 3, 255);
  v("pyramid_levels", c.pyramid_levels, 0, 10);
  v("min_eigen_threshold", c.min_eigen_threshold, 0.0, 1.0);
  v("max_iterations", c.max_iterations, 1, 1000);
  v("epsilon_px", c.epsilon_px, 1e-6, 10.0);
  v("fb_max_error_px", c.fb_max_error_px, 0.0, 100.0);
  v("border_px", c.border_px, 0, 1000);
  v("predict_flow", c.predict_flow);
  v.enumeration("replenish_strategy", c.replenish_strategy);
  v("replenish_cell_min_features", c.replenish_cell_min_features, 1, 10000);
  v("min_tracked_features", c.min_tracked_features, 0, 100000);
  v("replenish_min_cells", c.replenish_min_cells, 1, 4096);
  v("anchor_refinement", c.anchor_refinement);
  v("anchor_patch_px", c.anchor_patch_px, 3, 63);
  v("anchor_max_shift_px", c.anchor_max_shift_px, 0.0, 100.0);
  v("anchor_max_residual_ratio", c.anchor_max_residual_ratio, 0.0, 10.0);
  v("anchor_max_age_frames", c.anchor_max_age_frames, 1, 100000);
  v("anchor_warp_min_tracks", c.anchor_warp_min_tracks, 0, 100000);
  v("alignment_max_residual_ratio", c.alignment_max_residual_ratio, 0.0, 10.0);
  v("alignment_previous_fallback", c.alignment_previous_fallback);
}

template <class C, class V>
void motionFields(C& c, V& v) {
  v.enumeration("model", c.model);
  v("ransac_confidence", c.ransac_confidence, 0.5, 0.999999);
  v("ransac_threshold_px", c.ransac_threshold_px, 1e-3, 100.0);
  v("ransac_max_iterations", c.ransac_max_iterations, 1, 1000000);
  v("homography_score_ratio", c.homography_score_ratio, 0.0, 1.0);
  v("min_inliers", c.min_inliers, 5, 100000);
  v("min_parallax_deg", c.min_parallax_deg, 0.0, 90.0);
  v("max_rotation_sigma_deg", c.max_rotation_sigma_deg, 0.0, 180.0);
  v.enumeration("plane_normal_prior", c.plane_normal_prior);
}

template <class C, class V>
void keyframeFields(C& c, V& v) {
  v.enumeration("mode", c.mode);
  v("process_every_n_frames", c.process_every_n_frames, 1, 100000);
  v("min_parallax_deg", c.min_parallax_deg, 0.0, 90.0);
  v("min_track_ratio", c.min_track_ratio, 0.0, 1.0);
  v("max_interval_frames", c.max_interval_frames, 1, 100000);
}

template <class C, class V>
void mapFields(C& c, V& v) {
  v("min_triangulation_parallax_deg", c.min_triangulation_parallax_deg, 0.0, 90.0);
  v("max_reprojection_error_px", c.max_reprojection_error_px, 1e-3, 100.0);
  v("min_observations", c.min_observations, 2, 1000);
  v("cull_min_found_ratio", c.cull_min_found_ratio, 0.0, 1.0);
  v("window_keyframes", c.window_keyframes, 2, 1000);
  v("keyframe_features", c.keyframe_features, 0, 100000);
  v("keyframe_anchor_max_age", c.keyframe_anchor_max_age, 1, 100000);
  v("attitude_drift_deg_per_sqrt_keyframe", c.attitude_drift_deg_per_sqrt_keyframe, 0.0, 10.0);
}

template <class C, class V>
void pnpFields(C& c, V& v) {
  v("ransac_reprojection_error_px", c.ransac_reprojection_error_px, 1e-3, 100.0);
  v("ransac_iterations", c.ransac_iterations, 1, 1000000);
  v("ransac_confidence", c.ransac_confidence, 0.5, 0.999999);
  v("min_inliers", c.min_inliers, 4, 100000);
  v("refine", c.refine);
  v("from_prediction", c.from_prediction);
  v("prediction_min_inlier_ratio", c.prediction_min_inlier_ratio, 0.0, 1.0);
}

template <class C, class V>
void motionFilterFields(C& c, V& v) {
  v("enabled", c.enabled);
  v("accel_sigma_ratio_per_s", c.accel_sigma_ratio_per_s, 1e-6, 1e3);
  v("constant_acceleration", c.constant_acceleration);
  v("jerk_sigma_ratio_per_s2", c.jerk_sigma_ratio_per_s2, 1e-6, 1e3);
  v("initial_accel_sigma_ratio_per_s", c.initial_accel_sigma_ratio_per_s, 1e-6, 1e3);
  v("min_accel_sigma_depth_ratio", c.min_accel_sigma_depth_ratio, 0.0, 1e3);
  v("angular_accel_sigma_dps2", c.angular_accel_sigma_dps2, 1e-6, 1e6);
  v("min_pixel_sigma_px", c.min_pixel_sigma_px, 1e-4, 100.0);
  v("gate_nis", c.gate_nis, 1.0, 1e9);
  v("max_gap_s", c.max_gap_s, 1e-3, 1e3);
  v("move_with_map", c.move_with_map);
}

template <class C, class V>
void bundleAdjustmentFields(C& c, V& v) {
  v("enabled", c.enabled);
  v("window_keyframes", c.window_keyframes, 2, 1000);
  v.enumeration("robust_loss", c.robust_loss);
  v("robust_loss_scale_px", c.robust_loss_scale_px, 1e-3, 100.0);
  v("robust_loss_scale_aligned_px", c.robust_loss_scale_aligned_px, 1e-3, 100.0);
  v("max_iterations", c.max_iterations, 1, 10000);
  v("pose_change_tolerance", c.pose_change_tolerance, 0.0, 0.1);
  v("asynchronous", c.asynchronous);
  v("thread_nice", c.thread_nice, 0, 19);
  v("collect_after_images", c.collect_after_images, 1, 1000);
}

template <class C, class V>
void pipelineFields(C& c, V& v) {
  v.enumeration("trajectory_mode", c.trajectory_mode);
  v("max_consecutive_failed_frames", c.max_consecutive_failed_frames, 1, 100000);
  v("frozen_frame_max_mean_abs_diff", c.frozen_frame_max_mean_abs_diff, 0.0, 255.0);
  v("frozen_frame_max_moved_ratio", c.frozen_frame_max_moved_ratio, 0.0, 1.0);
  v("min_exposure_stddev", c.min_exposure_stddev, 0.0, 128.0);
  v("max_saturated_ratio", c.max_saturated_ratio, 1e-6, 1.0);
  v("exposure_step_ratio", c.exposure_step_ratio, 0.0, 100.0);
}

template <class C, class V>
void altimeterFields(C& c, V& v) {
  v("enabled", c.enabled);
  v("range_noise_floor_m", c.noise.range_noise_floor_m, 0.0, 1000.0);
  v("range_noise_fraction", c.noise.range_noise_fraction, 0.0, 1.0);
  v("min_range_m", c.noise.min_range_m, 0.0, 1e7);
  v("max_range_m", c.noise.max_range_m, 0.0, 1e7);
  v("origin_x_m", c.mounting.origin_body_m.x(), -100.0, 100.0);
  v("origin_y_m", c.mounting.origin_body_m.y(), -100.0, 100.0);
  v("origin_z_m", c.mounting.origin_body_m.z(), -100.0, 100.0);
  v("boresight_x", c.mounting.boresight_body.x(), -1.0, 1.0);
  v("boresight_y", c.mounting.boresight_body.y(), -1.0, 1.0);
  v("boresight_z", c.mounting.boresight_body.z(), -1.0, 1.0);
  v("max_time_offset_s", c.max_time_offset_s, 0.0, 10.0);
}

template <class C, class V>
void imuFields(C& c, V& v) {
  v("enabled", c.enabled);
  v("gyro_noise_density_radps_per_sqrt_hz", c.gyro_noise_density_radps_per_sqrt_hz, 1e-9, 1.0);
  v("accel_noise_density_mps2_per_sqrt_hz", c.accel_noise_density_mps2_per_sqrt_hz, 1e-9, 10.0);
  v("gyro_random_walk_radps2_per_sqrt_hz", c.gyro_random_walk_radps2_per_sqrt_hz, 1e-12, 1.0);
  v("accel_random_walk_mps3_per_sqrt_hz", c.accel_random_walk_mps3_per_sqrt_hz, 1e-12, 10.0);
  v("gyro_turn_on_bias_radps", c.gyro_turn_on_bias_radps, 1e-9, 1.0);
  v("accel_turn_on_bias_mps2", c.accel_turn_on_bias_mps2, 1e-9, 10.0);
  v("carry_bias_covariance", c.carry_bias_covariance);
  v("anchor_velocity_prior", c.anchor_velocity_prior);
  v("gravity_mps2", c.gravity_mps2, 0.0, 100.0);
  v("cam_imu_x_m", c.cam_imu_x_m, -100.0, 100.0);
  v("cam_imu_y_m", c.cam_imu_y_m, -100.0, 100.0);
  v("cam_imu_z_m", c.cam_imu_z_m, -100.0, 100.0);
  v("cam_imu_roll_deg", c.cam_imu_roll_deg, -180.0, 180.0);
  v("cam_imu_pitch_deg", c.cam_imu_pitch_deg, -180.0, 180.0);
  v("cam_imu_yaw_deg", c.cam_imu_yaw_deg, -180.0, 180.0);
  v("time_offset_s", c.time_offset_s, -1.0, 1.0);
  v("max_gap_s", c.max_gap_s, 0.0, 1.0);
  v("initial_position_sigma_m", c.initial_position_sigma_m, 1e-6, 1e6);
  v("initial_attitude_sigma_deg", c.initial_attitude_sigma_deg, 1e-6, 180.0);
  v("initial_velocity_sigma_mps", c.initial_velocity_sigma_mps, 1e-6, 1e4);
}

template <class C, class V>
void cpuBudgetFields(C& c, V& v) {
  v("frame_budget_ms", c.frame_budget_ms, 0.0, 1e5);
  v("window_frames", c.window_frames, 1, 100000);
  v("relax_ratio", c.relax_ratio, 0.05, 1.0);
  v("opencv_threads", c.opencv_threads, 0, 256);
}

/// Walks every section of VoConfig in file order.
template <class Cfg, class V>
void forEachField(Cfg& cfg, V& v) {
  v.beginSection("detector");
  detectorFields(cfg.detector, v);
  v.beginSection("tracker");
  trackerFields(cfg.tracker, v);
  v.beginSection("motion");
  motionFields(cfg.motion, v);
  v.beginSection("keyframe");
  keyframeFields(cfg.keyframe, v);
  v.beginSection("map");
  mapFields(cfg.map, v);
  v.beginSection("pnp");
  pnpFields(cfg.pnp, v);
  v.beginSection("motion_filter");
  motionFilterFields(cfg.motion_filter, v);
  v.beginSection("bundle_adjustment");
  bundleAdjustmentFields(cfg.bundle_adjustment, v);
  v.beginSection("pipeline");
  pipelineFields(cfg.pipeline, v);
  v.beginSection("altimeter");
  altimeterFields(cfg.altimeter, v);
  v.beginSection("imu");
  imuFields(cfg.imu, v);
  v.beginSection("cpu_budget");
  cpuBudgetFields(cfg.cpu_budget, v);
}

}  // namespace planetary_vo::config_detail
