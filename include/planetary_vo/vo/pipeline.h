#pragma once
/// @file pipeline.h
/// The visual-odometry chain: the stages composed, one image in, one FrameResult out.
///
/// Two compositions, chosen by config.pipeline.trajectory_mode:
/// - unit_step_concatenation (the thesis chain, 4.4.1): every n-th frame, two-view F / E / H / auto between
/// the
///   last accepted frame and the current one; a model that fails its quality checks is rejected (the pose is
///   held and the next frame is tried against the same reference) instead of being concatenated; accepted
///   motions are chained with unit-norm translations, T_world_cam_k = T_world_cam_ref * T_ref_k.
/// - map (default): two-view initialisation once the parallax suffices, a triangulated map at unit baseline,
///   every frame tracked by PnP against the map points carried by live KLT tracks, keyframes by parallax and
///   track survival, new points triangulated against the oldest keyframe that saw the track, culling,
///   windowed bundle adjustment, and recovery: after max_consecutive_failed_frames without a pose, a new
///   two-view map is attached to the last good pose with a scale bridge (shared points, else the last
///   keyframe speed, else the scene depth), so the trajectory continues instead of jumping back to the
///   origin.
///
/// The pipeline only composes; each stage lives in its own file: klt_tracker.h, initializer.h, pnp_tracker.h,
/// keyframe_policy.h, mapper.h (keyframe insertion, triangulation, culling), bundle_adjuster.h,
/// motion_prior.h (the pose while no image gives one) and scale_bridge.h (the scale of a recovery). Its one
/// state variable is the PipelineStage below.
///
/// Pixels from the tracker are undistorted (PinholeCamera::undistortPixels) before any geometry.
///
/// Threading: process(), reset(), setCamera() and reconfigure() must be called from one thread. With
/// bundle_adjustment.asynchronous the bundle adjustment of a new keyframe runs in a worker thread owned by
/// the pipeline while the next image is tracked (KLT); the next process() applies it after tracking and
/// before estimating the pose, waiting if it is still running. So the adjustment is hidden behind the
/// tracking of the next image, and the results do not depend on timing. The map-only features of a keyframe
/// (map.keyframe_features) are then tracked in a thread of their own until the next keyframe joins them to
/// the map. mapPoints() reads the map of the calling thread.

#include <chrono>
#include <cstdint>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/fusion/measurements.h"
#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/vo/altimeter_aiding.h"
#include "planetary_vo/vo/bundle_adjuster.h"
#include "planetary_vo/vo/config.h"
#include "planetary_vo/vo/frame_result.h"
#include "planetary_vo/vo/inertial_aiding.h"
#include "planetary_vo/vo/initializer.h"
#include "planetary_vo/vo/input_check.h"
#include "planetary_vo/vo/keyframe_policy.h"
#include "planetary_vo/vo/keyframe_tracker.h"
#include "planetary_vo/vo/klt_tracker.h"
#include "planetary_vo/vo/map.h"
#include "planetary_vo/vo/map_drift.h"
#include "planetary_vo/vo/mapper.h"
#include "planetary_vo/vo/motion_filter.h"
#include "planetary_vo/vo/pnp_tracker.h"

namespace planetary_vo {

/// What the chain does with the next processed image: the one state variable of the pipeline (the output
/// TrackingState of a frame follows from it and from whether that frame gave a pose).
enum class PipelineStage : uint8_t {
  kInitialising,  ///< no trajectory yet: waiting for a reference frame and the parallax of a two-view start
  kTracking,      ///< a map exists (map mode) or the unit-step chain runs: frames are tracked against it
  kRecovering,    ///< the map (chain) was lost or dropped: a new one is being built from the last good pose
};
/// "initialising", "tracking", "recovering".
const char* toString(PipelineStage stage);

/// `current` with the fields of `next` that Pipeline::reconfigure() changes at runtime (the list documented
/// there). It equals `next` exactly when `next` differs from `current` in those fields only.
VoConfig withRuntimeChangeableFields(const VoConfig& current, const VoConfig& next);

class Pipeline {
 public:
  /// @param config validated configuration (VoConfig::validate() is called; throws ConfigError).
  /// @param camera intrinsics and distortion of the images given to process(); must be valid.
  /// @throws std::invalid_argument for an invalid camera.
  Pipeline(const VoConfig& config, const PinholeCamera& camera);
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// @brief Processes one image.
  /// @param timestamp_s image time; only used for the output and the speed of the recovery's scale bridge.
  /// @param gray 8-bit single-channel image of the camera's size.
  /// @throws std::invalid_argument for an empty, non-8UC1 or wrongly sized image (the state is unchanged).
  FrameResult process(double timestamp_s, const cv::Mat& gray);

