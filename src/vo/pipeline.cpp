#include "planetary_vo/vo/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

#include "config_fields.h"
#include "planetary_vo/geometry/median.h"
#include "planetary_vo/vo/inertial_initializer.h"
#include "planetary_vo/vo/motion_prior.h"
#include "planetary_vo/vo/scale_bridge.h"

namespace planetary_vo {

namespace {

/// "N (A aligned, +NEW, -LOST)": what one keyframe's map-only tracking did (keyframe_tracker.h).
std::string describeKeyframeTracking(const KeyframeTrackingResult& tracked) {
  return std::to_string(tracked.num_tracked) + " (" + std::to_string(tracked.num_aligned) + " aligned, +" +
         std::to_string(tracked.num_new) + ", -" + std::to_string(tracked.num_lost) + ")";
}

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

Pose scaledInverse(const Pose& T_c2_c1_unit, double scale) {
  Pose T_c2_c1 = T_c2_c1_unit;
  T_c2_c1.translation() *= scale;
  return T_c2_c1.inverse();
}

// Gauge policy of the windowed BA. Vision only: the two oldest keyframes of the window stay fixed, the first
// fixes the gauge, the second the scale. Vision + altimeter with a metric map and range factors on at least
// two free keyframes: the ranges fix the scale, so only the oldest keyframe stays fixed.
constexpr int kNumFixedBaKeyframes = 2;
constexpr int kNumFixedBaKeyframesWithRanges = 1;
constexpr size_t kMinRangeFactorsForScale = 2;
// ... and the IMU factors whenever there is one: from the oldest keyframe's pose and (held) velocity the IMU
// predicts the next position, so a second fixed pose would only force the vision error between the two into
// the biases.
// Map points that carry the terrain plane of an altimeter range factor in the solve.
constexpr size_t kRangeSupportPoints = 12;
// Camera + IMU: the IMU alone carries a state over at most this long (no vision between two keyframes, or
// from the handed-over state to the first metric keyframe). A tactical accelerometer's turn-on bias
// (7e-3 m/s^2) moves the position by 3 m in 30 s.
constexpr double kMaxInertialBridgeS = 30.0;
// The IMU baseline of a new map is used for its scale when an accelerometer bias of the data sheet's
// turn-on sigma moves it by less than this fraction.
constexpr double kMaxInertialScaleError = 0.01;
// The pixel noise of one observation for the points' covariance in the map events (the unit the
// reprojection residual of the bundle adjustment assumes).
constexpr double kPointObservationSigmaPx = 1.0;
// The variance of a velocity the pipeline does not know (the first metric frames, before the motion filter
// has one), (m/s)^2: what nav/odometry publishes for an unknown velocity.
constexpr double kUnknownVelocityVariance = 1e6;

/// The relative 1-sigma of a metric map's scale from the altimeter's range factors of one window: the
/// median of their relative sigmas, not that over the square root of their number, because the ranges of
/// nearby keyframes are predicted from planes fitted to the same map points, so their errors are nearly
/// the same (docs/visual_core.md step 19: the scale error stays at that level while the window moves on).
double medianRelativeRangeSigma(const std::vector<BaRangeObservation>& ranges) {
  std::vector<double> relative;
  relative.reserve(ranges.size());
  for (const BaRangeObservation& r : ranges) relative.push_back(r.sigma_m / r.measured_range_m);
  const auto mid = relative.begin() + static_cast<std::ptrdiff_t>(relative.size() / 2);
  std::nth_element(relative.begin(), mid, relative.end());
  return *mid;
}

/// The covariance of [position, attitude, velocity] (world; attitude: truth = Exp(theta) estimate) of state
/// `a` moved on to state `b` by the IMU: the linearised propagation (the attitude error rotates the
/// integrated motion, the velocity error grows the position error) plus the white noise of the gyro and
/// the accelerometer over the span. The bias uncertainty is not carried (the states hold no bias
/// covariance), so over long spans without a keyframe it is optimistic.
Eigen::Matrix<double, 9, 9> propagateCovariance(const Eigen::Matrix<double, 9, 9>& P, const NavState& a,
                                                const NavState& b, const ImuAidingConfig& imu,
                                                const Eigen::Vector3d& gravity) {
  const double dt = b.timestamp_s - a.timestamp_s;
  if (!(dt > 0.0)) return P;
  const Eigen::Vector3d dp = b.T_world_body.translation() - a.T_world_body.translation() -
                             a.v_world_mps * dt - 0.5 * gravity * dt * dt;
  const Eigen::Vector3d dv = b.v_world_mps - a.v_world_mps - gravity * dt;
  Eigen::Matrix<double, 9, 9> F = Eigen::Matrix<double, 9, 9>::Identity();
  F.block<3, 3>(0, 3) = -skew(dp);
  F.block<3, 3>(0, 6) = dt * Eigen::Matrix3d::Identity();
  F.block<3, 3>(6, 3) = -skew(dv);
  const double qa = imu.accel_noise_density_mps2_per_sqrt_hz * imu.accel_noise_density_mps2_per_sqrt_hz;
  const double qg = imu.gyro_noise_density_radps_per_sqrt_hz * imu.gyro_noise_density_radps_per_sqrt_hz;
  Eigen::Matrix<double, 9, 9> Q = Eigen::Matrix<double, 9, 9>::Zero();
  Q.block<3, 3>(0, 0) = qa * dt * dt * dt / 3.0 * Eigen::Matrix3d::Identity();
  Q.block<3, 3>(0, 6) = Q.block<3, 3>(6, 0) = qa * dt * dt / 2.0 * Eigen::Matrix3d::Identity();
  Q.block<3, 3>(3, 3) = qg * dt * Eigen::Matrix3d::Identity();
  Q.block<3, 3>(6, 6) = qa * dt * Eigen::Matrix3d::Identity();
  return F * P * F.transpose() + Q;
}

}  // namespace

const char* toString(PipelineStage stage) {
  switch (stage) {
    case PipelineStage::kInitialising:
      return "initialising";
    case PipelineStage::kTracking:
      return "tracking";
    case PipelineStage::kRecovering:
      return "recovering";
  }
  return "unknown";
}

Pipeline::Pipeline(const VoConfig& config, const PinholeCamera& camera)
    : config_(config),
      camera_(camera),
      tracker_(config.tracker, config.detector),
      initializer_(config.motion, config.map, planeNormalPriorVector(config.motion.plane_normal_prior)),
      pnp_tracker_(config.pnp, config.bundle_adjustment),
      keyframe_policy_(config.keyframe),
      mapper_(config.map),
      keyframe_tracker_(config.map.keyframe_features, config.map.keyframe_anchor_max_age, config.tracker,
                        config.detector),
      motion_filter_(config.motion_filter),
      map_drift_(config.map.attitude_drift_deg_per_sqrt_keyframe * M_PI / 180.0,
                 config.bundle_adjustment.window_keyframes),
      altimeter_(config.altimeter),
      inertial_(config.imu),
      frozen_detector_(config.pipeline.frozen_frame_max_mean_abs_diff,
                       config.pipeline.frozen_frame_max_moved_ratio),
      exposure_compensator_(config.pipeline.exposure_step_ratio) {
  config_.validate();
  std::string why;
  if (!camera_.isValid(&why)) throw std::invalid_argument("Pipeline: invalid camera: " + why);
  K_ = camera_.K();
  map_.setObservationSigma(kPointObservationSigmaPx / camera_.fx());
  if (config_.bundle_adjustment.enabled && config_.bundle_adjustment.asynchronous)
    async_ba_ = std::make_unique<AsyncBundleAdjuster>(config_.bundle_adjustment);
}

Pipeline::~Pipeline() { discardKeyframeTracking(); }

void Pipeline::reset() {
  if (async_ba_) {
    async_ba_->waitIdle();
    async_ba_->takeResult();  // belongs to the old map
    async_ba_->takeCovariance();
  }
  images_since_ba_submit_ = -1;
  discardKeyframeTracking();
  tracker_.reset();
  keyframe_tracker_.reset();
  frozen_detector_.reset();
  exposure_compensator_.reset();
  map_.clear();
  frame_index_ = -1;
  stage_ = PipelineStage::kInitialising;
  state_ = TrackingState::kInitialising;
  T_world_cam_ = T_world_cam_initial_;
  metric_scale_ = false;
  scale_source_ = ScaleSource::kNone;
  last_nav_state_.reset();
  altimeter_.clear();
  inertial_.clear();
  gravity_aligned_ = false;
  carried_inertial_.reset();
  carried_covariance_.reset();
  failed_frames_ = 0;
  scale_confidence_ = 0.0;
  first_map_depth_ = 0.0;
  frames_since_keyframe_ = 0;
  map_drift_.reset();
  frame_pose_covariance_.setZero();
  keyframes_since_start_ = 0;
  reference_.valid = false;
  last_good_.valid = false;
  motion_filter_.reset();
}

void Pipeline::setCamera(const PinholeCamera& camera) {
  if (camera == camera_) return;
  std::string why;
  if (!camera.isValid(&why)) throw std::invalid_argument("Pipeline::setCamera: invalid camera: " + why);
  camera_ = camera;
  K_ = camera_.K();
  map_.setObservationSigma(kPointObservationSigmaPx / camera_.fx());
  // Pixels of the old intrinsics cannot be matched to the new ones.
  restartTracking();
}

void Pipeline::restartTracking() {
  tracker_.reset();
  discardKeyframeTracking();
  keyframe_tracker_.reset();
  frozen_detector_.reset();
  exposure_compensator_.reset();
  // Continue from the current pose as after a loss, so the trajectory does not jump.
  if (stage_ != PipelineStage::kInitialising) stage_ = PipelineStage::kRecovering;
  reference_.valid = false;
  last_good_.valid = false;
  failed_frames_ = 0;
}

namespace {

/// "section.key" and value text of every field of a configuration (the key table of config_fields.h).
class FieldTexts {
 public:
  void beginSection(const char* name) { section_ = name; }
  template <class T, class L>
  void operator()(const char* key, const T& value, L, L) {
    std::ostringstream text;
    text.precision(17);
    text << value;
    add(key, text.str());
  }
  void operator()(const char* key, const bool& value) { add(key, value ? "true" : "false"); }
  template <class E>
  void enumeration(const char* key, const E& value) {
    add(key, config_detail::enumName(value));
  }
  std::vector<std::pair<std::string, std::string>> fields;

