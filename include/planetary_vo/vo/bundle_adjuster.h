#pragma once
/// @file bundle_adjuster.h
/// Stage 6: windowed bundle adjustment with Ceres (thesis 3.5.2) over a plain problem description, so that
/// the optimiser knows nothing of the map's bookkeeping: the pipeline copies the local window out, the
/// adjuster optimises the copy (in its own thread if asked), and the pipeline writes back what is still
/// alive.
///
/// Poses are T_cam_world (world -> camera, the form the reprojection residual needs); observations are IDEAL
/// (undistorted) pixels of a pinhole camera with intrinsics K.
///
/// Factors: one reprojection residual per observation (vo/reprojection_cost.h, analytic Jacobians; robust
/// loss of the config); for a metric map of the camera + IMU mode, per BaImuConstraint a preintegrated IMU
/// factor and a bias random walk between the two keyframes' states (velocity, biases; the pose of T_cam_world
/// converted to the IMU body pose inside the factor), and the bias priors; for a metric map of the vision +
/// altimeter mode, one altimeter range residual per BaRangeObservation (the keyframe's measured slant range
/// against the range from its pose to the terrain plane fitted to the map, which moves with its support
/// points; fusion/altimeter_range.h, Cauchy loss at 2.5 sigma). The range factors make the scale observable,
/// so the caller may then fix only the oldest keyframe (the gauge policy is the caller's: see
/// Pipeline::runBundleAdjustment).
///
/// Contract of adjustBundle() / refinePose() (bundle_adjuster.cpp):
/// - Bad input is a caller bug and throws std::invalid_argument: an observation naming a keyframe or point
///   id that is not in the problem, duplicate keyframe or point ids, fx/fy not positive, a robust loss with
///   a non-positive scale, negative max_iterations, refinePose() with p_world and px of different sizes.
/// - Gauge: the caller fixes it. Hold at least one keyframe fixed (rotation + translation) and, for
///   monocular windows, a second one or some fixed points (scale); otherwise only Levenberg-Marquardt
///   damping keeps the free gauge directions from wandering (it works, but slower and less reproducibly).
/// - A non-fixed point seen by fewer than two keyframes (fixed or not) has no observable depth: it is held
///   constant, and its observation still constrains the pose.
/// - An observation whose point is not in front of its camera at the start cannot be evaluated: it is
///   left out of the solve and of the RMS, and is reported in BaSummary::outliers.
/// - Only robust_loss, robust_loss_scale_px and max_iterations of the config are used here; enabled,
///   window_keyframes and asynchronous are the pipeline's business. The solver runs single-threaded
///   (tracking owns the other core).

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/fusion/altimeter_range.h"
#include "planetary_vo/fusion/imu_preintegration.h"
#include "planetary_vo/fusion/nav_state.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/config.h"

