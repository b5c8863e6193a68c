#pragma once
/// @file config.h
/// Configuration of the visual-odometry chain: one plain struct per stage, gathered in VoConfig.
///
/// Every default is stated exactly once, as a member initialiser below. config/default.yaml documents the
/// same values key by key, and test_config checks that parsing it yields a default-constructed VoConfig, so
/// the two cannot drift apart. Each stage receives only its own sub-struct (e.g. `KltTracker(const
/// TrackerConfig&)`); no stage sees YAML, rosparam or the whole VoConfig.
///
/// YAML layout: one map per section, named as the VoConfig members (`detector:`, `tracker:`, `motion:`,
/// `keyframe:`, `map:`, `pnp:`, `bundle_adjustment:`, `pipeline:`, `altimeter:`, `imu:`, `cpu_budget:`), each
/// holding the
/// keys named as the struct members. Loading lives in config_yaml.h.

#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/fusion/altimeter_range.h"

namespace planetary_vo {

/// Thrown by the loader and by VoConfig::validate(); the message lists every problem, one per line, each
/// naming `section.key`.
class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(std::vector<std::string> problems);
  /// One entry per bad or unknown key, e.g. "detector.num_featurs: unknown key (did you mean
  /// 'num_features'?)".
  const std::vector<std::string>& problems() const { return problems_; }

 private:
  std::vector<std::string> problems_;
};

/// Stage 1: ORB/FAST corners detected on a grid of image cells (thesis 4.4.2, Table 4.5, plus the Phase-1
/// redistribution of the budget of textureless cells).
struct DetectorConfig {
  int num_features = 300;            ///< total feature budget per full detection (Table 4.5)
  double scale_factor = 1.5;         ///< ratio between ORB pyramid levels (Table 4.5)
  int num_levels = 4;                ///< ORB pyramid levels, 1 = full resolution only (Table 4.5)
  int patch_size_px = 20;            ///< rBRIEF patch size (Table 4.5)
  int fast_threshold = 20;           ///< FAST intensity threshold, grey levels (Table 4.5)
  int fast_threshold_fallback = 7;   ///< FAST threshold retried in a cell short of corners; 0 = no retry
  int edge_threshold_px = 0;         ///< no corner closer than this to the image border (Table 4.5: 0)
  int grid_cols = 8;                 ///< grid cells across (thesis 4.4.2.1: 64 sub-windows)
  int grid_rows = 8;                 ///< grid cells down
  double min_distance_px = 10.0;     ///< minimum distance between two features (new or existing); 0 = off
  bool redistribute_budget = true;   ///< give the unused budget of corner-poor cells to textured ones
  bool compute_descriptors = false;  ///< compute ORB descriptors (only relocalisation needs them)
};

/// What the tracker does when features are lost.
enum class ReplenishStrategy {
  kEmptyCells,  ///< keep surviving tracks, detect new features only in grid cells that became empty (Phase 1)
  kRestartBelowMin,  ///< thesis 4.4.1: when too few tracks survive, drop all and detect afresh
};

/// How the tracker finds each track in a new image.
enum class TrackingMethod {
  kKlt,  ///< pyramidal LK frame to frame (thesis 4.4.3), forward-backward check, optional anchor refinement
  /// No frame-to-frame LK: each track's anchor patch, cut at every pyramid level, is aligned coarse to fine
  /// from the predicted position (SVO's feature alignment used as the tracker). No Scharr pyramid, no
  /// backward pass; the anchor residual is the consistency check.
  kAnchorAlignment,
  /// anchor_alignment while the view is close to a plane (at least half the tracks on one homography between
  /// consecutive images, three frames in a row), klt otherwise (a 3D scene such as a street); starts with
  /// klt.
  kAuto,
};