 private:
  void add(const char* key, std::string text) { fields.emplace_back(section_ + "." + key, std::move(text)); }
  std::string section_;
};

}  // namespace

VoConfig withRuntimeChangeableFields(const VoConfig& current, const VoConfig& next) {
  VoConfig runtime = current;
  runtime.detector.num_features = next.detector.num_features;
  runtime.detector.grid_cols = next.detector.grid_cols;
  runtime.detector.grid_rows = next.detector.grid_rows;
  runtime.motion.model = next.motion.model;
  runtime.bundle_adjustment.enabled = next.bundle_adjustment.enabled;
  runtime.tracker.window_size_px = next.tracker.window_size_px;
  runtime.tracker.pyramid_levels = next.tracker.pyramid_levels;
  runtime.tracker.anchor_refinement = next.tracker.anchor_refinement;
  runtime.map.keyframe_features = next.map.keyframe_features;
  runtime.cpu_budget = next.cpu_budget;  // not read by the pipeline
  return runtime;
}

void Pipeline::reconfigure(const VoConfig& next) {
  // Everything is checked before anything changes: a refused configuration leaves the pipeline as it was.
  next.validate();
  const VoConfig runtime = withRuntimeChangeableFields(config_, next);
  if (runtime != next) {
    FieldTexts have, want;
    config_detail::forEachField(runtime, have);
    config_detail::forEachField(next, want);
    std::string names;
    for (size_t i = 0; i < have.fields.size() && i < want.fields.size(); ++i)
      if (have.fields[i].second != want.fields[i].second)
        names += (names.empty() ? "" : ", ") + want.fields[i].first + " (" + have.fields[i].second + " -> " +
                 want.fields[i].second + ")";
    throw std::invalid_argument(
        "Pipeline::reconfigure: " + names +
        ": not changeable at runtime (only detector.num_features, detector.grid_cols, detector.grid_rows, "
        "tracker.window_size_px, "
        "tracker.pyramid_levels, tracker.anchor_refinement, map.keyframe_features, motion.model, "
        "bundle_adjustment.enabled and cpu_budget are; a new Pipeline takes the rest)");
  }
  if (!(next.detector == config_.detector)) tracker_.setDetectorConfig(next.detector);
  if (!(next.tracker == config_.tracker)) tracker_.setConfig(next.tracker);
  if (next.map.keyframe_features != config_.map.keyframe_features) {
    // The map-only tracking starts again from the next keyframe with the new number; the tracks of the old
    // one (and a job still running) are dropped, and their points stay for the adjustment while keyframes
    // observe them. Track ids keep increasing, so an old keyframe's pixels never meet a new track.
    discardKeyframeTracking();
    keyframe_tracker_.setNumFeatures(next.map.keyframe_features);
    map_.retainTracks({}, kFirstMapOnlyTrackId);
  }
  if (next.motion.model != config_.motion.model) {
    Initializer initializer(next.motion, next.map, planeNormalPriorVector(next.motion.plane_normal_prior));
    if (prior_plane_normal_override_cam_) initializer.setPriorPlaneNormal(*prior_plane_normal_override_cam_);
    initializer_ = initializer;
  }
  if (next.bundle_adjustment.enabled && !async_ba_ && next.bundle_adjustment.asynchronous) {
    async_ba_ = std::make_unique<AsyncBundleAdjuster>(next.bundle_adjustment);
  } else if (!next.bundle_adjustment.enabled && async_ba_) {
    // The solve in flight was submitted at the last keyframe of this map: apply it now, as the next frame
    // would have, with the covariance the worker computed after it; then stop the worker.
    async_ba_->waitIdle();
    if (auto finished = async_ba_->takeResult(); finished && finished->second.converged)
      applyAdjustment(finished->first, finished->second.outliers);
    if (const auto covariances = async_ba_->takeCovariance()) map_.applyCovariances(*covariances);
    async_ba_.reset();
    images_since_ba_submit_ = -1;
    // The map-only tracks of the last keyframe, tracked in the background, join it as the next frame would
    // have joined them; from now on they are tracked at the keyframe itself.
    FrameResult ignored;
    collectKeyframeTracking(&ignored);
  }
  config_ = next;
}

void Pipeline::addAltimeter(const AltimeterSample& sample) {
  if (config_.altimeter.enabled) altimeter_.add(sample);
}

void Pipeline::addImu(const ImuSample& sample) {
  if (config_.imu.enabled) inertial_.add(sample);
}

void Pipeline::setInitialState(const Pose& T_world_cam, const Eigen::Vector3d& v_world_mps) {
  if (!v_world_mps.allFinite()) throw std::invalid_argument("Pipeline::setInitialState: non-finite velocity");
  setInitialPose(T_world_cam);
  v_initial_world_mps_ = v_world_mps;
}

void Pipeline::setInitialPose(const Pose& T_world_cam) {
  if (frame_index_ >= 0)
    throw std::logic_error("Pipeline::setInitialPose: call it before the first image (or after reset())");
  const Eigen::Matrix3d& R = T_world_cam.linear();
  if (!T_world_cam.matrix().allFinite() || !(R.transpose() * R).isIdentity(1e-6) || !(R.determinant() > 0.0))
    throw std::invalid_argument("Pipeline::setInitialPose: not a finite rigid pose");
  T_world_cam_initial_ = T_world_cam;
  T_world_cam_ = T_world_cam;
  initial_pose_given_ = true;
  v_initial_world_mps_.reset();
}

void Pipeline::setPriorPlaneNormal(const Eigen::Vector3d& normal_cam) {
  initializer_.setPriorPlaneNormal(normal_cam);
  prior_plane_normal_override_cam_ = normal_cam;
}

FrameResult Pipeline::process(double timestamp_s, const cv::Mat& gray) {
  const Clock::time_point start = Clock::now();
  frame_start_ = start;
  if (gray.empty() || gray.type() != CV_8UC1)
    throw std::invalid_argument("Pipeline::process: expected a non-empty 8-bit single-channel image");
  if (gray.cols != camera_.width() || gray.rows != camera_.height())
    throw std::invalid_argument("Pipeline::process: image is " + std::to_string(gray.cols) + "x" +
                                std::to_string(gray.rows) + " but the camera is " +
                                std::to_string(camera_.width()) + "x" + std::to_string(camera_.height()));
  FrameResult result;
  result.frame_index = ++frame_index_;
  result.timestamp_s = timestamp_s;
  result.T_world_cam = T_world_cam_;
  result.state = state_;
  result.scale_confidence = scale_confidence_;
  if (frame_index_ % config_.keyframe.process_every_n_frames != 0) {
    result.processed = false;
    result.num_map_points = static_cast<int>(map_.numPoints());
    result.num_keyframes = static_cast<int>(map_.numKeyframes());
    return result;
  }
  result.processed = true;
  timestamp_s_ = timestamp_s;
  // The handed-over state belongs to the first image, whether or not that image can be tracked (a first
  // image refused as black still starts the IMU's dead reckoning).
  if (frame_index_ == 0 && inertialActive() && v_initial_world_mps_) {
    carried_inertial_ = inertial_.bodyState(timestamp_s, T_world_cam_initial_, *v_initial_world_mps_, {});
    Eigen::Matrix<double, 9, 1> sigma;
    sigma << Eigen::Vector3d::Constant(config_.imu.initial_position_sigma_m),
        Eigen::Vector3d::Constant(config_.imu.initial_attitude_sigma_deg * M_PI / 180.0),
        Eigen::Vector3d::Constant(config_.imu.initial_velocity_sigma_mps);
    carried_covariance_ =
        std::make_pair(*carried_inertial_, Eigen::Matrix<double, 9, 9>(sigma.cwiseAbs2().asDiagonal()));
  }
  // A black, blank or saturated image has nothing to track: refused like a frozen frame (below), and not
  // given to the frozen-frame check, whose previous image stays the last usable one.
  const std::string exposure_problem =
      checkExposure(gray, config_.pipeline.min_exposure_stddev, config_.pipeline.max_saturated_ratio);
  if (!exposure_problem.empty()) return refuseInput(exposure_problem + ", not tracked", start, &result);
  // A frozen frame (stuck frame buffer) is not given to the tracker: tracked, it would give a confident
  // zero-motion pose and teach the motion model that the camera stood still. The tracker keeps the last
  // fresh image, so tracking continues from it when fresh images return; the output coasts meanwhile.
  FrozenFrameDetector::Difference difference;
  if (frozen_detector_.check(gray, &difference)) {
    std::ostringstream why;
    why.precision(3);
    why << "frozen frame: the image repeats the previous one (mean absolute difference "
        << difference.mean_abs_diff << " < pipeline.frozen_frame_max_mean_abs_diff "
        << config_.pipeline.frozen_frame_max_mean_abs_diff << " gray levels, "
        << 100.0 * difference.moved_ratio << " % of the samples moved), not tracked";
    return refuseInput(why.str(), start, &result);
  }

  // The adjustment submitted at the last keyframe runs while LK tracks this image (LK touches only the
  // tracker), and is applied before the pose is estimated against the map.
  // A sudden exposure step is scaled back for tracking (the same image otherwise).
  const double gain_before = exposure_compensator_.gain();
  const cv::Mat& tracked = exposure_compensator_.apply(gray, &compensated_);
  if (exposure_compensator_.gain() != gain_before) {
    std::ostringstream what;
    what.precision(3);
    what << "exposure step: images scaled by " << exposure_compensator_.gain() << " for tracking";
    result.message = what.str();
  }
  trackFeatures(tracked, &result);
  current_image_ = tracked;  // for the map-only features of a keyframe (released below)
  if (images_since_ba_submit_ >= 0 &&
      (++images_since_ba_submit_ >= config_.bundle_adjustment.collect_after_images ||
       config_.pipeline.trajectory_mode == TrajectoryMode::kUnitStepConcatenation))
    applyAsyncBundleAdjustment(&result);
  if (config_.pipeline.trajectory_mode == TrajectoryMode::kUnitStepConcatenation)
    processUnitStep(&result);
  else
    processMap(start, &result);
  fillInertialOutput(&result);
  addMapDriftToInertialOutput(&result);
  filterPublishedPose(&result);
  addMapDriftToAltimeterOutput(&result);

  T_world_cam_ = result.T_world_cam;
  state_ = result.state;
  result.scale_confidence = scale_confidence_;
  result.metric_scale = metric_scale_;
  result.scale_source = scale_source_;
  keepNavState(result);
  result.num_map_points = static_cast<int>(map_.numPoints());
  result.num_keyframes = static_cast<int>(map_.numKeyframes());
  result.map_events = map_.takeEvents();
  current_image_.release();
  result.times.total_ms = msSince(start);
  if (result.times.pose_ms == 0.0) result.times.pose_ms = result.times.total_ms;
  return result;
}

FrameResult Pipeline::refuseInput(const std::string& why, Clock::time_point start, FrameResult* result) {
  result->input_rejected = true;
  result->state =
      stage_ == PipelineStage::kInitialising ? TrackingState::kInitialising : TrackingState::kLost;
  holdPose(result, why);
  fillInertialOutput(result);
  addMapDriftToInertialOutput(result);
  addMapDriftToAltimeterOutput(result);
  keepNavState(*result);  // a refused image too: without a map yet, the IMU's dead reckoning goes on from it
  T_world_cam_ = result->T_world_cam;
  state_ = result->state;
  result->metric_scale = metric_scale_;
  result->scale_source = scale_source_;
  result->num_map_points = static_cast<int>(map_.numPoints());
  result->num_keyframes = static_cast<int>(map_.numKeyframes());
  result->times.total_ms = msSince(start);
  result->times.pose_ms = result->times.total_ms;
  return *result;
}

void Pipeline::trackFeatures(const cv::Mat& gray, FrameResult* result) {
  const Clock::time_point start = Clock::now();
  const TrackingResult tracking = tracker_.track(gray);
  result->times.pyramid_ms = tracking.pyramid_ms;
  result->times.klt_ms = tracking.lk_ms;
  result->times.refine_ms = tracking.refine_ms;
  result->times.detect_ms = tracking.detect_ms;
  result->anchor_alignment = tracking.anchor_alignment;
  result->lk_rescue = tracking.lk_rescue;
  result->num_new_features = tracking.num_new;
  result->num_tracked = tracking.num_tracked;

  const std::vector<FeatureTrack>& tracks = tracker_.tracks();
  distorted_px_.resize(tracks.size());
  for (size_t i = 0; i < tracks.size(); ++i) distorted_px_[i] = tracks[i].px;
  const std::vector<cv::Point2f> ideal =
      camera_.hasDistortion() ? camera_.undistortPixels(distorted_px_) : std::vector<cv::Point2f>();
  const std::vector<cv::Point2f>& px = camera_.hasDistortion() ? ideal : distorted_px_;

  // Everything downstream looks tracks up by id, so keep them ascending (the tracker appends new ids, so this
  // is normally already the case and the sort is skipped).
  order_.resize(tracks.size());
  std::iota(order_.begin(), order_.end(), size_t{0});
  const bool sorted = std::is_sorted(
      tracks.begin(), tracks.end(), [](const FeatureTrack& a, const FeatureTrack& b) { return a.id < b.id; });
  if (!sorted)
    std::sort(order_.begin(), order_.end(),
              [&tracks](size_t a, size_t b) { return tracks[a].id < tracks[b].id; });
  track_ids_.resize(tracks.size());
  px_.resize(tracks.size());
  for (size_t k = 0; k < order_.size(); ++k) {
    track_ids_[k] = tracks[order_[k]].id;
    px_[k] = Eigen::Vector2d(px[order_[k]].x, px[order_[k]].y);
  }
  result->times.tracking_ms = msSince(start);
}

void Pipeline::snapshotCurrent(double timestamp_s, const Pose& T_world_cam, FrameSnapshot* out) const {
  out->valid = true;
  out->timestamp_s = timestamp_s;
  out->T_world_cam = T_world_cam;
  out->track_ids = track_ids_;
  out->px = px_;
}

void Pipeline::matchToCurrent(const FrameSnapshot& ref) {
  match_ids_.clear();
  px_ref_.clear();
  px_cur_.clear();
  // Both id lists are ascending: a merge walk.
  size_t i = 0, j = 0;
  while (i < ref.track_ids.size() && j < track_ids_.size()) {
    if (ref.track_ids[i] < track_ids_[j]) {
      ++i;
    } else if (track_ids_[j] < ref.track_ids[i]) {
      ++j;
    } else {
      match_ids_.push_back(track_ids_[j]);
      px_ref_.emplace_back(ref.px[i].x(), ref.px[i].y());
      px_cur_.emplace_back(px_[j].x(), px_[j].y());
      ++i;
      ++j;
    }
  }
}

void Pipeline::holdPose(FrameResult* result, const std::string& why) {
  result->T_world_cam =
      config_.pipeline.trajectory_mode == TrajectoryMode::kMap ? predictPose() : T_world_cam_;
  result->motion = MotionEstimate::kNone;
  result->message = why;
}

Pose Pipeline::predictPose() const {
  // Camera + IMU: the newest inertial state moved on by the IMU (also before the first map, from the
  // handed-over state), as long as the map is metric like the IMU.
  if (config_.pipeline.trajectory_mode == TrajectoryMode::kMap && inertialActive() &&
      (metric_scale_ || stage_ == PipelineStage::kInitialising)) {
    if (const std::optional<NavState> now = inertialStateNow()) return inertial_.cameraPose(*now);
  }
  if (!last_good_.valid) return T_world_cam_;
  return predictConstantVelocity(last_good_.T_world_cam, last_good_.timestamp_s, map_, timestamp_s_);
}

// ---------------------------------------------------------------------------------------------------------------
// The thesis chain: unit-norm two-view steps.

void Pipeline::processUnitStep(FrameResult* result) {
  const Clock::time_point start = Clock::now();
  scale_confidence_ = 0.0;  // every step has its own arbitrary unit length
  if (!reference_.valid) {
    snapshotCurrent(timestamp_s_, T_world_cam_, &reference_);
    result->state =
        stage_ == PipelineStage::kInitialising ? TrackingState::kInitialising : TrackingState::kLost;
    holdPose(result, "reference frame set");
    result->times.motion_ms = msSince(start);
    return;
  }
  matchToCurrent(reference_);
  const RelativeMotion motion = initializer_.estimateMotion(px_ref_, px_cur_, K_);
  result->times.motion_ms = msSince(start);
  if (!motion.valid) {
    ++failed_frames_;
    result->state =
        stage_ == PipelineStage::kInitialising ? TrackingState::kInitialising : TrackingState::kLost;
    holdPose(result, "model rejected: " + motion.reason);
    // The reference is kept so that the next frame can bring the parallax this one lacked; when that does not
    // help for too long (or the tracks are gone), the motion over the gap is given up and the chain restarts
    // from the held pose.
    const bool starved = static_cast<int>(match_ids_.size()) < config_.motion.min_inliers;
    if (failed_frames_ >= config_.pipeline.max_consecutive_failed_frames || starved) {
      snapshotCurrent(timestamp_s_, T_world_cam_, &reference_);
      if (stage_ == PipelineStage::kTracking) stage_ = PipelineStage::kRecovering;
      failed_frames_ = 0;
    }
    return;
  }
  result->T_world_cam = reference_.T_world_cam * motion.T_c2_c1_unit.inverse();
  result->motion = motion.model;
  result->num_inliers = motion.num_inliers;
  result->is_keyframe = true;
  result->state = stage_ == PipelineStage::kRecovering ? TrackingState::kRecovered : TrackingState::kTracking;
  stage_ = PipelineStage::kTracking;
  failed_frames_ = 0;
  // Thesis 4.4.1: the outliers of the accepted model are deleted from the tracks.
  remove_ids_.clear();
  for (size_t i = 0; i < match_ids_.size(); ++i)
    if (i < motion.inlier_mask.size() && motion.inlier_mask[i] == 0) remove_ids_.push_back(match_ids_[i]);
  tracker_.removeTracks(remove_ids_);
  snapshotCurrent(timestamp_s_, result->T_world_cam, &reference_);
  result->message = motion.resolved_by_prior ? "homography ambiguity resolved by the plane-normal prior" : "";
}

// ---------------------------------------------------------------------------------------------------------------
// Map mode.

void Pipeline::processMap(Clock::time_point start, FrameResult* result) {
  if (stage_ != PipelineStage::kTracking) {
    tryInitialise(result);
    return;
  }
  trackAgainstMap(result);
  result->times.pose_ms = msSince(start);  // the rest (keyframe, map) does not change this frame's pose
  if (result->state == TrackingState::kTracking) {
    maybeInsertKeyframe(result);
  } else if (failed_frames_ >= config_.pipeline.max_consecutive_failed_frames) {
    // An adjustment not taken yet belongs to this map, which the scale bridge still reads: taken now.
    if (images_since_ba_submit_ >= 0) applyAsyncBundleAdjustment(result);
    startRecovery();
    result->message += "; re-initialising from the last good pose";
  }
}

void Pipeline::tryInitialise(FrameResult* result) {
  const Clock::time_point start = Clock::now();
  const bool recovering = stage_ == PipelineStage::kRecovering;
  const TrackingState waiting = recovering ? TrackingState::kLost : TrackingState::kInitialising;
  result->state = waiting;
  if (!reference_.valid) {
    holdPose(result, "initialisation reference set");
    snapshotCurrent(timestamp_s_, result->T_world_cam, &reference_);
    return;
  }
  matchToCurrent(reference_);
  if (static_cast<int>(match_ids_.size()) < std::max(8, config_.motion.min_inliers)) {
    // The reference's tracks are gone: restart from this frame. Its pose is the constant-velocity prediction,
    // so a recovery that gets here continues from the last known motion (less accurate, but no jump).
    holdPose(result, "too few tracks left from the initialisation reference; reference moved");
    snapshotCurrent(timestamp_s_, result->T_world_cam, &reference_);
    return;
  }
  // Cheap pre-check before any RANSAC: the raw image motion must at least reach the parallax the two-view
  // checks demand; rotation can fake it, which the full estimate then rejects.
  scratch_.clear();
  for (size_t i = 0; i < px_ref_.size(); ++i)
    scratch_.push_back(std::hypot(px_ref_[i].x - px_cur_[i].x, px_ref_[i].y - px_cur_[i].y));
  const double median_flow_deg = std::atan(medianInPlace(&scratch_) / K_(0, 0)) * 180.0 / M_PI;
  if (median_flow_deg < config_.motion.min_parallax_deg) {
    holdPose(result, "waiting for parallax (" + std::to_string(median_flow_deg) + " deg)");
    result->times.motion_ms = msSince(start);
    return;
  }

  const Initialization init = initializer_.initialize(match_ids_, px_ref_, px_cur_, K_);
  result->times.motion_ms = msSince(start);
  if (!init.valid) {
    holdPose(result, "initialisation rejected: " + init.reason);
    if (init.ill_conditioned) {
      // The reference's tracks only get fewer: they will not determine the motion later either. This frame's
      // tracks (with the new detections) may.
      result->message += "; reference moved";
      snapshotCurrent(timestamp_s_, result->T_world_cam, &reference_);
    }
    return;
  }
  const Clock::time_point mapping_start = Clock::now();
  // The scale of the new map: metres from the altimeter when it gives them (and the trajectory so far is
  // metric too), else the bridge from the old map (a recovery), else the unit baseline (the first map).
  const AltimeterScaleFix fix = config_.altimeter.enabled ? initialMapScale(init) : AltimeterScaleFix();
  double scale = 1.0;
  std::string scale_note;
  if (fix.valid && (!recovering || metric_scale_)) {
    scale = fix.metres_per_map_unit;
    scale_confidence_ = 1.0;
    metric_scale_ = true;
    scale_source_ = ScaleSource::kAltimeter;
    scale_note = ", metric scale from the altimeter: " + std::to_string(fix.measured_range_m) + " m over " +
                 std::to_string(fix.prediction.range) + " baselines (1-sigma " +
                 std::to_string(100.0 * fix.relative_sigma) + " %)";
  } else if (double imu_scale = std::numeric_limits<double>::quiet_NaN();
             inertialActive() && (!recovering || metric_scale_) &&
             std::isfinite(imu_scale = inertialMapScale(init, &scale_note))) {
    scale = imu_scale;
    scale_confidence_ = 1.0;
    metric_scale_ = true;
    scale_source_ = ScaleSource::kImu;
    scale_note = ", metric scale from the IMU baseline: " + std::to_string(scale) + " m" +
                 (fix.valid || !config_.altimeter.enabled ? "" : " (altimeter: " + fix.reason + ")");
  } else if (recovering) {
    const ScaleBridge bridge = bridgeScale(map_, camera_, reference_.T_world_cam, reference_.timestamp_s,
                                           timestamp_s_, init, first_map_depth_);
    scale = bridge.scale;
    scale_confidence_ *= bridge.confidence_factor;
    scale_note = std::string(", scale bridged by ") + toString(bridge.source) +
                 (bridge.detail.empty() ? "" : " (" + bridge.detail + ")");
  } else {
    scale_confidence_ = 1.0;
    if (config_.altimeter.enabled) scale_note = ", no metric scale yet (" + fix.reason + ")";
  }

  if (!recovering) first_map_depth_ = scale * init.median_depth;
  const Pose T_world_ref = reference_.T_world_cam;
  const Pose T_world_cur = T_world_ref * scaledInverse(init.motion.T_c2_c1_unit, scale);
  if (const std::optional<NavState> carried = newestInertialState()) carried_inertial_ = carried;
  if (auto carried = newestCovariance()) carried_covariance_ = carried;
  map_.clear();
  discardKeyframeTracking();
  keyframe_tracker_.reset();
  const uint64_t kf_ref =
      map_.addKeyframe(reference_.timestamp_s, T_world_ref, reference_.track_ids, reference_.px);
  const uint64_t kf_cur = map_.addKeyframe(timestamp_s_, T_world_cur, track_ids_, px_);
  ++keyframes_since_start_;  // the reference keyframe is a pose the chain already had
  map_drift_.addKeyframe();
  if (fix.valid && metric_scale_ && scale_source_ == ScaleSource::kAltimeter)
    startMapDrift(T_world_cur.translation(), fix.relative_sigma);
  for (size_t i = 0; i < init.points_c1.size(); ++i) {
    map_.addPoint(init.track_ids[i], T_world_ref * (scale * init.points_c1[i]),
                  {{kf_ref, init.px1[i]}, {kf_cur, init.px2[i]}});
  }
  attachInertialState(kf_ref, result);
  attachInertialState(kf_cur, result);
  remove_ids_.clear();
  for (size_t i = 0; i < match_ids_.size(); ++i)
    if (i < init.motion.inlier_mask.size() && init.motion.inlier_mask[i] == 0)
      remove_ids_.push_back(match_ids_[i]);
  tracker_.removeTracks(remove_ids_);

  result->T_world_cam = T_world_cur;
  result->state = recovering ? TrackingState::kRecovered : TrackingState::kTracking;
  result->motion = init.motion.model;
  result->num_inliers = init.motion.num_inliers;
  result->is_keyframe = true;
  result->message =
      std::string(recovering ? "re-initialised" : "initialised") + " (" + toString(init.motion.model) + ", " +
      std::to_string(init.points_c1.size()) + " points" +
      (init.rival_points > 0 ? ", rival motion " + std::to_string(init.rival_points) : std::string()) +
      (init.rival_cost_ratio > 0.0
           ? " at " + std::to_string(init.rival_cost_ratio).substr(0, 4) + "x the cost"
           : std::string()) +
      (init.motion.resolved_by_prior ? ", homography ambiguity resolved by the normal prior" : "") +
      ", rotation 1-sigma " + std::to_string(init.conditioning.rotation_sigma_deg).substr(0, 5) +
      " deg at 1 px" + scale_note + ")";
  stage_ = PipelineStage::kTracking;
  failed_frames_ = 0;
  frames_since_keyframe_ = 0;
  reference_.valid = false;
  snapshotCurrent(timestamp_s_, T_world_cur, &last_good_);
  result->times.mapping_ms = msSince(mapping_start);
}

void Pipeline::trackAgainstMap(FrameResult* result) {
  const Clock::time_point start = Clock::now();
  assoc_.clear();
  for (size_t i = 0; i < track_ids_.size(); ++i) {
    const MapPoint* p = map_.pointForTrack(track_ids_[i]);
    if (p == nullptr) continue;
    assoc_.p_world.push_back(p->p_world);
    assoc_.px.push_back(px_[i]);
    assoc_.track_ids.push_back(track_ids_[i]);
    assoc_.point_ids.push_back(p->id);
  }
  const Pose predicted = predictPose();
  pnp_tracker_.setRobustLossScale(adjustmentConfig(*result).robust_loss_scale_px);
  const PnpTrackResult pnp = pnp_tracker_.track(assoc_.p_world, assoc_.px, K_, &predicted);
  assoc_.inlier.assign(assoc_.size(), 0);
  if (pnp.valid) assoc_.inlier = pnp.inlier_mask;
  for (size_t i = 0; i < assoc_.size(); ++i) {
    MapPoint* p = map_.point(assoc_.point_ids[i]);
    ++p->times_visible;
    if (assoc_.inlier[i]) ++p->times_found;
  }
  result->times.motion_ms = msSince(start);
  if (!pnp.valid) {
    ++failed_frames_;
    result->state = TrackingState::kLost;
    holdPose(result, "tracking failed: " + pnp.reason);
    return;
  }
  // A track that disagrees with the map has drifted (or the point is wrong): it stops carrying the point, and
  // the tracker drops it so that its grid cell gets a fresh feature.
  remove_ids_.clear();
  for (size_t i = 0; i < assoc_.size(); ++i) {
    if (assoc_.inlier[i]) continue;
    map_.detachTrack(assoc_.track_ids[i]);
    remove_ids_.push_back(assoc_.track_ids[i]);
  }
  tracker_.removeTracks(remove_ids_);

  failed_frames_ = 0;
  result->T_world_cam = pnp.T_world_cam;
  result->state = TrackingState::kTracking;
  result->motion = MotionEstimate::kPnp;
  result->num_inliers = pnp.num_inliers;
  result->pose_from_prediction = pnp.from_prediction;
  snapshotCurrent(timestamp_s_, pnp.T_world_cam, &last_good_);
}

void Pipeline::filterPublishedPose(FrameResult* result) {
  if (!config_.motion_filter.enabled || config_.imu.enabled ||
      config_.pipeline.trajectory_mode != TrajectoryMode::kMap)
    return;
  if (result->state != TrackingState::kTracking || result->motion != MotionEstimate::kPnp) {
    // A lost frame coasts and the filter predicts over the gap; a new map (initialising, recovered) is
    // another frame of reference.
    if (result->state != TrackingState::kLost) motion_filter_.reset();
    return;
  }
  if (metric_scale_ != motion_filter_metric_scale_) {
    motion_filter_.reset();
    motion_filter_metric_scale_ = metric_scale_;
  }
  const PoseMeasurement m = poseMeasurement(
      timestamp_s_, result->T_world_cam, assoc_.p_world, assoc_.px, assoc_.inlier, camera_.fx(), camera_.fy(),
      camera_.cx(), camera_.cy(), config_.motion_filter.min_pixel_sigma_px, &scratch_);
  if (!m.valid) {
    motion_filter_.reset();
    return;
  }
  const FilteredPose filtered = motion_filter_.update(m);
  result->T_world_cam = filtered.T_world_cam;
  result->filtered_motion = filtered.motion;
  frame_pose_covariance_ = m.covariance;
}

void Pipeline::addMapDriftToAltimeterOutput(FrameResult* result) {
  // In metres (vision + altimeter) the pose and velocity are the navigation's, and guidance reads their
  // covariance: the frame's own (how well it sits in the map: the last frame measured, for a frame that
  // coasts) plus the map's drift (how well the map sits in the world), which the filter, posed against the
  // map at every frame, cannot see. A frame that coasts gets it too, so that its covariance does not shrink
  // (the nodelet inflates it further as not confident).
  if (inertialActive() || !metric_scale_ || !map_drift_.running() || !config_.motion_filter.enabled ||
      config_.pipeline.trajectory_mode != TrajectoryMode::kMap || frame_pose_covariance_.isZero())
    return;
  map_drift_.moveTo(result->T_world_cam.translation());
  result->has_covariance = true;
  result->covariance.setZero();
  result->covariance.topLeftCorner<6, 6>() = frame_pose_covariance_;
  FilteredMotion& motion = result->filtered_motion;
  if (!motion.valid) {
    result->covariance.bottomRightCorner<3, 3>() = kUnknownVelocityVariance * Eigen::Matrix3d::Identity();
    map_drift_.addTo(&result->covariance, nullptr);
    return;
  }
  result->covariance.bottomRightCorner<3, 3>() = motion.v_covariance;
  map_drift_.addTo(&result->covariance, &motion.v_world);
  motion.v_covariance = result->covariance.bottomRightCorner<3, 3>();
  motion.map_scale_relative_sigma = map_drift_.relativeScaleSigma();
  motion.map_attitude_sigma_rad = map_drift_.attitudeSigmaRad();
}

void Pipeline::startMapDrift(const Eigen::Vector3d& c_world_m, double relative_scale_sigma) {
  if (inertialActive()) return;  // addMapDriftToInertialOutput()
  if (map_drift_.running()) {    // a new fix of a map that was metric already: the drift goes on
    map_drift_.setScaleSigma(relative_scale_sigma);
    return;
  }
  MapDrift::Matrix6d start = MapDrift::Matrix6d::Zero();
  if (initial_pose_given_) {  // the handed-over pose's claimed uncertainty; else the world is the first
                              // camera
    start.topLeftCorner<3, 3>().diagonal().setConstant(std::pow(config_.imu.initial_position_sigma_m, 2));
    start.bottomRightCorner<3, 3>().diagonal().setConstant(
        std::pow(config_.imu.initial_attitude_sigma_deg * M_PI / 180.0, 2));
  }
  map_drift_.start(T_world_cam_initial_.translation(), c_world_m, keyframes_since_start_,
                   relative_scale_sigma, start);
}

void Pipeline::startRecovery() {
  stage_ = PipelineStage::kRecovering;
  failed_frames_ = 0;
  // The old map stays until the new one exists: the scale bridge needs it.
  reference_ = last_good_;
  if (!reference_.valid) snapshotCurrent(timestamp_s_, predictPose(), &reference_);
}

void Pipeline::maybeInsertKeyframe(FrameResult* result) {
  ++frames_since_keyframe_;
  const Keyframe& last = map_.keyframes().back();
  bearings_kf_.clear();
  bearings_cur_.clear();
  for (size_t i = 0; i < track_ids_.size(); ++i) {
    auto it = last.px_by_track.find(track_ids_[i]);
    if (it == last.px_by_track.end()) continue;
    bearings_kf_.push_back(camera_.pixelToBearing(it->second));
    bearings_cur_.push_back(camera_.pixelToBearing(px_[i]));
  }
  const Eigen::Matrix3d R_cur_kf = result->T_world_cam.linear().transpose() * last.T_world_cam.linear();
  KeyframeCandidate candidate;
  candidate.frames_since_keyframe = frames_since_keyframe_;
  candidate.tracks_at_keyframe = last.num_frame_tracks;  // not its map-only tracks
  candidate.surviving_tracks = static_cast<int>(bearings_kf_.size());
  candidate.median_parallax_deg =
      KeyframePolicy::medianParallaxDeg(bearings_kf_, bearings_cur_, R_cur_kf, &scratch_);
  const KeyframeDecision decision = keyframe_policy_.decide(candidate);
  if (!decision.is_keyframe) return;
  result->is_keyframe = true;
  result->message = "keyframe (" + decision.reason + ")";
  insertKeyframe(result);
}

void Pipeline::insertKeyframe(FrameResult* result) {
  // The adjustment of the last keyframe, when not taken yet (collect_after_images > 1): taken now, before
  // this keyframe joins the map, and this frame's pose refined again against the adjusted points so that the
  // new keyframe agrees with the adjusted ones. Its pose time then includes both.
  if (images_since_ba_submit_ >= 0) {
    applyAsyncBundleAdjustment(result);
    refinePoseAgainstMap(result);
    result->times.pose_ms = msSince(frame_start_);
  }
  const Clock::time_point start = Clock::now();
  ++keyframes_since_start_;
  map_drift_.addKeyframe();
  KeyframeTracks keyframe_tracks;
  std::string keyframe_note;
  const bool with_map_only = config_.map.keyframe_features > 0 && !current_image_.empty();
  // The map-only features (keyframe_tracker.h), predicted by the frame tracks' motion since the last
  // keyframe (distorted pixels, in track_ids_ order).
  std::vector<cv::Point2f> live_px;
  if (with_map_only) {
    live_px.resize(track_ids_.size());
    for (size_t k = 0; k < track_ids_.size(); ++k) live_px[k] = distorted_px_[order_[k]];
  }
  const bool in_background = with_map_only && async_ba_ != nullptr;
  if (in_background) {
    // With the optimiser in its own thread, so are they: tracked while the next images are processed and
    // joined to this keyframe just before the next keyframe is inserted (collectKeyframeTracking()), so that
    // they cost the tracking path nothing. No frame's pose uses them; the bundle adjustment of the next
    // keyframe is the first to (at the keyframe, this keyframe's adjustment would have: docs/visual_core.md
    // step 10 measures the difference).
    collectKeyframeTracking(result);  // those of the last keyframe
  } else if (with_map_only) {
    const KeyframeTrackingResult tracked = keyframe_tracker_.track(current_image_, track_ids_, live_px);
    keyframe_tracks = idealKeyframeTracks();
    result->times.keyframe_tracking_ms = tracked.ms;
    keyframe_note = "; map-only tracks " + describeKeyframeTracking(tracked);
  }
  const KeyframeInsertion insertion =
      mapper_.insertKeyframe(timestamp_s_, result->T_world_cam, track_ids_, px_, assoc_, camera_, &map_,
                             with_map_only && !in_background ? &keyframe_tracks : nullptr);
  if (in_background) {
    // Started once the keyframe is in the map, so that the job and its keyframe id go together.
    keyframe_job_keyframe_id_ = insertion.keyframe_id;
    keyframe_job_ = std::async(std::launch::async,
                               [this, image = current_image_.clone(), ids = track_ids_,
                                px = std::move(live_px)] { return keyframe_tracker_.track(image, ids, px); });
  } else {
    keyframe_tracker_.removeTracks(insertion.rejected_keyframe_tracks);
  }
  frames_since_keyframe_ = 0;
  result->message +=
      ": +" + std::to_string(insertion.points_created) + " points, -" +
      std::to_string(insertion.points_culled) + " culled" + keyframe_note +
      (keyframe_note.empty()
           ? std::string()
           : ", " + std::to_string(insertion.keyframe_track_observations) + " observe their point, " +
                 std::to_string(insertion.rejected_keyframe_tracks.size()) + " rejected");
  if (config_.altimeter.enabled) {
    if (const std::optional<AltimeterSample> reading = altimeter_.readingAt(timestamp_s_))
      map_.keyframe(insertion.keyframe_id)->altimeter_range_m = reading->slant_range_m;
    if (!metric_scale_) tryMetricScaleAtKeyframe(result);
  }
  attachInertialState(insertion.keyframe_id, result);
  // No inertial state yet (no handed-over velocity), or the chain broke at an IMU gap: align again over the
  // keyframes since (the gravity direction and the scale are known by then).
  if (config_.imu.enabled && !map_.keyframes().back().has_inertial_state) tryInertialAlignment(result);
  result->times.mapping_ms = msSince(start);
  runBundleAdjustment(result);
}

AltimeterScaleFix Pipeline::initialMapScale(const Initialization& init) const {
  // In the reference camera's frame at unit baseline: the current camera sits at T_c1_c2.
  return altimeter_.scaleAt(timestamp_s_, init.points_c1, init.motion.T_c2_c1_unit.inverse());
}

void Pipeline::tryMetricScaleAtKeyframe(FrameResult* result) {
  std::vector<Eigen::Vector3d> points_world;
  points_world.reserve(map_.numPoints());
  for (const auto& entry : map_.points()) points_world.push_back(entry.second.p_world);
  const AltimeterScaleFix fix = altimeter_.scaleAt(timestamp_s_, points_world, result->T_world_cam);
  if (!fix.valid) return;
  // Scale about where the trajectory started, so that the initial pose handed over stays where it was.
  const Eigen::Vector3d centre = T_world_cam_initial_.translation();
  const double s = fix.metres_per_map_unit;
  map_.scaleAbout(centre, s);
  first_map_depth_ *= s;
  auto scaled = [&](Pose T) {
    T.translation() = centre + s * (T.translation() - centre);
    return T;
  };
  result->T_world_cam = scaled(result->T_world_cam);
  last_good_.T_world_cam = scaled(last_good_.T_world_cam);
  if (reference_.valid) reference_.T_world_cam = scaled(reference_.T_world_cam);
  metric_scale_ = true;
  scale_source_ = ScaleSource::kAltimeter;
  startMapDrift(result->T_world_cam.translation(), fix.relative_sigma);
  result->message += "; metric scale from the altimeter: x" + std::to_string(s) + " (1-sigma " +
                     std::to_string(100.0 * fix.relative_sigma) + " %)";
}

std::vector<BaRangeObservation> Pipeline::altimeterRanges() const {
  std::vector<BaRangeObservation> ranges;
  const auto& kfs = map_.keyframes();
  if (!config_.altimeter.enabled || !metric_scale_ || kfs.size() < 2) return ranges;
  const size_t window = std::min(kfs.size(), static_cast<size_t>(config_.bundle_adjustment.window_keyframes));
  std::vector<Eigen::Vector3d> points_world;
  std::vector<uint64_t> point_ids;
  points_world.reserve(map_.numPoints());
  for (const auto& entry : map_.points()) {
    points_world.push_back(entry.second.p_world);
    point_ids.push_back(entry.first);
  }
  std::vector<std::pair<double, size_t>> by_distance;
  for (size_t i = kfs.size() - window + 1; i < kfs.size(); ++i) {
    const Keyframe& kf = kfs[i];
    if (!std::isfinite(kf.altimeter_range_m)) continue;
    const RangePrediction prediction =
        predictRange(points_world, {}, kf.T_world_cam, altimeter_.config().mounting);
    if (!prediction.valid()) continue;
    BaRangeObservation r;
    r.keyframe_id = kf.id;
    r.plane = prediction.plane;
    // The plane's support in the solve: the map points nearest the beam's hit that lie on the plane (within
    // 3 roughness, at least 1 % of the range).
    const double on_plane = std::max(3.0 * prediction.plane.roughness, 0.01 * prediction.range);
    by_distance.clear();
    for (size_t j = 0; j < points_world.size(); ++j) {
      if (std::abs(prediction.plane.normal_world.dot(points_world[j] - prediction.plane.centroid_world)) >
          on_plane)
        continue;
      by_distance.emplace_back((points_world[j] - prediction.hit_world).squaredNorm(), j);
    }
    const size_t num_support = std::min(by_distance.size(), kRangeSupportPoints);
    if (num_support < 3) continue;
    std::partial_sort(by_distance.begin(), by_distance.begin() + static_cast<std::ptrdiff_t>(num_support),
                      by_distance.end());
    for (size_t m = 0; m < num_support; ++m) r.support_point_ids.push_back(point_ids[by_distance[m].second]);
    r.mounting = altimeter_.config().mounting;
    r.measured_range_m = kf.altimeter_range_m;
    r.sigma_m = altimeterResidualSigmaM(altimeter_.config().noise, kf.altimeter_range_m, prediction);
    ranges.push_back(r);
  }
  return ranges;
}

BundleAdjustmentConfig Pipeline::adjustmentConfig(const FrameResult& frame) const {
  BundleAdjustmentConfig config = config_.bundle_adjustment;
  if (frame.anchor_alignment) config.robust_loss_scale_px = config.robust_loss_scale_aligned_px;
  return config;
}

void Pipeline::runBundleAdjustment(FrameResult* result) {
  if (!config_.bundle_adjustment.enabled) return;
  const Clock::time_point start = Clock::now();
  // The covariance of the previous window (computed by the worker after that solve) before this window's
  // anchor needs it.
  if (async_ba_)
    if (const auto covariances = async_ba_->takeCovariance()) map_.applyCovariances(*covariances);
  const std::vector<BaRangeObservation> ranges = altimeterRanges();
  // (With the IMU the scale is held by the accelerometer as well: the drift's scale term stays zero.)
  if (!ranges.empty() && !inertialActive()) map_drift_.setScaleSigma(medianRelativeRangeSigma(ranges));
  // The window with `num_fixed` oldest keyframes fixed, and the ranges of its free keyframes.
  auto makeProblem = [&](int num_fixed) {
    BaProblem p = map_.makeBaProblem(config_.bundle_adjustment.window_keyframes, num_fixed, camera_.fx(),
                                     camera_.fy(), camera_.cx(), camera_.cy());
    for (const BaRangeObservation& r : ranges) {
      const auto kf = std::find_if(p.keyframes.begin(), p.keyframes.end(),
                                   [&r](const BaKeyframe& k) { return k.id == r.keyframe_id; });
      if (kf != p.keyframes.end() && !kf->fixed) p.ranges.push_back(r);
    }
    addInertialFactors(&p);
    return p;
  };
  // Gauge policy: the ranges hold the scale when at least two free keyframes carry one, the IMU factors
  // (gravity and the accelerometer) whenever there is one; then only the oldest keyframe stays fixed.
  auto scaleHeld = [](const BaProblem& p) {
    return p.ranges.size() >= kMinRangeFactorsForScale || !p.inertial.constraints.empty();
  };
  const bool may_hold_scale =
      ranges.size() >= kMinRangeFactorsForScale || (inertialActive() && metric_scale_);
  BaProblem problem = makeProblem(may_hold_scale ? kNumFixedBaKeyframesWithRanges : kNumFixedBaKeyframes);
  if (may_hold_scale && !scaleHeld(problem)) problem = makeProblem(kNumFixedBaKeyframes);
  const bool has_free_pose = std::any_of(problem.keyframes.begin(), problem.keyframes.end(),
                                         [](const BaKeyframe& k) { return !k.fixed; });
  if (!has_free_pose || problem.points.empty()) return;
  if (async_ba_) {
    async_ba_->submit(std::move(problem), adjustmentConfig(*result));
    images_since_ba_submit_ = 0;
    result->times.ba_ms += msSince(start);
    return;
  }
  const BaSummary summary = adjustBundle(&problem, adjustmentConfig(*result));
  result->times.optimiser_ms = summary.solve_cpu_ms;
  if (summary.converged) {
    const int removed = applyAdjustment(problem, summary.outliers);
    // The current frame is the newest keyframe: report its adjusted pose.
    result->T_world_cam = map_.keyframes().back().T_world_cam;
    last_good_.T_world_cam = result->T_world_cam;
    result->message += "; BA " + std::to_string(summary.initial_rms_px).substr(0, 5) + " -> " +
                       std::to_string(summary.final_rms_px).substr(0, 5) + " px, -" + std::to_string(removed);
  }
  result->times.ba_ms += msSince(start);
}

int Pipeline::applyAdjustment(const BaProblem& problem, const std::vector<BaObservation>& outliers) {
  const uint64_t newest_id = map_.keyframes().back().id;
  const Pose T_world_newest_before = map_.keyframes().back().T_world_cam;
  const int removed = map_.applyBaResult(problem, outliers);
  // The filter of the published pose moves by the move of the newest keyframe (the frames are posed mostly
  // against its points; with the optimiser inline it is this frame), so that the frame posed against the
  // moved map does not read the move as motion (docs/visual_core.md step 17).
  if (config_.motion_filter.move_with_map)
    if (const Keyframe* after = map_.keyframe(newest_id))
      motion_filter_.moveWithMap(after->T_world_cam * T_world_newest_before.inverse());
  return removed;
}

void Pipeline::refinePoseAgainstMap(FrameResult* result) {
  // The associations of trackAgainstMap() with the points as they are now; points the adjustment removed
  // leave.
  size_t kept = 0;
  for (size_t i = 0; i < assoc_.size(); ++i) {
    const MapPoint* p = map_.point(assoc_.point_ids[i]);
    if (p == nullptr) continue;
    assoc_.p_world[kept] = p->p_world;
    assoc_.px[kept] = assoc_.px[i];
    assoc_.track_ids[kept] = assoc_.track_ids[i];
    assoc_.point_ids[kept] = assoc_.point_ids[i];
    assoc_.inlier[kept] = assoc_.inlier[i];
    ++kept;
  }
  assoc_.p_world.resize(kept);
  assoc_.px.resize(kept);
  assoc_.track_ids.resize(kept);
  assoc_.point_ids.resize(kept);
  assoc_.inlier.resize(kept);
  const Pose before = result->T_world_cam;
  pnp_tracker_.setRobustLossScale(adjustmentConfig(*result).robust_loss_scale_px);
  const PnpTrackResult pnp = pnp_tracker_.track(assoc_.p_world, assoc_.px, K_, &before);
  if (!pnp.valid) return;  // the pose against the map before the adjustment stands
  result->T_world_cam = pnp.T_world_cam;
  result->num_inliers = pnp.num_inliers;
  assoc_.inlier = pnp.inlier_mask;
  snapshotCurrent(timestamp_s_, pnp.T_world_cam, &last_good_);
}

KeyframeTracks Pipeline::idealKeyframeTracks() const {
  KeyframeTracks tracks;
  tracks.ids = keyframe_tracker_.ids();
  const std::vector<cv::Point2f>& distorted = keyframe_tracker_.px();
  const std::vector<cv::Point2f> ideal =
      camera_.hasDistortion() ? camera_.undistortPixels(distorted) : distorted;
  tracks.px.resize(ideal.size());
  for (size_t i = 0; i < ideal.size(); ++i) tracks.px[i] = Eigen::Vector2d(ideal[i].x, ideal[i].y);
  return tracks;
}

void Pipeline::collectKeyframeTracking(FrameResult* result) {
  if (!keyframe_job_.valid()) return;
  auto note = [result](const std::string& text) {
    result->message += (result->message.empty() ? "" : "; ") + text;
  };
  KeyframeTrackingResult tracked;
  try {
    tracked = keyframe_job_.get();
  } catch (const std::exception& e) {
    // A fault of the background tracking stays there: its tracks are dropped (the tracker starts again at
    // the next keyframe) and the frame says so.
    keyframe_tracker_.reset();
    note(std::string("map-only tracking failed in the background (") + e.what() + "): its tracks dropped");
    return;
  }
  result->times.keyframe_tracking_ms = tracked.ms;
  if (map_.keyframes().empty() || map_.keyframes().back().id != keyframe_job_keyframe_id_) {
    keyframe_tracker_.reset();  // its keyframe left the map (cannot happen while the map is kept)
    note("map-only tracks of a keyframe no longer in the map: dropped");
    return;
  }
  const KeyframeInsertion attached =
      mapper_.attachKeyframeTracks(keyframe_job_keyframe_id_, idealKeyframeTracks(), camera_, &map_);
  keyframe_tracker_.removeTracks(attached.rejected_keyframe_tracks);
  note("map-only tracks of the last keyframe " + describeKeyframeTracking(tracked) + ": +" +
       std::to_string(attached.points_created) + " points, " +
       std::to_string(attached.keyframe_track_observations) + " observe their point, " +
       std::to_string(attached.rejected_keyframe_tracks.size()) + " rejected");
}

void Pipeline::discardKeyframeTracking() {
  if (!keyframe_job_.valid()) return;
  try {
    keyframe_job_.get();
  } catch (const std::exception&) {
    // discarded with its result
  }
}

void Pipeline::applyAsyncBundleAdjustment(FrameResult* result) {
  images_since_ba_submit_ = -1;
  if (!async_ba_) return;
  const Clock::time_point start = Clock::now();
  // Waiting for the adjustment here, rather than taking it whenever it happens to be ready, makes every
  // result land at the same frame on every run: offline runs stay reproducible, and in real time (an image
  // every 100 ms against a ~10 ms adjustment) the wait is zero.
  async_ba_->waitIdle();
  std::optional<std::pair<BaProblem, BaSummary>> finished;
  try {
    finished = async_ba_->takeResult();
  } catch (const std::exception& e) {
    // A fault of the optimiser thread stays there: its result is discarded, the map keeps the poses it had
    // (the next keyframe submits a new adjustment), and the frame says so.
    result->message += std::string(result->message.empty() ? "" : "; ") +
                       "bundle adjustment failed in the optimiser thread (" + e.what() +
                       "): result discarded";
    return;
  }
  if (finished) result->times.optimiser_ms = finished->second.solve_cpu_ms;
  if (!finished || !finished->second.converged) return;
  applyAdjustment(finished->first, finished->second.outliers);  // the next frame is posed against it
  result->times.ba_ms += msSince(start);
}

}  // namespace planetary_vo