namespace planetary_vo {

struct BaKeyframe {
  uint64_t id = 0;
  Pose T_cam_world = Pose::Identity();
  bool fixed =
      false;  ///< held constant (gauge: at least the oldest keyframe of the window, plus those outside)
};

struct BaPoint {
  uint64_t id = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  bool fixed = false;
};

struct BaObservation {
  uint64_t keyframe_id = 0;
  uint64_t point_id = 0;
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  ///< ideal pixel
};

/// An altimeter reading of a keyframe in a metric map, against the terrain plane fitted to the map under its
/// beam (predictRange()). In the solve the plane keeps its normal and moves with the mean of its support
/// points (ids of points of the problem, at least 3), so that the range constrains the scale of the map, not
/// the distance to a plane frozen in the world.
struct BaRangeObservation {
  uint64_t keyframe_id = 0;
  LocalSurfacePlane plane;
  std::vector<uint64_t> support_point_ids;
  AltimeterMounting mounting;     ///< in the camera frame
  double measured_range_m = 0.0;  ///< > 0
  double sigma_m = 0.0;           ///< > 0: instrument noise and plane uncertainty (altimeterResidualSigmaM)
};

/// Velocity and IMU biases of a keyframe in the camera + IMU mode (the body = the IMU, T_cam_imu of
/// BaInertial): free in the solve (unless velocity_fixed), also when the keyframe's pose is fixed.
struct BaInertialState {
  uint64_t keyframe_id = 0;
  Eigen::Vector3d v_world_mps = Eigen::Vector3d::Zero();  ///< body velocity, world frame
  ImuBias bias;
  /// The velocity is held (like the fixed pose of the window's oldest keyframe: what earlier windows
  /// estimated, or the velocity handed over); the biases stay free.
  bool velocity_fixed = false;
  /// A Gaussian prior on the velocity, used when the velocity is free (not velocity_fixed): the window's
  /// oldest state solved under what earlier windows knew of its velocity instead of held. When the covariance
  /// releases that state under anchor_covariance (BaInertial::compute_covariance), that prior replaces it.
  bool has_velocity_prior = false;
  Eigen::Vector3d velocity_prior_mps = Eigen::Vector3d::Zero();
  Eigen::Matrix3d velocity_prior_covariance = Eigen::Matrix3d::Identity();  ///< positive definite
  /// Output of BaInertial::compute_covariance: the covariance of [position (world, m), attitude (world-frame
  /// rotation vector, rad), velocity (world, m/s)] of the keyframe's camera and body velocity.
  bool has_covariance = false;
  Eigen::Matrix<double, 9, 9> covariance = Eigen::Matrix<double, 9, 9>::Zero();
  /// With it: the covariance of the biases [gyro (rad/s), accelerometer (m/s^2)] (their marginal; the
  /// correlations with the pose and velocity are not kept).
  Eigen::Matrix<double, 6, 6> bias_covariance = Eigen::Matrix<double, 6, 6>::Zero();
};

/// The preintegrated IMU between two keyframes of the problem (i older than j): an ImuFactor and a bias
/// random-walk factor (fusion/inertial_factors.h) on their poses, velocities and biases.
struct BaImuConstraint {
  uint64_t keyframe_i = 0, keyframe_j = 0;
  std::shared_ptr<const ImuPreintegration> preintegration;
};

/// A Gaussian prior on the biases of one keyframe: the turn-on bias of the data sheet (diagonal()), or what
/// an earlier window estimated with its covariance.
struct BaBiasPrior {
  uint64_t keyframe_id = 0;
  ImuBias mean;
  /// Covariance of [gyro (rad/s), accelerometer (m/s^2)] biases; positive definite.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();