/// Stage 2: pyramidal Lucas-Kanade tracking (thesis 4.4.3, Table 4.7) with forward-backward check.
struct TrackerConfig {
  /// klt (the thesis' LK), anchor_alignment (no LK: faster, and on a plane-like view more accurate) or auto
  TrackingMethod method = TrackingMethod::kAuto;
  int window_size_px = 21;             ///< LK search window side (Table 4.7: 21x21)
  int pyramid_levels = 3;              ///< LK pyramid levels above full resolution (Table 4.7)
  double min_eigen_threshold = 0.001;  ///< OpenCV minEigThreshold: rejects low-contrast windows (Table 4.7)
  int max_iterations = 30;             ///< LK iterations per level (Table 4.7)
  double epsilon_px = 0.01;            ///< LK stops when the update is smaller than this (Table 4.7)
  double fb_max_error_px =
      1.0;            ///< forward-backward round-trip error above which a track is dropped; 0 = off
  int border_px = 1;  ///< a track closer than this to the image border is dropped
  /// Start LK at a predicted position instead of the previous one: the track's own last image motion
  /// (constant image velocity), or the median motion of its 8 nearest tracks for a new feature. Keeps LK
  /// inside its convergence basin when the whole image moves by tens of pixels (a turn, a fast pass over the
  /// ground).
  bool predict_flow = true;
  ReplenishStrategy replenish_strategy = ReplenishStrategy::kEmptyCells;
  int replenish_cell_min_features =
      1;                           ///< kEmptyCells: a cell holding fewer tracks than this gets new features
  int min_tracked_features = 100;  ///< kRestartBelowMin: restart detection below this many tracks
  /// kEmptyCells: detect only once at least this many grid cells hold fewer than replenish_cell_min_features
  /// tracks (1 = whenever one does); fewer, larger detections instead of one for every cell that empties.
  int replenish_min_cells = 3;
  /// After KLT, align each track's anchor patch (its patch when detected or last re-anchored) in the new
  /// image (patch_alignment.h, SVO's feature alignment), so that its position error does not grow with its
  /// age.
  bool anchor_refinement = true;
  int anchor_patch_px = 11;          ///< side of the anchor patch (odd)
  double anchor_max_shift_px = 1.0;  ///< a refinement farther than this from KLT is not used: re-anchored
  double anchor_max_residual_ratio =
      0.3;                         ///< nor one whose RMS residual exceeds this fraction of the contrast
  int anchor_max_age_frames = 20;  ///< the anchor is renewed after this many frames (appearance changes)
  /// The patch is warped by the rotation and zoom since its anchor frame, fitted to the tracks anchored in
  /// the same frame when there are at least this many; 0 = never warped (translation only).
  int anchor_warp_min_tracks = 8;
  /// anchor_alignment: a track whose alignment leaves more of its patch's contrast than this (RMS residual /
  /// patch standard deviation), or does not converge, is looked for again from the previous image; lost when
  /// that fails too.
  double alignment_max_residual_ratio = 0.6;
  /// anchor_alignment: look for a track whose anchor failed with its patch from the previous image (frame to
  /// frame, like LK), which then becomes its anchor. false: such a track is lost.
  bool alignment_previous_fallback = true;
};

enum class MotionModel { kFundamental, kEssential, kHomography, kAuto };

/// Expected ground-plane normal in the camera frame (pointing away from the camera) that may decide the
/// homography's two-fold ambiguity when the points' in-front counts cannot.
enum class PlaneNormalPrior {
  kNone,         ///< no prior: an ambiguous homography is rejected and the essential matrix is tried
  kOpticalAxis,  ///< +z: the ground faces a nadir (down-looking) camera
  kImageDown,    ///< +y: the ground lies below a forward-looking vehicle camera (road, rover)
};

/// The unit normal of `prior` in the camera frame; zero for kNone.
Eigen::Vector3d planeNormalPriorVector(PlaneNormalPrior prior);

/// Stage 3: two-view motion estimation (thesis 4.4.4) and the H-vs-F/E model selection.
struct MotionConfig {
  MotionModel model = MotionModel::kAuto;  ///< auto = choose H or E per frame pair by the score ratio below
  double ransac_confidence = 0.99;         ///< RANSAC success probability
  double ransac_threshold_px = 1.0;        ///< RANSAC inlier threshold (epipolar distance / transfer error)
  int ransac_max_iterations = 1000;        ///< RANSAC iteration cap
  double homography_score_ratio = 0.45;    ///< auto: pick H when S_H / (S_H + S_F) > this (ORB-SLAM R_H)
  int min_inliers = 30;                    ///< fewer RANSAC inliers -> the frame pair is rejected
  double min_parallax_deg = 0.7;           ///< median triangulation angle needed to trust a two-view pose
  /// A two-view start's rotation may have at most this 1-sigma (deg) for 1 px of pixel noise, from the
  /// geometry of its points (geometry/two_view_conditioning.h); above it the initialisation reference moves
  /// to the current frame. 0 = no check.
  double max_rotation_sigma_deg = 1.5;
  /// Homography two-fold ambiguity prior; none by default (a wrong prior picks the wrong decomposition, see
  /// config/default.yaml).
  PlaneNormalPrior plane_normal_prior = PlaneNormalPrior::kNone;
};