// ---------------------------------------------------------------------------------------------------------------
// Camera + IMU.

namespace planetary_vo {

std::optional<NavState> Pipeline::inertialStateNow() const {
  const std::optional<NavState> from = newestInertialState();
  if (!from || timestamp_s_ < from->timestamp_s || timestamp_s_ - from->timestamp_s > kMaxInertialBridgeS)
    return std::nullopt;
  return inertial_.propagate(*from, timestamp_s_);
}

std::optional<std::pair<NavState, Eigen::Matrix<double, 9, 9>>> Pipeline::newestCovariance() const {
  const auto& kfs = map_.keyframes();
  for (auto it = kfs.rbegin(); it != kfs.rend(); ++it)
    if (it->has_inertial_state && it->has_covariance)
      return std::make_pair(
          inertial_.bodyState(it->timestamp_s, it->T_world_cam, it->v_world_mps, it->imu_bias),
          it->covariance);
  return carried_covariance_;
}

void Pipeline::tryInertialAlignment(FrameResult* result) {
  // At least this many keyframes over at least this long: the accelerometer must see the motion change.
  constexpr size_t kMinKeyframes = 5;
  constexpr double kMinSpanS = 2.0;
  const auto& kfs = map_.keyframes();
  // The newest run of keyframes that the IMU covers without a gap.
  size_t first = kfs.size();
  std::vector<std::shared_ptr<const ImuPreintegration>> pre;
  while (first > 0) {
    if (first < kfs.size()) {
      auto p = inertial_.preintegrate(kfs[first - 1].timestamp_s, kfs[first].timestamp_s, ImuBias());
      if (!p) break;
      pre.insert(pre.begin(), p);
    }
    --first;
  }
  if (kfs.size() - first < kMinKeyframes || kfs.back().timestamp_s - kfs[first].timestamp_s < kMinSpanS)
    return;
  InertialAlignmentInput in;
  for (size_t k = first; k < kfs.size(); ++k) {
    in.timestamps_s.push_back(kfs[k].timestamp_s);
    in.T_map_cam.push_back(kfs[k].T_world_cam);
  }
  in.preintegrations = pre;
  in.T_cam_imu = inertial_.T_cam_imu();
  in.gravity_mps2 = config_.imu.gravity_mps2;
  const bool world_aligned = initial_pose_given_ || gravity_aligned_;
  if (world_aligned) in.known_gravity_map = inertial_.gravityWorld();
  in.known_scale = metric_scale_;
  in.gyro_bias_prior_sigma_radps = config_.imu.gyro_turn_on_bias_radps;
  const InertialAlignment a = alignVisualInertial(in);
  if (!a.valid) {
    result->message += "; visual-inertial alignment not yet: " + a.reason;
    return;
  }
  // The map frame turned gravity-aligned (unless it was: handed-over pose) and metric, about the first camera
  // (the initial pose); yaw stays the map's.
  const Eigen::Vector3d centre = T_world_cam_initial_.translation();
  const Eigen::Matrix3d R = world_aligned ? Eigen::Matrix3d::Identity()
                                          : Eigen::Quaterniond::FromTwoVectors(a.gravity_map.normalized(),
                                                                               -Eigen::Vector3d::UnitZ())
                                                .toRotationMatrix();
  map_.transformAbout(centre, R, a.scale);
  first_map_depth_ *= a.scale;
  auto moved = [&](Pose T) {
    T.translation() = centre + a.scale * R * (T.translation() - centre);
    T.linear() = R * T.linear();
    return T;
  };
  result->T_world_cam = moved(result->T_world_cam);
  if (last_good_.valid) last_good_.T_world_cam = moved(last_good_.T_world_cam);
  if (reference_.valid) reference_.T_world_cam = moved(reference_.T_world_cam);
  ImuBias bias;
  bias.gyro_radps = a.gyro_bias_radps;
  for (size_t k = first; k < kfs.size(); ++k) {
    Keyframe* kf = map_.keyframe(kfs[k].id);
    kf->has_inertial_state = true;
    kf->v_world_mps = R * a.velocities_map_mps[k - first];
    kf->imu_bias = bias;
    if (k > first)
      kf->imu_from_previous = inertial_.preintegrate(kfs[k - 1].timestamp_s, kf->timestamp_s, bias);
  }
  if (!metric_scale_) scale_source_ = ScaleSource::kImu;
  metric_scale_ = true;
  gravity_aligned_ = true;
  scale_confidence_ = 1.0;
  result->message += "; visual-inertial alignment over " + std::to_string(kfs.size() - first) +
                     " keyframes: scale x" + std::to_string(a.scale) + " (1-sigma " +
                     std::to_string(100.0 * a.scale_sigma) + " %), gyro bias " +
                     std::to_string(a.gyro_bias_radps.norm()) + " rad/s" +
                     (world_aligned ? "" : ", world turned gravity-aligned");
}

void Pipeline::keepNavState(const FrameResult& result) {
  if (result.has_velocity)
    last_nav_state_ =
        inertial_.bodyState(timestamp_s_, result.T_world_cam, result.v_world_mps, result.imu_bias);
  else
    last_nav_state_.reset();
}

std::optional<NavState> Pipeline::navStateAt(double t_s) const {
  if (!last_nav_state_ || t_s < last_nav_state_->timestamp_s) return std::nullopt;
  return inertial_.propagate(*last_nav_state_, t_s);
}

std::optional<NavState> Pipeline::newestInertialState() const {
  const auto& kfs = map_.keyframes();
  for (auto it = kfs.rbegin(); it != kfs.rend(); ++it)
    if (it->has_inertial_state)
      return inertial_.bodyState(it->timestamp_s, it->T_world_cam, it->v_world_mps, it->imu_bias);
  return carried_inertial_;
}

void Pipeline::attachInertialState(uint64_t keyframe_id, FrameResult* result) {
  if (!inertialActive() || !metric_scale_) return;
  const auto& kfs = map_.keyframes();
  const auto at =
      std::find_if(kfs.begin(), kfs.end(), [&](const Keyframe& k) { return k.id == keyframe_id; });
  if (at == kfs.end()) return;
  const Keyframe* previous = at == kfs.begin() ? nullptr : &*(at - 1);
  Keyframe* kf = map_.keyframe(keyframe_id);
  std::optional<NavState> from;
  if (previous != nullptr && previous->has_inertial_state)
    from = inertial_.bodyState(previous->timestamp_s, previous->T_world_cam, previous->v_world_mps,
                               previous->imu_bias);
  else
    from = carried_inertial_;
  if (!from || from->timestamp_s > kf->timestamp_s) return;
  if (kf->timestamp_s - from->timestamp_s > kMaxInertialBridgeS) {
    result->message += "; IMU: no inertial state within " + std::to_string(kMaxInertialBridgeS) + " s";
    return;
  }
  const std::optional<NavState> state = inertial_.propagate(*from, kf->timestamp_s);
  if (!state) {
    result->message +=
        "; IMU not used at this keyframe: " + inertial_.coverageProblem(from->timestamp_s, kf->timestamp_s);
    return;
  }
  kf->has_inertial_state = true;
  kf->v_world_mps = state->v_world_mps;
  kf->imu_bias = from->bias();
  if (previous != nullptr && previous->has_inertial_state)
    kf->imu_from_previous =
        inertial_.preintegrate(previous->timestamp_s, kf->timestamp_s, previous->imu_bias);
}

double Pipeline::inertialMapScale(const Initialization& init, std::string* why) const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::optional<NavState> from = newestInertialState();
  const double t_ref = reference_.timestamp_s, t_cur = timestamp_s_;
  if (!from) {
    *why = ", no IMU scale (no inertial state: hand over the initial velocity)";
    return nan;
  }
  if (t_ref < from->timestamp_s || t_cur - from->timestamp_s > kMaxInertialBridgeS) {
    *why = ", no IMU scale (the inertial state is not within the IMU's reach)";
    return nan;
  }
  const std::optional<NavState> at_ref = inertial_.propagate(*from, t_ref);
  const std::optional<NavState> at_cur = at_ref ? inertial_.propagate(*at_ref, t_cur) : std::nullopt;
  if (!at_cur) {
    *why = ", no IMU scale (" + inertial_.coverageProblem(from->timestamp_s, t_cur) + ")";
    return nan;
  }
  const double baseline_m =
      (inertial_.cameraPose(*at_cur).translation() - inertial_.cameraPose(*at_ref).translation()).norm();
  const double unit = init.motion.T_c2_c1_unit.translation().norm();
  // The baseline error an accelerometer bias of the turn-on sigma causes over the propagation.
  const double a = t_ref - from->timestamp_s, b = t_cur - from->timestamp_s;
  const double error_m = 0.5 * config_.imu.accel_turn_on_bias_mps2 * (b * b - a * a);
  if (!(unit > 0.0) || !(baseline_m > 0.0) || error_m > kMaxInertialScaleError * baseline_m) {
    *why = ", no IMU scale (baseline " + std::to_string(baseline_m) + " m, bias error up to " +
           std::to_string(error_m) + " m)";
    return nan;
  }
  return baseline_m / unit;
}