  /// @brief An altimeter reading (vision + altimeter mode, config.altimeter.enabled; ignored otherwise).
  /// Give readings in stamp order, before the image they belong to. With a reading at the time of the
  /// initialising image the first map is metric at once (metres); otherwise at the first keyframe that has
  /// one (FrameResult::metric_scale says which).
  /// @throws std::invalid_argument for a non-finite stamp, a NaN or negative range, or a stamp older than the
  /// last reading (the state is unchanged).
  void addAltimeter(const AltimeterSample& sample);

  /// An IMU sample (camera + IMU mode, config.imu.enabled; ignored otherwise), stamped on the IMU clock.
  /// Give samples in stamp order, up to (at least) the time of the image they precede.
  /// @throws std::invalid_argument for a non-finite stamp or value, or a stamp not after the last sample
  /// (the state is unchanged).
  void addImu(const ImuSample& sample);

  /// The pose of the camera at the first image, as guidance hands it over (e.g. in the landing-site frame):
  /// the trajectory starts there instead of at the origin. Call before the first image (or after reset()).
  /// The world frame is then taken as gravity-aligned (z up), which the camera + IMU mode needs.
  void setInitialPose(const Pose& T_world_cam);
  /// setInitialPose() plus the velocity of the IMU body at the first image (world frame, m/s): with the IMU,
  /// the first map is metric from the IMU alone (its baseline propagated from this state).
  void setInitialState(const Pose& T_world_cam, const Eigen::Vector3d& v_world_mps);

  /// Camera + IMU mode: the navigation state (IMU body pose, velocity, biases) of the last processed frame
  /// moved on to t_s by the IMU samples given so far: the low-latency output between images. nullopt when
  /// there is no inertial estimate, t_s is before the last frame, or the IMU does not cover the span.
  std::optional<NavState> navStateAt(double t_s) const;
  /// T_cam_imu of the configuration (camera pose = body pose * T_cam_imu^-1).
  const Pose& T_cam_imu() const { return inertial_.T_cam_imu(); }

  /// Forgets tracks, map, trajectory and buffered readings: the next frame starts a new trajectory at the
  /// initial pose (the origin unless setInitialPose() was called).
  void reset();

  /// Changes the intrinsics (e.g. a new camera_info). If they differ, the tracks and the map are dropped and
  /// the chain re-initialises from the current pose (state lost, then recovered), without a jump.
  void setCamera(const PinholeCamera& camera);

  /// Drops the tracks and re-initialises from the current pose (state lost, then recovered, without a jump),
  /// as after a camera change: for a caller that cannot trust the last frame (an exception part-way through
  /// process(), e.g. from OpenCV or Ceres).
  void restartTracking();

  /// @brief Applies a configuration change to the running pipeline in place, between two process() calls:
  /// tracks, map, trajectory, scale (and its confidence) and inertial state are all kept, so the trajectory
  /// continues without a jump and without a new scale. Runtime-changeable fields (every other field of
  /// `next` must equal config()):
  /// - detector.num_features, detector.grid_cols, detector.grid_rows: the budget and the grid of the next
  ///   detections (replenishment, restart); live tracks stay.
  /// - tracker.window_size_px, tracker.pyramid_levels, tracker.anchor_refinement: from the next frame on, for
  ///   the live tracks too (KltTracker::setConfig; CpuBudget's steps).
  /// - map.keyframe_features: the map-only features from the next keyframe on (0: none); the current ones are
  ///   dropped, their points stay while keyframes observe them (CpuBudget's first step when they are on).
  /// - cpu_budget: not read by the pipeline (vo_run and the VO nodelet apply it).
  /// - motion.model: the two-view model of the next initialisation or recovery (map mode) or of the next
  ///   step (unit-step chain); a setPriorPlaneNormal() override is kept.
  /// - bundle_adjustment.enabled: off waits for a solve still in flight and applies it (it belongs to the
  ///   current map: the same as the next frame would have done), then stops the worker; on adjusts from the
  ///   next keyframe (in a worker thread when bundle_adjustment.asynchronous).
  /// @throws ConfigError when `next` is invalid (VoConfig::validationErrors()); std::invalid_argument naming
  /// every other field that differs ("tracker.window_size_px, map.window_keyframes: not changeable at
  /// runtime ..."). The pipeline is unchanged when it throws.
  void reconfigure(const VoConfig& next);