enum class KeyframeMode {
  kFixedRate,  ///< every processed frame is a keyframe (the thesis chain)
  kParallax,   ///< a keyframe when parallax or track survival says the view changed enough
};

/// Keyframe selection and input decimation.
struct KeyframeConfig {
  KeyframeMode mode = KeyframeMode::kParallax;
  int process_every_n_frames = 1;  ///< process one input frame out of n (thesis: 0.5 Hz from 30 Hz = 60)
  double min_parallax_deg = 3.0;   ///< kParallax: median rotation-compensated parallax for a new keyframe
  double min_track_ratio = 0.8;  ///< kParallax: new keyframe when fewer of the last keyframe's tracks survive
  int max_interval_frames = 30;  ///< kParallax: a keyframe at least every this many processed frames
};

/// Sparse map of triangulated points (thesis Phase 2).
struct MapConfig {
  double min_triangulation_parallax_deg = 0.7;  ///< rays closer than this are not triangulated
  double max_reprojection_error_px = 2.0;       ///< a new or refined point reprojecting worse is rejected
  int min_observations = 2;                     ///< keyframes that must see a point for it to be kept
  double cull_min_found_ratio = 0.25;           ///< culled when found / predicted-visible falls below this
  int window_keyframes = 10;                    ///< keyframes in the local map used for tracking
  /// Map-only features followed from keyframe to keyframe (keyframe_tracker.h) on top of the frame tracker's
  /// detector.num_features: more points for the map and the bundle adjustment, none for the per-frame pose.
  /// 0 = none.
  int keyframe_features = 0;
  /// A map-only track's anchor patch is cut again after this many keyframes (the view changes the ground's
  /// appearance; 1 = each keyframe aligns the previous one's patch).
  int keyframe_anchor_max_age = 3;
  /// The map's attitude drifts: a random walk of this 1-sigma per axis per keyframe inserted. The published
  /// covariance of a metric navigation carries it (vo/map_drift.h: vision + altimeter, with the scale's
  /// uncertainty; camera + IMU, on top of the window's covariance); no estimate reads it. 0.01: the attitude
  /// drift of the benchmark main brakes (docs/visual_core.md steps 19-21).
  double attitude_drift_deg_per_sqrt_keyframe = 0.01;
};

/// Frame-to-map pose by EPnP inside RANSAC.
struct PnpConfig {
  double ransac_reprojection_error_px = 2.0;  ///< RANSAC inlier threshold
  int ransac_iterations = 100;                ///< RANSAC iteration cap
  double ransac_confidence = 0.99;            ///< RANSAC success probability
  int min_inliers = 15;                       ///< fewer inliers -> tracking against the map failed
  /// Levenberg-Marquardt on RANSAC's inliers, then the robust motion-only refinement over all
  /// correspondences (geometry/pose_gauss_newton.h, bundle_adjustment's loss).
  bool refine = true;
  /// Start from the motion model's predicted pose: robust motion-only refinement from it, RANSAC only when
  /// that leaves fewer than prediction_min_inlier_ratio of the correspondences as inliers. Needs refine.
  bool from_prediction = true;
  double prediction_min_inlier_ratio = 0.8;
};

/// The motion filter of the vision-only output (motion_filter.h): each frame's pose against the map fused
/// with a constant-acceleration (or constant-velocity) prediction. Off in the camera + IMU mode (the IMU is
/// the motion model there) and in the unit-step chain.
struct MotionFilterConfig {
  bool enabled = true;  ///< the default since docs/visual_core.md step 16 (held out: 53 of 53 renders lower)
  /// Random acceleration of the motion model, as a fraction of the speed per second (map units are not metres
  /// in vision-only mode): 0.01 lets the speed change by about 1 % a second between images beyond the
  /// estimated acceleration. 0.01 and a jerk of 0.025 since docs/visual_core.md step 18 (held out: one-frame
  /// error lower on 53 of 53 renders); config/lunar_altimeter.yaml keeps 0.02 and 0.05 for its velocity
  /// covariance, which guidance reads.
  double accel_sigma_ratio_per_s = 0.01;
  /// Also estimate a constant acceleration (a braking lander is then followed without lag), driven by a
  /// random jerk of jerk_sigma_ratio_per_s2 times the speed; false: constant velocity (step 14's filter).
  bool constant_acceleration = true;
  double jerk_sigma_ratio_per_s2 = 0.025;
  /// The acceleration's uncertainty when the filter starts, as a fraction of the speed per second.
  double initial_accel_sigma_ratio_per_s = 0.2;
  /// Floor of that acceleration, as a fraction of the median scene depth per second^2 (a hovering camera).
  double min_accel_sigma_depth_ratio = 0.001;
  /// Random angular acceleration of the motion model, deg/s^2.
  double angular_accel_sigma_dps2 = 10.0;
  /// Floor of the pixel noise that scales a frame's information (its RMS reprojection residual otherwise).
  double min_pixel_sigma_px = 0.05;
  /// A frame whose normalised innovation squared (6 dof) exceeds this is taken unfiltered and restarts the
  /// pose (chi-square 6 dof: 22.5 at p = 0.001).
  double gate_nis = 22.5;
  /// A gap longer than this between two filtered frames restarts the filter, s.
  double max_gap_s = 1.0;
  /// When the optimiser moves the map, the filter's state moves with the newest keyframe (else the next
  /// frame's pose, taken against the moved map, reads the move as motion). The default since
  /// docs/visual_core.md step 17 (held out: velocity error lower on 46 of 53 renders).
  bool move_with_map = true;
};