void Pipeline::addInertialFactors(BaProblem* problem) const {
  if (!inertialActive() || !metric_scale_) return;
  BaInertial& inertial = problem->inertial;
  inertial.gravity_world_mps2 = inertial_.gravityWorld();
  inertial.T_cam_imu = inertial_.T_cam_imu();
  const auto& kfs = map_.keyframes();
  const size_t window = std::min(kfs.size(), static_cast<size_t>(config_.bundle_adjustment.window_keyframes));
  auto inProblem = [&](uint64_t id) {
    return std::any_of(problem->keyframes.begin(), problem->keyframes.end(),
                       [id](const BaKeyframe& k) { return k.id == id; });
  };
  const Keyframe* previous = nullptr;  // the keyframe before, when it has a state in the problem
  for (size_t i = kfs.size() - window; i < kfs.size(); ++i) {
    const Keyframe& kf = kfs[i];
    if (!kf.has_inertial_state || !inProblem(kf.id)) {
      previous = nullptr;
      continue;
    }
    inertial.states.push_back({kf.id, kf.v_world_mps, kf.imu_bias});
    if (previous != nullptr && kf.imu_from_previous)
      inertial.constraints.push_back({previous->id, kf.id, kf.imu_from_previous});
    previous = &kf;
  }
  if (inertial.constraints.empty()) {
    inertial.states.clear();
    return;
  }
  // Only states that an IMU factor ties (across a gap a keyframe may have a state but no factor).
  inertial.states.erase(std::remove_if(inertial.states.begin(), inertial.states.end(),
                                       [&](const BaInertialState& st) {
                                         return std::none_of(inertial.constraints.begin(),
                                                             inertial.constraints.end(),
                                                             [&](const BaImuConstraint& c) {
                                                               return c.keyframe_i == st.keyframe_id ||
                                                                      c.keyframe_j == st.keyframe_id;
                                                             });
                                       }),
                        inertial.states.end());
  // The covariance of the window's states, the oldest (held) one released under the covariance it had: its
  // own from an earlier window, else the newest known one moved on to it by the IMU's noise.
  const Keyframe* anchor = map_.keyframe(inertial.states.front().keyframe_id);
  if (anchor->has_covariance) {
    inertial.compute_covariance = true;
    inertial.anchor_covariance = anchor->covariance;
  } else if (const auto known = newestCovariance()) {
    const NavState anchor_state =
        inertial_.bodyState(anchor->timestamp_s, anchor->T_world_cam, anchor->v_world_mps, anchor->imu_bias);
    if (known->first.timestamp_s <= anchor_state.timestamp_s) {
      inertial.compute_covariance = true;
      inertial.anchor_covariance = propagateCovariance(known->second, known->first, anchor_state, config_.imu,
                                                       inertial_.gravityWorld());
    }
  }
  // The oldest state's pose and velocity are held (the gauge: what earlier windows estimated, or what was
  // handed over). Its biases are solved under what the window in which it was the newest estimated, with that
  // window's covariance (which holds the earlier windows' through its own oldest state): under the turn-on
  // sigma re-centred on the estimate so far, as before session 32, they took up the held state's errors at
  // every window and walked (docs/fusion/README.md). With imu.anchor_velocity_prior the velocity is solved
  // under its covariance from that window too, about the estimate so far. Before a covariance is known: the
  // velocity held, the biases under the data sheet's turn-on sigma about the estimate so far.
  BaInertialState& oldest = inertial.states.front();
  oldest.velocity_fixed =
      std::any_of(problem->keyframes.begin(), problem->keyframes.end(),
                  [&](const BaKeyframe& k) { return k.id == oldest.keyframe_id && k.fixed; });
  const bool known =
      anchor->has_covariance && anchor->covariance.allFinite() && anchor->bias_covariance.allFinite();
  const Eigen::Matrix3d velocity_covariance = anchor->covariance.block<3, 3>(6, 6);
  if (config_.imu.anchor_velocity_prior && known && oldest.velocity_fixed &&
      velocity_covariance.llt().info() == Eigen::Success) {
    oldest.velocity_fixed = false;
    oldest.has_velocity_prior = true;
    oldest.velocity_prior_mps = oldest.v_world_mps;
    oldest.velocity_prior_covariance = velocity_covariance;
  }
  // The carried covariance holds the data sheet's turn-on prior once, through the first window of the chain,
  // so it is never looser than that prior. A chain that restarted (after an IMU gap, visual-inertial
  // alignment) had no bias prior in its first windows: until its covariance is within the turn-on sigma in
  // every direction, its biases are held under that sigma about the estimate so far, as before.
  auto withinTurnOn = [&](const Eigen::Matrix<double, 6, 6>& covariance) {
    Eigen::Matrix<double, 6, 1> turn_on_sigma;
    turn_on_sigma << Eigen::Vector3d::Constant(config_.imu.gyro_turn_on_bias_radps),
        Eigen::Vector3d::Constant(config_.imu.accel_turn_on_bias_mps2);
    const Eigen::Matrix<double, 6, 6> relative =
        turn_on_sigma.cwiseInverse().asDiagonal() * covariance * turn_on_sigma.cwiseInverse().asDiagonal();
    constexpr double kMaxVarianceRatio = 1.01;  // measured: at most 1.0000 along a descent (main_brake_down)
    return Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(relative, Eigen::EigenvaluesOnly)
               .eigenvalues()
               .maxCoeff() <= kMaxVarianceRatio;
  };
  if (config_.imu.carry_bias_covariance && known && anchor->bias_covariance.llt().info() == Eigen::Success &&
      withinTurnOn(anchor->bias_covariance)) {
    BaBiasPrior prior;
    prior.keyframe_id = anchor->id;
    prior.mean = anchor->imu_bias_at_covariance;
    prior.covariance = anchor->bias_covariance;
    inertial.bias_priors.push_back(prior);
  } else {
    inertial.bias_priors.push_back(BaBiasPrior::diagonal(oldest.keyframe_id, oldest.bias,
                                                         config_.imu.gyro_turn_on_bias_radps,
                                                         config_.imu.accel_turn_on_bias_mps2));
  }
}