  /// Expected ground-plane normal in the camera (pointing away from it) that decides the homography's
  /// two-fold ambiguity; overrides motion.plane_normal_prior of the config (default none), zero = no prior.
  void setPriorPlaneNormal(const Eigen::Vector3d& normal_cam);

  /// World positions and observation counts of the current (windowed) map points.
  void mapPoints(std::vector<MapPointView>* out) const { map_.pointViews(out); }
  const Map& map() const { return map_; }
  const PinholeCamera& camera() const { return camera_; }
  const VoConfig& config() const { return config_; }
  /// Live tracks of the last processed frame (distorted pixels), e.g. to draw the tracking image.
  const std::vector<FeatureTrack>& tracks() const { return tracker_.tracks(); }

 private:
  /// Ideal pixels of a frame's live tracks, sorted by track id, with the pose the frame had.
  struct FrameSnapshot {
    bool valid = false;
    double timestamp_s = 0.0;
    Pose T_world_cam = Pose::Identity();
    std::vector<uint64_t> track_ids;
    std::vector<Eigen::Vector2d> px;
  };

  void trackFeatures(const cv::Mat& gray, FrameResult* result);
  /// The input check refused the image (`why`): the chain does not see it, the pose coasts (holdPose).
  FrameResult refuseInput(const std::string& why, std::chrono::steady_clock::time_point start,
                          FrameResult* result);
  void snapshotCurrent(double timestamp_s, const Pose& T_world_cam, FrameSnapshot* out) const;
  /// Correspondences of `ref` with the current frame by track id into px_ref_ / px_cur_ / match_ids_.
  void matchToCurrent(const FrameSnapshot& ref);