  static BaBiasPrior diagonal(uint64_t keyframe_id, const ImuBias& mean, double gyro_sigma_radps,
                              double accel_sigma_mps2);
};

/// The inertial part of a window (empty states: vision only). Gravity makes the world's roll and pitch and
/// the scale observable; only position and yaw remain a gauge freedom.
struct BaInertial {
  Eigen::Vector3d gravity_world_mps2 = kLunarGravityWorldMps2;
  Pose T_cam_imu = Pose::Identity();
  std::vector<BaInertialState> states;
  std::vector<BaImuConstraint> constraints;  ///< both keyframes must have a state
  std::vector<BaBiasPrior> bias_priors;
  /// After the solve, the covariance of every state (BaInertialState::covariance): the inverse of the
  /// solution's information (J^T J with the points eliminated by their Schur complement) with the oldest
  /// state's fixed pose and its velocity (held, or under its velocity prior) released under a prior of
  /// anchor_covariance (same order as the output), so that what the window's gauge holds fixed carries the
  /// uncertainty it had. Left out (has_covariance false) when the reduced information is not positive
  /// definite.
  bool compute_covariance = false;
  Eigen::Matrix<double, 9, 9> anchor_covariance = Eigen::Matrix<double, 9, 9>::Identity();
};

struct BaProblem {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  std::vector<BaKeyframe> keyframes;
  std::vector<BaPoint> points;
  std::vector<BaObservation> observations;
  std::vector<BaRangeObservation> ranges;  ///< empty in vision-only mode
  BaInertial inertial;                     ///< empty in vision-only mode
};

struct BaSummary {
  bool converged = false;  ///< Ceres reported a usable solution
  int iterations = 0;
  double initial_rms_px = 0.0;  ///< RMS reprojection error over all observations before
  double final_rms_px = 0.0;    ///< and after the adjustment
  double solve_ms = 0.0;        ///< wall time of the whole call (set-up, solve, evaluation)
  double solve_cpu_ms = 0.0;    ///< CPU time of the calling thread over the same call
  int range_factors = 0;        ///< altimeter range residuals that took part (their keyframe free)
  int imu_factors = 0;          ///< preintegrated IMU factors that took part
  double covariance_ms = 0.0;   ///< time of the covariance (BaInertial::compute_covariance)
  /// Observations whose error after the adjustment exceeds the robust-loss scale times 3: the pipeline drops
  /// them. The threshold is 3 * robust_loss_scale_px also with robust_loss none. Points behind their camera
  /// are listed too. refinePose() reports keyframe_id 0 and point_id = index into its p_world/px vectors.
  std::vector<BaObservation> outliers;
};

/// Optimises the non-fixed keyframe poses and points of `problem` in place. The problem is written back
/// only when Ceres reports a usable solution (summary.converged); otherwise it is left untouched. An empty
/// problem, or one with nothing free, is "converged" after 0 iterations.
BaSummary adjustBundle(BaProblem* problem, const BundleAdjustmentConfig& config);

/// Motion-only refinement: the camera pose that minimises the robust reprojection error of fixed world
/// points. Returns the summary; `T_cam_world` is updated in place. With no point in front of the camera the
/// pose is undetermined: converged is false and the pose is unchanged. The pipeline's per-frame refinement
/// is geometry/pose_gauss_newton.h (the same problem without Ceres); this one is the Ceres reference the
/// tests check it against (test_pnp_tracker.cpp).
BaSummary refinePose(Pose* T_cam_world, const std::vector<Eigen::Vector3d>& p_world,
                     const std::vector<Eigen::Vector2d>& px, double fx, double fy, double cx, double cy,
                     const BundleAdjustmentConfig& config);

/// Runs adjustBundle() in a background thread (thesis Phase 2): submit() returns at once. The Pipeline
/// submits at a keyframe and collects with waitIdle() + takeResult() after the next image's KLT, so the
/// solve overlaps that tracking and its result always lands at the same frame.
/// At most one problem is in flight; submitting while busy replaces the queued (not yet started) problem.
/// A problem that asks for the covariance (BaInertial::compute_covariance) is solved without it first, so
/// that takeResult() does not wait for it; the worker then computes the covariance of the solution and keeps
/// it for takeCovariance(), which waits for it (call it at the next keyframe: by then it is long done in real
/// time, and it lands at the same keyframe on every run).
/// Threading: submit() and takeResult() may be called from the tracking thread; the worker only touches its
/// own copy of the problem. A solve that failed with an exception (bad input, see above) is rethrown by the
/// next takeResult(). Destroying the adjuster while a solve runs aborts that solve at its next Ceres
/// iteration (an IterationCallback watching abort_) and discards its result and any queued problem, so the
/// destructor waits for at most one iteration, not the whole solve.
class AsyncBundleAdjuster {
 public:
  explicit AsyncBundleAdjuster(const BundleAdjustmentConfig& config);
  ~AsyncBundleAdjuster();  ///< stops and joins the worker
  AsyncBundleAdjuster(const AsyncBundleAdjuster&) = delete;
  AsyncBundleAdjuster& operator=(const AsyncBundleAdjuster&) = delete;

  void submit(BaProblem problem);
  /// The same, solved with the loss and iteration cap of `solve` (robust_loss, robust_loss_scale_px,
  /// max_iterations); the thread settings stay the constructor's. The Pipeline passes the robust-loss scale
  /// of the tracking method (BundleAdjustmentConfig::robust_loss_scale_aligned_px).
  void submit(BaProblem problem, const BundleAdjustmentConfig& solve);
  /// The most recent finished adjustment, if one finished since the last call.
  std::optional<std::pair<BaProblem, BaSummary>> takeResult();
  /// The inertial states with their covariance of the last solve that asked for one (waits until it is
  /// computed); nullopt when none is pending.
  std::optional<std::vector<BaInertialState>> takeCovariance();
  /// Blocks until no solve is queued or running (a covariance may still be computed).
  void waitIdle();
  bool busy() const;

 private:
  void run();
  BundleAdjustmentConfig config_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::optional<BaProblem> queued_;
  BundleAdjustmentConfig queued_config_;  ///< the loss and iterations of the queued problem
  std::optional<std::pair<BaProblem, BaSummary>> finished_;
  std::optional<std::vector<BaInertialState>> covariance_finished_;
  std::condition_variable covariance_done_;
  bool running_ = false;
  bool covariance_running_ = false;
  bool stop_ = false;
  std::atomic<bool> abort_{false};  ///< read by the Ceres callback without the mutex
  std::exception_ptr error_;        ///< exception of the last solve, rethrown by takeResult()
  std::thread worker_;              ///< last member: started once everything above is constructed
};

}  // namespace planetary_vo