enum class RobustLoss { kNone, kHuber, kCauchy };

/// Sliding-window bundle adjustment (Ceres).
struct BundleAdjustmentConfig {
  bool enabled = true;
  int window_keyframes = 10;  ///< keyframes whose poses are optimised
  RobustLoss robust_loss = RobustLoss::kHuber;
  /// Reprojection error where the robust loss starts to flatten, for frames tracked with LK.
  double robust_loss_scale_px = 2.0;
  /// The same while the tracker runs anchor_alignment: its tracks are aligned to sub-pixel against their
  /// anchor patch, so their inlier errors are smaller than LK's. Used by the adjustment and the per-frame
  /// refinement of the frames tracked that way (and for their 3x outlier threshold).
  double robust_loss_scale_aligned_px = 0.5;
  int max_iterations = 20;  ///< Ceres iterations per adjustment
  /// The adjustment also stops once an iteration moved no free keyframe by more than this: its rotation in
  /// rad, and its camera centre as a fraction of the window's extent (the largest distance between two of
  /// its camera centres). What is still moving then (a point sliding along its ray) changes no pose: on the
  /// benchmark renders a fifth of the adjustments ran to max_iterations that way (docs/visual_core.md step
  /// 22). Not used in windows with IMU states (their biases converge after the poses). 0 = Ceres' own
  /// stopping criteria only.
  double pose_change_tolerance = 1e-5;
  /// Adjust in a background thread while the next image is tracked (applied before that frame's pose, so
  /// results do not depend on timing); false = inline, within the keyframe's own processing.
  bool asynchronous = true;
  /// Linux nice value of the background optimiser thread (asynchronous), 0-19: on a core it shares with the
  /// tracking, the tracking then runs first and the optimiser takes the time between frames (frames fed at
  /// the camera's rate). Frames fed back to back (vo_run) then wait for the optimiser at keyframes. 0 = the
  /// tracking's priority.
  int thread_nice = 0;
  /// Asynchronous only: the tracking takes the finished adjustment at the N-th image after the keyframe that
  /// submitted it, after that image's KLT and before its pose (which waits for the optimiser if it is not
  /// done), or at the next keyframe if that comes first (after its pose: the keyframe's pose is then refined
  /// again against the adjusted map, and its pose time includes the wait). 1: the next image. A larger N
  /// gives the optimiser the tracking of N images to finish in (on a shared core, it slows them instead of
  /// making one of them wait); the images in between are posed against the map as it was. The result lands
  /// at a fixed frame either way: results do not depend on timing.
  int collect_after_images = 1;
};

enum class TrajectoryMode {
  kUnitStepConcatenation,  ///< thesis 4.4.1: chain the unit-norm two-view motions, no map
  kMap,                    ///< track against a triangulated map (scale consistent up to drift)
};