  void processUnitStep(FrameResult* result);
  /// @param start when process() was entered: the pose's latency (times.pose_ms) is measured from it.
  void processMap(std::chrono::steady_clock::time_point start, FrameResult* result);
  void tryInitialise(FrameResult* result);
  void trackAgainstMap(FrameResult* result);
  void startRecovery();
  void maybeInsertKeyframe(FrameResult* result);
  void insertKeyframe(FrameResult* result);
  void runBundleAdjustment(FrameResult* result);
  /// The bundle adjustment's config with the robust-loss scale of the frame's tracking method
  /// (robust_loss_scale_aligned_px when `frame` was tracked by anchor alignment).
  BundleAdjustmentConfig adjustmentConfig(const FrameResult& frame) const;
  void applyAsyncBundleAdjustment(FrameResult* result);
  /// The keyframe tracker's tracks (keyframe_tracker.h) in ideal pixels.
  KeyframeTracks idealKeyframeTracks() const;
  /// Joins the map-only tracks tracked in the background (keyframe_job_) to their keyframe, if any are
  /// pending (waits for them).
  void collectKeyframeTracking(FrameResult* result);
  /// Waits for the background map-only tracking, if any, and drops its result (a new map or a reset).
  void discardKeyframeTracking();
  /// The current frame's pose refined again against the map points as they are now (after an adjustment).
  void refinePoseAgainstMap(FrameResult* result);
  /// A converged adjustment into the map (Map::applyBaResult(), whose count of removed points it returns); the
  /// published pose's motion filter moves with the newest keyframe (motion_filter.move_with_map).
  int applyAdjustment(const BaProblem& problem, const std::vector<BaObservation>& outliers);
  /// No pose this frame: map mode outputs predictPose(), the unit-step chain holds the last pose.
  void holdPose(FrameResult* result, const std::string& why);
  /// The motion prior (motion_prior.h): the last good pose moved on to the current time.
  Pose predictPose() const;
  /// Vision + altimeter: metres per unit of a new two-view map (points in the reference camera, unit
  /// baseline), or an invalid fix.
  AltimeterScaleFix initialMapScale(const Initialization& init) const;
  /// Vision + altimeter, map not yet metric: scales map and trajectory to metres about the initial position
  /// when the current keyframe has a valid fix.
  void tryMetricScaleAtKeyframe(FrameResult* result);
  /// Vision + altimeter, metric map: the altimeter ranges of the BA window's keyframes (but the oldest)
  /// against planes fitted to the current map.
  std::vector<BaRangeObservation> altimeterRanges() const;
  /// Camera + IMU mode usable: enabled and a gravity-aligned world (initial pose handed over, or the
  /// visual-inertial alignment done).
  bool inertialActive() const { return config_.imu.enabled && (initial_pose_given_ || gravity_aligned_); }
  /// Camera + IMU without an inertial state at the newest keyframe (no handed-over velocity, or the chain
  /// broken by an IMU gap): the visual-inertial alignment (inertial_initializer.h) over the newest keyframes
  /// the IMU covers without a gap; on success the map becomes metric and gravity-aligned (rotated about the
  /// first camera when it was not yet) and those keyframes get their velocities and biases.
  void tryInertialAlignment(FrameResult* result);
  /// The newest keyframe's inertial state (body), else the state handed over / carried from an older map.
  std::optional<NavState> newestInertialState() const;
  /// newestInertialState() moved on by the IMU to the current image time (at most kMaxInertialBridgeS), or
  /// nullopt.
  std::optional<NavState> inertialStateNow() const;
  /// Gives a new (metric) keyframe its velocity and biases (propagated by the IMU from the previous
  /// keyframe, or from newestInertialState()) and the preintegration from the previous keyframe.
  void attachInertialState(uint64_t keyframe_id, FrameResult* result);
  /// Metres per unit of a new two-view map from the IMU baseline between the reference and the current
  /// image (propagated from newestInertialState()), or NaN with `why`.
  double inertialMapScale(const Initialization& init, std::string* why) const;
  /// The newest inertial state that has a covariance (a keyframe's, else the carried one) and that
  /// covariance.
  std::optional<std::pair<NavState, Eigen::Matrix<double, 9, 9>>> newestCovariance() const;
  /// Adds the window's inertial states, IMU factors and bias prior to `problem`.
  void addInertialFactors(BaProblem* problem) const;
  /// The inertial state of a processed (or refused) frame that navStateAt() moves on: the frame's pose and
  /// velocity when it has a velocity, else none.
  void keepNavState(const FrameResult& result);
  /// Velocity and biases of this frame (camera + IMU mode).
  void fillInertialOutput(FrameResult* result) const;
  /// The published pose of a frame tracked against the map through the motion filter (vision only:
  /// motion_filter.h); the filter restarts on a new or rescaled map.
  void filterPublishedPose(FrameResult* result);
  /// The map became metric from the altimeter (at `c_world_m`, the scale's relative 1-sigma): the map's
  /// drift starts from the handed-over pose's uncertainty, or goes on with the new scale's sigma.
  void startMapDrift(const Eigen::Vector3d& c_world_m, double relative_scale_sigma);
  /// Camera + IMU: the map's attitude walk since the first covariance, summed along the path, added to the
  /// covariance fillInertialOutput() gave (vo/map_drift.h; no scale term: the accelerometer holds it).
  void addMapDriftToInertialOutput(FrameResult* result);
  /// Vision + altimeter, a metric map, the motion filter on: the covariance of every frame from the last
  /// measurement's and the map's drift; the velocity's drift when the filter gives a velocity.
  void addMapDriftToAltimeterOutput(FrameResult* result);