void Pipeline::fillInertialOutput(FrameResult* result) const {
  if (!inertialActive()) return;
  const std::optional<NavState> now = inertialStateNow();
  if (!now) return;
  result->has_velocity = true;
  result->v_world_mps = now->v_world_mps;
  result->imu_bias = now->bias();
  if (const auto known = newestCovariance(); known && known->first.timestamp_s <= timestamp_s_) {
    NavState frame = *now;
    if (result->hasPoseEstimate()) frame.T_world_body = result->T_world_cam * inertial_.T_cam_imu();
    result->covariance =
        propagateCovariance(known->second, known->first, frame, config_.imu, inertial_.gravityWorld());
    result->has_covariance = true;
  }
  const auto& kfs = map_.keyframes();
  result->inertial = metric_scale_ && !kfs.empty() && kfs.back().has_inertial_state;
  // Without a map, holdPose() took the pose from the same inertial state (predictPose()).
  result->inertial_only = stage_ == PipelineStage::kInitialising &&
                          result->state == TrackingState::kInitialising &&
                          config_.pipeline.trajectory_mode == TrajectoryMode::kMap;
}

void Pipeline::addMapDriftToInertialOutput(FrameResult* result) {
  // The window's covariance holds its oldest state under the covariance that state had when it was the
  // newest, so it misses what the chain of such anchors lets the map's attitude walk (docs/fusion/README.md,
  // "Covariance"): the drift of the map since the first covariance, summed along the path, is added to it.
  if (!inertialActive() || !result->has_covariance || !metric_scale_ || result->inertial_only) return;
  const Eigen::Vector3d c_world = result->T_world_cam.translation();
  if (!map_drift_.running()) map_drift_.start(c_world, c_world, 0, 0.0, MapDrift::Matrix6d::Zero());
  map_drift_.moveTo(c_world);
  map_drift_.addTo(&result->covariance, result->has_velocity ? &result->v_world_mps : nullptr);
}

}  // namespace planetary_vo