/// How the stages are composed and how the chain recovers from failures.
struct PipelineConfig {
  TrajectoryMode trajectory_mode = TrajectoryMode::kMap;
  int max_consecutive_failed_frames = 10;  ///< after this many frames without a pose, reinitialise
  /// An image whose mean absolute difference to the previous input image (subsampled, gray levels) is below
  /// this is a frozen frame (a stuck frame buffer): refused by the input check (input_check.h), not tracked;
  /// 0 = off.
  double frozen_frame_max_mean_abs_diff = 0.5;
  /// ... unless more than this fraction of the sampled pixels changed by more than 8 gray levels (an edge
  /// that moved: a slow camera without noise; input_check.h). 1 = the mean difference alone decides.
  double frozen_frame_max_moved_ratio = 0.0005;
  /// Exposure check (input_check.h): an image whose gray-level standard deviation is below this is black or
  /// blank (nothing to track) and is refused.
  double min_exposure_stddev = 2.0;
  /// Exposure check: an image with more than this fraction of its pixels at 255 is saturated and refused.
  double max_saturated_ratio = 0.9;
  /// Exposure compensation (input_check.h): when the mean brightness of an image differs from the previous
  /// one by at least this factor (either way), the step is taken as a change of exposure or gain and the
  /// images are scaled back to the brightness before the step for tracking; 0 = off.
  double exposure_step_ratio = 1.2;
};

/// Laser-altimeter aiding (issue 10): the metric scale of the map from the altimeter's slant range against
/// the range the map predicts along the beam (fusion/altimeter_range.h). Off by default: vision only. Map
/// mode only: the unit-step chain has no map to predict a range from and ignores it.
struct AltimeterAidingConfig {
  bool enabled = false;  ///< use the readings given to Pipeline::addAltimeter()
  /// The instrument as its data sheet gives it (defaults: the benchmark's flight altimeter, sensors.yaml).
  AltimeterNoise noise;
  /// Beam origin and unit boresight in the CAMERA optical frame (default: co-located, along +z).
  AltimeterMounting mounting;
  /// A reading is used for an image when it lies within this of the image time (the two readings around the
  /// image are interpolated when both returned).
  double max_time_offset_s = 0.06;
};

/// Inertial aiding (issue 10): the IMU between keyframes as preintegrated factors in the windowed bundle
/// adjustment (fusion/imu_preintegration.h, inertial_factors.h), with a velocity and IMU biases per keyframe.
/// Off by default: vision only. Needs a gravity-aligned, metric world: the initial state handed over
/// (Pipeline::setInitialState) and a metric map (from the altimeter, or from the IMU over the initialisation
/// baseline when the initial velocity is given). Map mode only.
struct ImuAidingConfig {
  bool enabled = false;  ///< use the samples given to Pipeline::addImu()
  /// Noise densities of the instrument (defaults: the benchmark's tactical-grade flight IMU, sensors.yaml).
  double gyro_noise_density_radps_per_sqrt_hz = 4.36332313e-05;
  double accel_noise_density_mps2_per_sqrt_hz = 0.001;
  double gyro_random_walk_radps2_per_sqrt_hz = 2.46126856e-08;
  double accel_random_walk_mps3_per_sqrt_hz = 1.550567511e-05;
  /// 1-sigma of the turn-on biases (the prior of the bias estimate; sensors.yaml *_turn_on_bias_*).
  double gyro_turn_on_bias_radps = 1.939254724e-05;
  double accel_turn_on_bias_mps2 = 0.0073549875;
  /// The biases of a window's oldest keyframe: true: under the estimate and covariance of the window in which
  /// that keyframe was the newest (what earlier windows learnt is carried on); false: under the turn-on sigma
  /// about the estimate so far (no memory: the estimate may walk by that much at every window).
  bool carry_bias_covariance = true;
  /// The velocity of a window's oldest keyframe: true: solved under the estimate so far with the covariance
  /// of the window in which that keyframe was the newest; false: held with its pose (its error then goes into
  /// the biases and the map). Opt-in: on Main Brake it lowers the position error further (22 biased-IMU
  /// renders at 512x512: position RMSE x0.66 of before session 32, against x0.86 with the velocity held), but
  /// on Approach it raises it x2.29 (15 of 16 held-out 1024 flight renders, 0.04-0.12 -> 0.10-0.69 m;
  /// docs/fusion/README.md, session 32).
  bool anchor_velocity_prior = false;
  /// Gravity magnitude; the world frame of the handed-over state has z up (Lunar: 1.62 m/s^2).
  double gravity_mps2 = 1.62;
  /// IMU pose in the camera optical frame (T_cam_imu): translation and roll/pitch/yaw (x, y, z axes, applied
  /// z-y-x); default co-located and aligned, as in the Lunar datasets.
  double cam_imu_x_m = 0.0, cam_imu_y_m = 0.0, cam_imu_z_m = 0.0;
  double cam_imu_roll_deg = 0.0, cam_imu_pitch_deg = 0.0, cam_imu_yaw_deg = 0.0;
  /// IMU clock minus camera clock: the sample stamped t_imu was taken at camera time t_imu - time_offset_s.
  double time_offset_s = 0.0;
  /// Gaps in the IMU stream up to this long are bridged by holding the last sample; a longer gap breaks the
  /// inertial chain (the keyframes on either side are not tied by an IMU factor; the status says so).
  double max_gap_s = 0.05;
  /// 1-sigma of the handed-over initial state (what guidance claims), the start of the covariance.
  double initial_position_sigma_m = 1.0;
  double initial_attitude_sigma_deg = 0.05;
  double initial_velocity_sigma_mps = 0.05;
};