  VoConfig config_;
  PinholeCamera camera_;
  Eigen::Matrix3d K_;
  KltTracker tracker_;
  Initializer initializer_;
  PnpTracker pnp_tracker_;
  KeyframePolicy keyframe_policy_;
  Mapper mapper_;
  KeyframeTracker keyframe_tracker_;  ///< map.keyframe_features > 0
  MotionFilter motion_filter_;        ///< motion_filter.enabled, vision only
  bool motion_filter_metric_scale_ = false;  ///< the map's scale when the filter last ran
  /// A metric map's drift that the filter cannot see (vision + altimeter): the covariance it gives the
  /// navigation, started at the metric fix; the scale's sigma is the altimeter fix's, then the median
  /// relative sigma of each adjustment's range factors.
  MapDrift map_drift_;
  int keyframes_since_start_ = 0;  ///< keyframes that added a pose since the start (the attitude's walk)
  /// The covariance of the last frame the motion filter measured (vision + altimeter): the frame's own part.
  Eigen::Matrix<double, 6, 6> frame_pose_covariance_ = Eigen::Matrix<double, 6, 6>::Zero();
  cv::Mat current_image_;             ///< the image being processed (as tracked), within process() only
  /// The map-only tracking of the last keyframe when the optimiser runs in its own thread: running in the
  /// background until the next keyframe joins its tracks to that keyframe (keyframe_job_keyframe_id_), just
  /// before it is inserted itself. While it is valid, nothing else touches keyframe_tracker_.
  std::future<KeyframeTrackingResult> keyframe_job_;
  uint64_t keyframe_job_keyframe_id_ = 0;
  Map map_;
  AltimeterAiding altimeter_;
  InertialAiding inertial_;
  std::unique_ptr<AsyncBundleAdjuster> async_ba_;
  int images_since_ba_submit_ = -1;  ///< -1: no adjustment waiting to be taken
  std::chrono::steady_clock::time_point frame_start_;
  FrozenFrameDetector frozen_detector_;
  ExposureCompensator exposure_compensator_;
  cv::Mat compensated_;  ///< the scaled image while the exposure compensation is active
  /// setPriorPlaneNormal()'s override of the configured plane-normal prior, kept across reconfigure().
  std::optional<Eigen::Vector3d> prior_plane_normal_override_cam_;

  // Chain state.
  int64_t frame_index_ = -1;
  double timestamp_s_ = 0.0;
  PipelineStage stage_ = PipelineStage::kInitialising;
  TrackingState state_ = TrackingState::kInitialising;  // output state of the last processed frame
  Pose T_world_cam_ = Pose::Identity();                 // last output pose
  Pose T_world_cam_initial_ = Pose::Identity();         // where the trajectory starts (setInitialPose)
  bool initial_pose_given_ = false;                     // the world is the handed-over, gravity-aligned one
  bool gravity_aligned_ = false;                        // ... or was made so by the visual-inertial alignment
  std::optional<Eigen::Vector3d> v_initial_world_mps_;  // handed-over velocity at the first image
  std::optional<NavState> carried_inertial_;            // inertial state before / between maps
  /// Covariance (position, attitude, velocity) of the state handed over or carried between maps, and that
  /// state.
  std::optional<std::pair<NavState, Eigen::Matrix<double, 9, 9>>> carried_covariance_;
  bool metric_scale_ = false;                      // map and trajectory in metres (vision + altimeter)
  ScaleSource scale_source_ = ScaleSource::kNone;  // what made them metres
  std::optional<NavState> last_nav_state_;         // inertial state of the last processed frame
  int failed_frames_ = 0;
  double scale_confidence_ = 0.0;
  // Median scene depth of the first map, world units (the scale bridge's anchor).
  double first_map_depth_ = 0.0;
  int frames_since_keyframe_ = 0;
  FrameSnapshot reference_;  // initialisation / unit-step reference frame
  FrameSnapshot last_good_;  // last frame with a pose estimate (map mode), the anchor of a recovery

  // Per-frame buffers, reused so that steady-state processing allocates little.
  std::vector<uint64_t> track_ids_;  // live tracks of the current frame, ascending
  std::vector<Eigen::Vector2d> px_;  // their ideal pixels
  std::vector<cv::Point2f> distorted_px_;
  std::vector<size_t> order_;
  std::vector<uint64_t> match_ids_;
  std::vector<cv::Point2d> px_ref_, px_cur_;
  MapAssociations assoc_;  // the current frame's tracks that carry map points, and PnP's verdict
  std::vector<Eigen::Vector3d> bearings_kf_, bearings_cur_;
  std::vector<double> scratch_;
  std::vector<uint64_t> remove_ids_;
};

}  // namespace planetary_vo