/// CPU budget of a frame (issue 13, vo/cpu_budget.h): when the measured time of Pipeline::process() stays
/// above the budget, the caller makes the tracking lighter step by step (fewer features, fewer LK pyramid
/// levels, no anchor refinement, a smaller LK window) and undoes the steps when there is room again. The
/// pipeline itself does not read this section; vo_run and the VO nodelet do. Off by default.
struct CpuBudgetConfig {
  double frame_budget_ms = 0.0;  ///< budget of one frame's process() call, ms; 0 = off
  int window_frames = 20;        ///< processed frames whose median time decides one step
  /// A step is undone when the median is below this fraction of the budget and the lighter step's measured
  /// cost says the heavier one fits the budget (hysteresis: no step back and forth every window).
  double relax_ratio = 0.6;
  /// Threads of OpenCV's parallel loops (LK, pyramids; cv::setNumThreads, process-wide); 0 = OpenCV's default
  /// (one per core). 1 runs them on the calling thread: on a small flight computer whose other core serves
  /// the optimiser thread and the other nodes, a worker per core only adds waiting (docs/visual_core.md
  /// measures it).
  int opencv_threads = 0;
};

/// The whole configuration. A default-constructed VoConfig is the documented default (config/default.yaml).
struct VoConfig {
  DetectorConfig detector;
  TrackerConfig tracker;
  MotionConfig motion;
  KeyframeConfig keyframe;
  MapConfig map;
  PnpConfig pnp;
  MotionFilterConfig motion_filter;
  BundleAdjustmentConfig bundle_adjustment;
  PipelineConfig pipeline;
  AltimeterAidingConfig altimeter;
  ImuAidingConfig imu;
  CpuBudgetConfig cpu_budget;

  /// Every out-of-range value and every inconsistent combination, one line each naming `section.key`.
  std::vector<std::string> validationErrors() const;
  /// Throws ConfigError listing validationErrors() when there is any.
  void validate() const;
  /// YAML text of every key in effect (parseVoConfig(dump()) == *this). Defined in config_yaml.cpp.
  std::string dump() const;
};

bool operator==(const DetectorConfig& a, const DetectorConfig& b);
bool operator==(const TrackerConfig& a, const TrackerConfig& b);
bool operator==(const MotionConfig& a, const MotionConfig& b);
bool operator==(const KeyframeConfig& a, const KeyframeConfig& b);
bool operator==(const MapConfig& a, const MapConfig& b);
bool operator==(const PnpConfig& a, const PnpConfig& b);
bool operator==(const MotionFilterConfig& a, const MotionFilterConfig& b);
bool operator==(const BundleAdjustmentConfig& a, const BundleAdjustmentConfig& b);
bool operator==(const PipelineConfig& a, const PipelineConfig& b);
bool operator==(const AltimeterAidingConfig& a, const AltimeterAidingConfig& b);
bool operator==(const ImuAidingConfig& a, const ImuAidingConfig& b);
bool operator==(const CpuBudgetConfig& a, const CpuBudgetConfig& b);
bool operator==(const VoConfig& a, const VoConfig& b);
inline bool operator!=(const VoConfig& a, const VoConfig& b) { return !(a == b); }

/// YAML spelling of the enum values ("fundamental", "empty_cells", ...).
/// @brief The valid range [lo, hi] of a numeric key ("detector", "num_features"), from the one key table
/// (for front ends that clamp values themselves, e.g. dynamic_reconfigure). False for an unknown or
/// non-numeric key.
bool configRange(const std::string& section, const std::string& key, double* lo, double* hi);

const char* toString(MotionModel v);
const char* toString(PlaneNormalPrior v);
const char* toString(KeyframeMode v);
const char* toString(RobustLoss v);
const char* toString(TrajectoryMode v);
const char* toString(ReplenishStrategy v);
const char* toString(TrackingMethod v);

}  // namespace planetary_vo
