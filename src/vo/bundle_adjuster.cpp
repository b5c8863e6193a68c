/// @file bundle_adjuster.cpp
/// Windowed bundle adjustment and motion-only refinement with Ceres (thesis 3.5.2), plus the background
/// worker.
///
/// Parameterisation: each keyframe is a unit quaternion block (Eigen order x, y, z, w, on
/// ceres::EigenQuaternionManifold) and a translation block, both of T_cam_world; each point is a 3-vector
/// block. The quaternion avoids the singularity of Euler angles and the manifold keeps the update
/// 3-dimensional, so the normal equations stay full rank in the rotation.

#include "planetary_vo/vo/bundle_adjuster.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <ctime>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include <ceres/ceres.h>
#include <ceres/jet.h>
#include <ceres/manifold.h>
#include <ceres/rotation.h>
#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "planetary_vo/fusion/inertial_factors.h"
#include "planetary_vo/vo/reprojection_cost.h"

namespace planetary_vo {
namespace {

/// Windows with at most this many free poses reduce to a Schur complement of at most 6 * 30 = 180 unknowns,
/// which a dense Cholesky factorises faster than any sparse one (no symbolic analysis). Larger ones go
/// sparse.
constexpr int kMaxDensePoses = 30;
/// Initial Levenberg-Marquardt trust region of windows with inertial states (see where it is used).
constexpr double kInertialInitialTrustRegionRadius = 1e12;

/// The altimeter range residual of a keyframe against the terrain plane under its beam, tied to the map: the
/// plane keeps the normal of its fit but passes through the mean of its support points (plus the constant
/// offset of the fit's centroid from that mean), so it moves with the points it was fitted to. A plane held
/// fixed in the world would not: in a window whose scale is free (only the oldest keyframe fixed), pulling
/// the cameras to the measured range from a fixed plane changes the scale the wrong way (it diverged in the
/// unit test). Blocks: q_cam_world (4), t_cam_world (3), then one 3-vector per support point.
struct RangeOnCameraAndPoints {
  RangeOnCameraAndPoints(const BaRangeObservation& o, const std::vector<Eigen::Vector3d>& support_points)
      : normal(o.plane.normal_world),
        origin_cam(o.mounting.origin_body_m),
        boresight_cam(o.mounting.boresight_body.normalized()),
        measured_m(o.measured_range_m),
        sigma_m(o.sigma_m),
        num_points(static_cast<int>(support_points.size())) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& p : support_points) mean += p;
    mean /= static_cast<double>(num_points);
    offset = normal.dot(o.plane.centroid_world - mean);
  }

  template <typename T>
  bool operator()(T const* const* blocks, T* residual) const {
    const Eigen::Quaternion<T> q_world_cam = Eigen::Map<const Eigen::Quaternion<T>>(blocks[0]).conjugate();
    const Eigen::Matrix<T, 3, 1> centre =
        -(q_world_cam * Eigen::Map<const Eigen::Matrix<T, 3, 1>>(blocks[1]));
    Eigen::Matrix<T, 3, 1> mean = Eigen::Matrix<T, 3, 1>::Zero();
    for (int i = 0; i < num_points; ++i) mean += Eigen::Map<const Eigen::Matrix<T, 3, 1>>(blocks[2 + i]);
    mean /= T(num_points);
    T range;
    if (!beamRangeToPlane(q_world_cam, centre, origin_cam, boresight_cam, normal,
                          Eigen::Matrix<T, 3, 1>(mean + T(offset) * normal.cast<T>()), &range))
      return false;
    residual[0] = (range - T(measured_m)) / T(sigma_m);
    return true;
  }

  static ceres::CostFunction* create(const BaRangeObservation& o,
                                     const std::vector<Eigen::Vector3d>& support_points) {
    auto* cost = new ceres::DynamicAutoDiffCostFunction<RangeOnCameraAndPoints, 4>(
        new RangeOnCameraAndPoints(o, support_points));
    cost->AddParameterBlock(4);
    cost->AddParameterBlock(3);
    for (size_t i = 0; i < support_points.size(); ++i) cost->AddParameterBlock(3);
    cost->SetNumResiduals(1);
    return cost;
  }

  Eigen::Vector3d normal, origin_cam, boresight_cam;
  double measured_m, sigma_m, offset = 0.0;
  int num_points;
};

/// The body (IMU) pose of a camera pose block: q_world_body = q_cam_world^-1 q_cam_imu and p_world_body =
/// R_world_cam (t_cam_imu - t_cam_world), the quaternion normalised first (so the derivative is that of
/// the normalised quaternion, as the inertial factors expect).
template <typename T>
void bodyPoseOfCamera(const T* q_cam_world, const T* t_cam_world, const Eigen::Quaterniond& q_cam_imu,
                      const Eigen::Vector3d& t_cam_imu, T* q_world_body, T* p_world_body) {
  const Eigen::Quaternion<T> q_world_cam =
      Eigen::Map<const Eigen::Quaternion<T>>(q_cam_world).normalized().conjugate();
  const Eigen::Matrix<T, 3, 1> t(t_cam_world[0], t_cam_world[1], t_cam_world[2]);
  Eigen::Map<Eigen::Quaternion<T>> q_out(q_world_body);
  Eigen::Map<Eigen::Matrix<T, 3, 1>> p_out(p_world_body);
  q_out = q_world_cam * q_cam_imu.cast<T>();
  p_out = q_world_cam * (t_cam_imu.cast<T>() - t);
}

/// The preintegrated IMU factor (fusion/inertial_factors.h, analytic Jacobians) on the bundle adjuster's
/// camera pose blocks: the poses are converted to body poses and the chain rule applied with the Jacobian
/// of that conversion (forward-mode jets over its 7 inputs). Blocks: q_cw_i (4), t_cw_i (3), v_i, bg_i, ba_i,
/// q_cw_j (4), t_cw_j (3), v_j.
class ImuOnCameraPoses final : public ceres::SizedCostFunction<9, 4, 3, 3, 3, 3, 4, 3, 3> {
 public:
  ImuOnCameraPoses(std::shared_ptr<const ImuPreintegration> preintegration, const Eigen::Vector3d& gravity,
                   const Pose& T_cam_imu)
      : imu_(std::move(preintegration), gravity),
        q_cam_imu_(Eigen::Quaterniond(T_cam_imu.linear()).normalized()),
        t_cam_imu_(T_cam_imu.translation()) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    using Jet = ceres::Jet<double, 7>;
    // Body poses of i and j with d(q_wb, p_wb) / d(q_cw, t_cw) (7 x 7, rows q_wb then p_wb).
    std::array<std::array<double, 4>, 2> q_wb;
    std::array<std::array<double, 3>, 2> p_wb;
    std::array<Eigen::Matrix<double, 7, 7>, 2> J_conv;
    const int pose_block[2] = {0, 5};
    for (int s = 0; s < 2; ++s) {
      Jet q[4], t[3], qb[4], pb[3];
      for (int k = 0; k < 4; ++k) q[k] = Jet(parameters[pose_block[s]][k], k);
      for (int k = 0; k < 3; ++k) t[k] = Jet(parameters[pose_block[s] + 1][k], 4 + k);
      bodyPoseOfCamera(q, t, q_cam_imu_, t_cam_imu_, qb, pb);
      for (int k = 0; k < 4; ++k) {
        q_wb[s][k] = qb[k].a;
        J_conv[s].row(k) = qb[k].v.transpose();
      }
      for (int k = 0; k < 3; ++k) {
        p_wb[s][k] = pb[k].a;
        J_conv[s].row(4 + k) = pb[k].v.transpose();
      }
    }
    const double* inner[8] = {q_wb[0].data(), p_wb[0].data(), parameters[2],  parameters[3],
                              parameters[4],  q_wb[1].data(), p_wb[1].data(), parameters[7]};
    if (jacobians == nullptr) return imu_.Evaluate(inner, residuals, nullptr);
    // Jacobians of the inner factor w.r.t. q_wb / p_wb of i and j (row-major 9 x 4 and 9 x 3).
    Eigen::Matrix<double, 9, 4, Eigen::RowMajor> Jq[2];
    Eigen::Matrix<double, 9, 3, Eigen::RowMajor> Jp[2];
    double* inner_jac[8] = {Jq[0].data(), Jp[0].data(), jacobians[2], jacobians[3],
                            jacobians[4], Jq[1].data(), Jp[1].data(), jacobians[7]};
    if (!imu_.Evaluate(inner, residuals, inner_jac)) return false;
    for (int s = 0; s < 2; ++s) {
      double* jq = jacobians[pose_block[s]];
      double* jt = jacobians[pose_block[s] + 1];
      if (jq != nullptr) {
        Eigen::Map<Eigen::Matrix<double, 9, 4, Eigen::RowMajor>> J(jq);
        J = Jq[s] * J_conv[s].block<4, 4>(0, 0) + Jp[s] * J_conv[s].block<3, 4>(4, 0);
      }
      if (jt != nullptr) {
        Eigen::Map<Eigen::Matrix<double, 9, 3, Eigen::RowMajor>> J(jt);
        J = Jq[s] * J_conv[s].block<4, 3>(0, 4) + Jp[s] * J_conv[s].block<3, 3>(4, 4);
      }
    }
    return true;
  }

 private:
  ImuFactor imu_;
  Eigen::Quaterniond q_cam_imu_;
  Eigen::Vector3d t_cam_imu_;
};

/// L^-1 for the Cholesky factor L of a prior's covariance (its residual is L^-1 (x - mean)); throws when the
/// covariance is not positive definite.
template <int N>
Eigen::Matrix<double, N, N> priorWhitening(const Eigen::Matrix<double, N, N>& covariance, const char* what) {
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(covariance);
  if (!covariance.allFinite() || llt.info() != Eigen::Success)
    throw std::invalid_argument(std::string("bundle adjustment: ") + what +
                                " needs a positive definite covariance");
  return llt.matrixL().solve(Eigen::Matrix<double, N, N>::Identity());
}

/// Gaussian prior on the gyro and accelerometer biases of one keyframe: residual L^-1 (b - mean).
struct BiasPriorResidual {
  Eigen::Matrix<double, 6, 1> mean;  // [gyro, accelerometer]
  Eigen::Matrix<double, 6, 6> whitening;
  template <typename T>
  bool operator()(const T* bg, const T* ba, T* r) const {
    Eigen::Matrix<T, 6, 1> e;
    e << Eigen::Map<const Eigen::Matrix<T, 3, 1>>(bg), Eigen::Map<const Eigen::Matrix<T, 3, 1>>(ba);
    Eigen::Map<Eigen::Matrix<T, 6, 1>> residual(r);
    residual = whitening.cast<T>() * (e - mean.cast<T>());
    return true;
  }
};

/// Gaussian prior on a velocity: residual L^-1 (v - mean).
struct VelocityPriorResidual {
  Eigen::Vector3d mean;
  Eigen::Matrix3d whitening;
  template <typename T>
  bool operator()(const T* v, T* r) const {
    Eigen::Map<Eigen::Matrix<T, 3, 1>> residual(r);
    residual = whitening.cast<T>() * (Eigen::Map<const Eigen::Matrix<T, 3, 1>>(v) - mean.cast<T>());
    return true;
  }
};

/// Prior on the pose of a camera pose block and a velocity: e = [p_world_cam - p, Log(R_world_cam R^T),
/// v - v_prior] whitened by the inverse Cholesky factor of its covariance (the order of BaInertialState).
struct CameraStatePrior {
  CameraStatePrior(const Pose& T_world_cam, const Eigen::Vector3d& v, const Eigen::Matrix<double, 9, 9>& cov)
      : p_prior(T_world_cam.translation()),
        q_prior(Eigen::Quaterniond(T_world_cam.linear()).normalized()),
        v_prior(v) {
    whitening = cov.llt().matrixL().solve(Eigen::Matrix<double, 9, 9>::Identity());
  }
  template <typename T>
  bool operator()(const T* q_cam_world, const T* t_cam_world, const T* v, T* residual) const {
    const Eigen::Quaternion<T> q_world_cam =
        Eigen::Map<const Eigen::Quaternion<T>>(q_cam_world).normalized().conjugate();
    const Eigen::Matrix<T, 3, 1> p = -(q_world_cam * Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t_cam_world));
    const Eigen::Quaternion<T> dq = q_world_cam * q_prior.cast<T>().conjugate();
    const T wxyz[4] = {dq.w(), dq.x(), dq.y(), dq.z()};
    T angle_axis[3];
    ceres::QuaternionToAngleAxis(wxyz, angle_axis);
    Eigen::Matrix<T, 9, 1> e;
    for (int k = 0; k < 3; ++k) {
      e[k] = p[k] - T(p_prior[k]);
      e[3 + k] = angle_axis[k];
      e[6 + k] = v[k] - T(v_prior[k]);
    }
    Eigen::Map<Eigen::Matrix<T, 9, 1>> r(residual);
    r = whitening.cast<T>() * e;
    return true;
  }
  Eigen::Vector3d p_prior;
  Eigen::Quaterniond q_prior;
  Eigen::Vector3d v_prior;
  Eigen::Matrix<double, 9, 9> whitening;
};

/// Stops the solve at the next iteration once the flag is raised (AsyncBundleAdjuster's destructor).
class AbortCallback : public ceres::IterationCallback {
 public:
  explicit AbortCallback(const std::atomic<bool>* abort) : abort_(abort) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return abort_->load(std::memory_order_relaxed) ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* abort_;
};

struct PoseBlock {
  std::array<double, 4> q;  ///< Eigen coefficient order x, y, z, w
  std::array<double, 3> t;
};

PoseBlock toBlock(const Pose& T) {
  // Isometry3d::rotation() would run an SVD polar decomposition; linear() is a rotation by contract.
  const Eigen::Quaterniond q(T.linear());
  PoseBlock b;
  Eigen::Map<Eigen::Quaterniond>(b.q.data()) = q.normalized();
  Eigen::Map<Eigen::Vector3d>(b.t.data()) = T.translation();
  return b;
}

Pose toPose(const PoseBlock& b) {
  Pose T = Pose::Identity();
  T.linear() = Eigen::Map<const Eigen::Quaterniond>(b.q.data()).normalized().toRotationMatrix();
  T.translation() = Eigen::Map<const Eigen::Vector3d>(b.t.data());
  return T;
}

/// Stops the solve once a successful iteration moved no free keyframe by more than `tolerance`: rotation in
/// rad, camera centre as a fraction of `extent_m` (BundleAdjustmentConfig::pose_change_tolerance). Reads the
/// pose blocks after each iteration (Solver::Options::update_state_every_iteration must be set).
class PoseChangeCallback : public ceres::IterationCallback {
 public:
  PoseChangeCallback(std::vector<const PoseBlock*> free_poses, double extent_m, double tolerance)
      : poses_(std::move(free_poses)), extent_m_(extent_m), tolerance_(tolerance) {
    read(&previous_);
  }

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& iteration) override {
    if (iteration.iteration == 0 || !iteration.step_is_successful) return ceres::SOLVER_CONTINUE;
    std::vector<Pose> now;
    read(&now);
    bool moved = false;
    for (size_t k = 0; k < now.size() && !moved; ++k) {
      const double rotation_rad =
          Eigen::AngleAxisd(now[k].linear().transpose() * previous_[k].linear()).angle();
      const double centre_m = (now[k].translation() - previous_[k].translation()).norm();
      moved = rotation_rad > tolerance_ || centre_m > tolerance_ * extent_m_;
    }
    previous_ = std::move(now);
    return moved ? ceres::SOLVER_CONTINUE : ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }

 private:
  // T_world_cam of each pose block (its translation is the camera centre).
  void read(std::vector<Pose>* T_world_cam) const {
    T_world_cam->clear();
    for (const PoseBlock* b : poses_) T_world_cam->push_back(toPose(*b).inverse());
  }

  std::vector<const PoseBlock*> poses_;
  double extent_m_, tolerance_;
  std::vector<Pose> previous_;
};

void validateConfig(const BundleAdjustmentConfig& config) {
  if (config.robust_loss != RobustLoss::kNone &&
      !(config.robust_loss_scale_px > 0.0 && std::isfinite(config.robust_loss_scale_px))) {
    throw std::invalid_argument("bundle adjustment: robust_loss_scale_px must be positive, got " +
                                std::to_string(config.robust_loss_scale_px));
  }
  if (!(config.pose_change_tolerance >= 0.0 && std::isfinite(config.pose_change_tolerance))) {
    throw std::invalid_argument("bundle adjustment: pose_change_tolerance must not be negative, got " +
                                std::to_string(config.pose_change_tolerance));
  }
  if (config.max_iterations < 0) {
    throw std::invalid_argument("bundle adjustment: max_iterations must not be negative, got " +
                                std::to_string(config.max_iterations));
  }
}

std::unique_ptr<ceres::LossFunction> makeLoss(const BundleAdjustmentConfig& config) {
  // Both losses take the scale in the residual's unit (px): Huber is quadratic up to `scale` px and linear
  // beyond; Cauchy keeps a slowly growing (log) cost, so a gross outlier barely pulls at all.
  switch (config.robust_loss) {
    case RobustLoss::kHuber:
      return std::make_unique<ceres::HuberLoss>(config.robust_loss_scale_px);
    case RobustLoss::kCauchy:
      return std::make_unique<ceres::CauchyLoss>(config.robust_loss_scale_px);
    case RobustLoss::kNone:
      break;
  }
  return nullptr;  // plain squared error
}

/// Error in px of every observation of `problem` (negative: point not in front of the camera).
std::vector<double> reprojectionErrors(const BaProblem& problem, const std::vector<size_t>& obs_keyframe,
                                       const std::vector<size_t>& obs_point) {
  std::vector<PoseBlock> poses(problem.keyframes.size());
  for (size_t k = 0; k < poses.size(); ++k) poses[k] = toBlock(problem.keyframes[k].T_cam_world);
  std::vector<double> errors(problem.observations.size(), -1.0);
  for (size_t i = 0; i < problem.observations.size(); ++i) {
    const PoseBlock& pose = poses[obs_keyframe[i]];
    const Eigen::Vector3d& p = problem.points[obs_point[i]].p_world;
    // The residual the solve uses (vo/reprojection_cost.h), without its Jacobians.
    const ReprojectionCost cost(problem.observations[i].px, problem.fx, problem.fy, problem.cx, problem.cy);
    const double* parameters[3] = {pose.q.data(), pose.t.data(), p.data()};
    Eigen::Vector2d r;
    if (cost.Evaluate(parameters, r.data(), nullptr)) errors[i] = r.norm();
  }
  return errors;
}

double rms(const std::vector<double>& errors) {
  double sum = 0.0;
  size_t n = 0;
  for (double e : errors) {
    if (e < 0.0) continue;
    sum += e * e;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

template <typename Item>
std::unordered_map<uint64_t, size_t> indexById(const std::vector<Item>& items, const char* what) {
  std::unordered_map<uint64_t, size_t> index;
  index.reserve(items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    if (!index.emplace(items[i].id, i).second) {
      throw std::invalid_argument(std::string("bundle adjustment: duplicate ") + what + " id " +
                                  std::to_string(items[i].id));
    }
  }
  return index;
}

double elapsedMs(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

/// CPU time of the calling thread, in ms (what a solve costs, whatever else shares the core).
double threadCpuMs() {
  timespec ts{};
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) != 0) return 0.0;
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

/// adjustBundle() with an optional abort flag; `num_residuals` (optional) receives how many observations took
/// part in the solve.
BaSummary solveBundle(BaProblem* problem, const BundleAdjustmentConfig& config,
                      const std::atomic<bool>* abort, size_t* num_residuals) {
  const auto start = std::chrono::steady_clock::now();
  const double start_cpu_ms = threadCpuMs();
  if (problem == nullptr) throw std::invalid_argument("bundle adjustment: null problem");
  validateConfig(config);
  const size_t num_obs = problem->observations.size();
  if (num_obs > 0 && !(problem->fx > 0.0 && problem->fy > 0.0)) {
    throw std::invalid_argument("bundle adjustment: fx and fy must be positive");
  }

  // Resolve every observation first, so that a bad id throws before anything is touched.
  const auto keyframe_index = indexById(problem->keyframes, "keyframe");
  const auto point_index = indexById(problem->points, "point");
  std::vector<size_t> obs_keyframe(num_obs), obs_point(num_obs);
  for (size_t i = 0; i < num_obs; ++i) {
    const BaObservation& o = problem->observations[i];
    const auto kf = keyframe_index.find(o.keyframe_id);
    const auto pt = point_index.find(o.point_id);
    if (kf == keyframe_index.end() || pt == point_index.end()) {
      std::ostringstream msg;
      msg << "bundle adjustment: observation " << i << " names "
          << (kf == keyframe_index.end() ? "missing keyframe " : "missing point ")
          << (kf == keyframe_index.end() ? o.keyframe_id : o.point_id);
      throw std::invalid_argument(msg.str());
    }
    obs_keyframe[i] = kf->second;
    obs_point[i] = pt->second;
  }

  BaSummary summary;
  const std::vector<double> initial_errors = reprojectionErrors(*problem, obs_keyframe, obs_point);
  summary.initial_rms_px = rms(initial_errors);

  // Observations per point among the evaluable ones: a point seen once has no depth to estimate.
  std::vector<int> point_obs_count(problem->points.size(), 0);
  for (size_t i = 0; i < num_obs; ++i) {
    if (initial_errors[i] >= 0.0) ++point_obs_count[obs_point[i]];
  }
  auto pointConstant = [&](size_t j) { return problem->points[j].fixed || point_obs_count[j] < 2; };

  // Parameter blocks: copies of the problem's values, written back only if the solve is usable. The vectors
  // are sized once so the pointers handed to Ceres stay valid.
  std::vector<PoseBlock> poses(problem->keyframes.size());
  for (size_t k = 0; k < poses.size(); ++k) poses[k] = toBlock(problem->keyframes[k].T_cam_world);
  std::vector<std::array<double, 3>> points(problem->points.size());
  for (size_t j = 0; j < points.size(); ++j) {
    Eigen::Map<Eigen::Vector3d>(points[j].data()) = problem->points[j].p_world;
  }

  // Declared before the problem so that they outlive it (the problem only borrows them).
  const std::unique_ptr<ceres::LossFunction> loss = makeLoss(config);
  const std::unique_ptr<ceres::LossFunction> range_loss(problem->ranges.empty() ? nullptr
                                                                                : makeAltimeterLoss());
  const auto manifold = std::make_unique<ceres::EigenQuaternionManifold>();
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);

  std::vector<char> pose_used(poses.size(), 0), point_used(points.size(), 0);
  size_t residuals = 0;
  for (size_t i = 0; i < num_obs; ++i) {
    const size_t k = obs_keyframe[i], j = obs_point[i];
    if (initial_errors[i] < 0.0) continue;  // behind the camera: reported as outlier below
    // A residual with nothing free only adds a constant to the cost.
    if (problem->keyframes[k].fixed && pointConstant(j)) continue;
    ceres_problem.AddResidualBlock(
        new ReprojectionCost(problem->observations[i].px, problem->fx, problem->fy, problem->cx, problem->cy),
        loss.get(), poses[k].q.data(), poses[k].t.data(), points[j].data());
    pose_used[k] = point_used[j] = 1;
    ++residuals;
  }
  if (num_residuals != nullptr) *num_residuals = residuals;

  // Altimeter ranges of free keyframes (a fixed keyframe's range constrains nothing).
  std::vector<char> range_support(points.size(), 0);
  for (const BaRangeObservation& o : problem->ranges) {
    const auto kf = keyframe_index.find(o.keyframe_id);
    if (kf == keyframe_index.end())
      throw std::invalid_argument("bundle adjustment: range observation names missing keyframe " +
                                  std::to_string(o.keyframe_id));
    if (!(o.measured_range_m > 0.0 && std::isfinite(o.measured_range_m) && o.sigma_m > 0.0 &&
          std::isfinite(o.sigma_m)))
      throw std::invalid_argument("bundle adjustment: range observation of keyframe " +
                                  std::to_string(o.keyframe_id) + " needs a positive range and sigma");
    std::vector<size_t> support;
    for (uint64_t id : o.support_point_ids) {
      const auto pt = point_index.find(id);
      if (pt != point_index.end()) support.push_back(pt->second);
    }
    if (support.size() < 3)
      throw std::invalid_argument("bundle adjustment: range observation of keyframe " +
                                  std::to_string(o.keyframe_id) + " has fewer than 3 support points");
    const size_t k = kf->second;
    if (problem->keyframes[k].fixed) continue;
    std::vector<Eigen::Vector3d> support_points;
    std::vector<double*> blocks{poses[k].q.data(), poses[k].t.data()};
    for (size_t j : support) {
      support_points.push_back(problem->points[j].p_world);
      blocks.push_back(points[j].data());
      point_used[j] = 1;
      range_support[j] = 1;
    }
    ceres_problem.AddResidualBlock(RangeOnCameraAndPoints::create(o, support_points), range_loss.get(),
                                   blocks);
    pose_used[k] = 1;
    ++summary.range_factors;
  }

  // Inertial states (velocity, biases) and their factors.
  BaInertial& inertial = problem->inertial;
  std::unordered_map<uint64_t, size_t> state_index;
  for (size_t st = 0; st < inertial.states.size(); ++st)
    if (!state_index.emplace(inertial.states[st].keyframe_id, st).second)
      throw std::invalid_argument("bundle adjustment: two inertial states of keyframe " +
                                  std::to_string(inertial.states[st].keyframe_id));
  struct StateBlocks {
    std::array<double, 3> v, bg, ba;
  };
  std::vector<StateBlocks> states(inertial.states.size());
  for (size_t s = 0; s < states.size(); ++s) {
    const BaInertialState& st = inertial.states[s];
    if (keyframe_index.count(st.keyframe_id) == 0)
      throw std::invalid_argument("bundle adjustment: inertial state of missing keyframe " +
                                  std::to_string(st.keyframe_id));
    Eigen::Map<Eigen::Vector3d>(states[s].v.data()) = st.v_world_mps;
    Eigen::Map<Eigen::Vector3d>(states[s].bg.data()) = st.bias.gyro_radps;
    Eigen::Map<Eigen::Vector3d>(states[s].ba.data()) = st.bias.accel_mps2;
  }
  auto stateOf = [&](uint64_t keyframe_id, const char* what) {
    const auto it = state_index.find(keyframe_id);
    if (it == state_index.end())
      throw std::invalid_argument(std::string("bundle adjustment: ") + what + " names keyframe " +
                                  std::to_string(keyframe_id) + " without an inertial state");
    return it->second;
  };
  std::vector<char> state_used(states.size(), 0);
  for (const BaImuConstraint& c : inertial.constraints) {
    if (!c.preintegration)
      throw std::invalid_argument("bundle adjustment: IMU constraint without a preintegration");
    const size_t si = stateOf(c.keyframe_i, "IMU constraint"), sj = stateOf(c.keyframe_j, "IMU constraint");
    const size_t ki = keyframe_index.at(c.keyframe_i), kj = keyframe_index.at(c.keyframe_j);
    ceres_problem.AddResidualBlock(
        new ImuOnCameraPoses(c.preintegration, inertial.gravity_world_mps2, inertial.T_cam_imu), nullptr,
        {poses[ki].q.data(), poses[ki].t.data(), states[si].v.data(), states[si].bg.data(),
         states[si].ba.data(), poses[kj].q.data(), poses[kj].t.data(), states[sj].v.data()});
    ceres_problem.AddResidualBlock(
        new BiasRandomWalkFactor(c.preintegration->biasRandomWalkCovariance()), nullptr,
        {states[si].bg.data(), states[si].ba.data(), states[sj].bg.data(), states[sj].ba.data()});
    pose_used[ki] = pose_used[kj] = 1;
    state_used[si] = state_used[sj] = 1;
    ++summary.imu_factors;
  }
  std::vector<ceres::ResidualBlockId> velocity_priors(states.size(), nullptr);
  for (size_t s = 0; s < states.size(); ++s) {
    const BaInertialState& st = inertial.states[s];
    if (!state_used[s] || st.velocity_fixed || !st.has_velocity_prior) continue;
    velocity_priors[s] = ceres_problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<VelocityPriorResidual, 3, 3>(new VelocityPriorResidual{
            st.velocity_prior_mps, priorWhitening<3>(st.velocity_prior_covariance, "velocity prior")}),
        nullptr, states[s].v.data());
  }
  for (const BaBiasPrior& p : inertial.bias_priors) {
    const Eigen::Matrix<double, 6, 6> whitening = priorWhitening<6>(p.covariance, "bias prior");
    const size_t s = stateOf(p.keyframe_id, "bias prior");
    if (!state_used[s]) continue;
    Eigen::Matrix<double, 6, 1> mean;
    mean << p.mean.gyro_radps, p.mean.accel_mps2;
    ceres_problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<BiasPriorResidual, 6, 3, 3>(new BiasPriorResidual{mean, whitening}),
        nullptr, states[s].bg.data(), states[s].ba.data());
  }
  int free_states = 0;
  for (size_t s = 0; s < states.size(); ++s) {
    if (!state_used[s]) continue;
    ++free_states;
    if (inertial.states[s].velocity_fixed) ceres_problem.SetParameterBlockConstant(states[s].v.data());
  }

  int free_poses = 0, free_points = 0;
  for (size_t k = 0; k < poses.size(); ++k) {
    if (!pose_used[k]) continue;
    ceres_problem.SetManifold(poses[k].q.data(), manifold.get());
    if (problem->keyframes[k].fixed) {
      ceres_problem.SetParameterBlockConstant(poses[k].q.data());
      ceres_problem.SetParameterBlockConstant(poses[k].t.data());
    } else {
      ++free_poses;
    }
  }
  for (size_t j = 0; j < points.size(); ++j) {
    if (!point_used[j]) continue;
    if (pointConstant(j)) {
      ceres_problem.SetParameterBlockConstant(points[j].data());
    } else {
      ++free_points;
    }
  }

  bool usable = true;
  if (free_poses + free_points + free_states > 0) {
    ceres::Solver::Options options;
    options.max_num_iterations = config.max_iterations;
    // With IMU factors (whitened by a preintegration covariance of ~1e-6 m and rad) Ceres' default initial
    // trust region (1e4) damps the first steps so much that Levenberg-Marquardt needed 17 iterations per
    // window on main_brake_down (10 keyframes, 900 points, 9 IMU and 9 range factors, ~200 ms: the next frame
    // waited for it); starting with Gauss-Newton-like steps it needs 3 (24 ms mean), same accuracy.
    if (free_states > 0) options.initial_trust_region_radius = kInertialInitialTrustRegionRadius;
    options.num_threads = 1;
    options.logging_type = ceres::SILENT;
    options.minimizer_progress_to_stdout = false;
    const bool have_sparse = options.sparse_linear_algebra_library_type != ceres::NO_SPARSE;
    if (free_poses == 0 && free_states == 0) {
      // Structure only: the normal equations are block diagonal (one 3x3 per point).
      options.linear_solver_type = have_sparse ? ceres::SPARSE_NORMAL_CHOLESKY : ceres::DENSE_QR;
    } else if (free_points == 0) {
      // Motion only: 6 unknowns per pose, nothing to eliminate.
      options.linear_solver_type =
          free_poses <= kMaxDensePoses || !have_sparse ? ceres::DENSE_QR : ceres::SPARSE_NORMAL_CHOLESKY;
    } else {
      // Eliminate the points (group 0) and solve the reduced camera system (group 1). Constant blocks must be
      // in the ordering too: Ceres checks it against all parameter blocks before removing the constant ones.
      options.linear_solver_type =
          free_poses <= kMaxDensePoses || !have_sparse ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
      auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
      for (size_t j = 0; j < points.size(); ++j) {
        // A Schur solver eliminates blocks that each residual touches at most once: the support points of an
        // altimeter range (several points in one residual) stay in the reduced system with the poses.
        if (point_used[j]) ordering->AddElementToGroup(points[j].data(), range_support[j] ? 1 : 0);
      }
      for (size_t k = 0; k < poses.size(); ++k) {
        if (!pose_used[k]) continue;
        ordering->AddElementToGroup(poses[k].q.data(), 1);
        ordering->AddElementToGroup(poses[k].t.data(), 1);
      }
      for (size_t st = 0; st < states.size(); ++st) {
        if (!state_used[st]) continue;
        for (double* block : {states[st].v.data(), states[st].bg.data(), states[st].ba.data()})
          ordering->AddElementToGroup(block, 1);
      }
      options.linear_solver_ordering = ordering;
    }
    AbortCallback abort_callback(abort);
    if (abort != nullptr) options.callbacks.push_back(&abort_callback);
    std::unique_ptr<PoseChangeCallback> pose_change_callback;
    // Not with inertial states: their biases converge after the poses (on 50 camera + IMU renders the attitude
    // at the end was 3 % worse, 17 of 50 better, with the early stop).
    if (config.pose_change_tolerance > 0.0 && free_poses > 0 && free_states == 0) {
      std::vector<const PoseBlock*> free_pose_blocks;
      std::vector<Eigen::Vector3d> centres;
      for (size_t k = 0; k < poses.size(); ++k) {
        if (!pose_used[k]) continue;
        centres.push_back(toPose(poses[k]).inverse().translation());
        if (!problem->keyframes[k].fixed) free_pose_blocks.push_back(&poses[k]);
      }
      double extent_m = 0.0;
      for (const Eigen::Vector3d& a : centres)
        for (const Eigen::Vector3d& b : centres) extent_m = std::max(extent_m, (a - b).norm());
      if (extent_m > 0.0) {
        pose_change_callback = std::make_unique<PoseChangeCallback>(std::move(free_pose_blocks), extent_m,
                                                                    config.pose_change_tolerance);
        options.update_state_every_iteration = true;
        options.callbacks.push_back(pose_change_callback.get());
      }
    }

    ceres::Solver::Summary ceres_summary;
    ceres::Solve(options, &ceres_problem, &ceres_summary);
    usable = ceres_summary.IsSolutionUsable();
    summary.iterations = ceres_summary.num_successful_steps + ceres_summary.num_unsuccessful_steps;
    if (usable) {
      for (size_t k = 0; k < poses.size(); ++k) {
        if (pose_used[k] && !problem->keyframes[k].fixed)
          problem->keyframes[k].T_cam_world = toPose(poses[k]);
      }
      for (size_t j = 0; j < points.size(); ++j) {
        if (point_used[j] && !pointConstant(j)) {
          problem->points[j].p_world = Eigen::Map<const Eigen::Vector3d>(points[j].data());
        }
      }
      for (size_t st = 0; st < states.size(); ++st) {
        if (!state_used[st]) continue;
        inertial.states[st].has_covariance = false;
        if (!inertial.states[st].velocity_fixed)
          inertial.states[st].v_world_mps = Eigen::Map<const Eigen::Vector3d>(states[st].v.data());
        inertial.states[st].bias.gyro_radps = Eigen::Map<const Eigen::Vector3d>(states[st].bg.data());
        inertial.states[st].bias.accel_mps2 = Eigen::Map<const Eigen::Vector3d>(states[st].ba.data());
      }
    }
  }
  summary.converged = usable;
  if (usable && inertial.compute_covariance && free_states > 0 && state_used[0] &&
      problem->keyframes[keyframe_index.at(inertial.states.front().keyframe_id)].fixed) {
    const auto covariance_start = std::chrono::steady_clock::now();
    // Release the oldest state's held pose and velocity under the anchor prior, then read the marginal
    // covariance of every state's pose and velocity in the tangent space.
    const size_t s0 = 0;
    const size_t k0 = keyframe_index.at(inertial.states[s0].keyframe_id);
    ceres_problem.SetParameterBlockVariable(poses[k0].q.data());
    ceres_problem.SetParameterBlockVariable(poses[k0].t.data());
    ceres_problem.SetParameterBlockVariable(states[s0].v.data());
    if (velocity_priors[s0] != nullptr) ceres_problem.RemoveResidualBlock(velocity_priors[s0]);
    ceres_problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<CameraStatePrior, 9, 4, 3, 3>(
            new CameraStatePrior(problem->keyframes[k0].T_cam_world.inverse(),
                                 inertial.states[s0].v_world_mps, inertial.anchor_covariance)),
        nullptr, poses[k0].q.data(), poses[k0].t.data(), states[s0].v.data());
    // The information matrix J^T J of the free blocks at the solution (tangent space, loss applied), the
    // points eliminated by their Schur complement, then inverted: the covariance of the poses and states.
    // Done by hand rather than with ceres::Covariance, whose sparse QR declares the whole problem
    // rank-deficient when far terrain (Main Brake, 15 km) leaves point depths nearly free next to the IMU
    // factors' large weights; a point's own 3x3 block is inverted with a tiny regularisation instead, which
    // leaves its weak depth weak.
    std::vector<double*> camera_blocks, point_blocks;
    std::unordered_map<const double*, int> offset;
    int nc = 0;
    auto addCamera = [&](double* block) {
      if (ceres_problem.IsParameterBlockConstant(block) || offset.count(block)) return;
      offset[block] = nc;
      nc += 3;
      camera_blocks.push_back(block);
    };
    for (size_t k = 0; k < poses.size(); ++k) {
      if (!pose_used[k]) continue;
      addCamera(poses[k].q.data());
      addCamera(poses[k].t.data());
    }
    for (size_t st = 0; st < states.size(); ++st) {
      if (!state_used[st]) continue;
      for (double* block : {states[st].v.data(), states[st].bg.data(), states[st].ba.data()})
        addCamera(block);
    }
    for (size_t j = 0; j < points.size(); ++j)
      if (point_used[j] && !pointConstant(j) && range_support[j]) addCamera(points[j].data());
    for (size_t j = 0; j < points.size(); ++j)
      if (point_used[j] && !pointConstant(j) && !range_support[j]) point_blocks.push_back(points[j].data());
    ceres::Problem::EvaluateOptions evaluate_options;
    evaluate_options.parameter_blocks = camera_blocks;
    evaluate_options.parameter_blocks.insert(evaluate_options.parameter_blocks.end(), point_blocks.begin(),
                                             point_blocks.end());
    ceres::CRSMatrix jacobian;
    bool computed = ceres_problem.Evaluate(evaluate_options, nullptr, nullptr, nullptr, &jacobian) &&
                    jacobian.num_cols == nc + 3 * static_cast<int>(point_blocks.size());
    std::vector<size_t> with_covariance;
    Eigen::MatrixXd covariance_cc;
    if (computed) {
      const size_t np = point_blocks.size();
      Eigen::MatrixXd H_cc = Eigen::MatrixXd::Zero(nc, nc);
      Eigen::MatrixXd H_cp = Eigen::MatrixXd::Zero(nc, 3 * static_cast<int>(np));
      std::vector<Eigen::Matrix3d> H_pp(np, Eigen::Matrix3d::Zero());
      for (int r = 0; r < jacobian.num_rows; ++r) {
        for (int a = jacobian.rows[r]; a < jacobian.rows[r + 1]; ++a) {
          const int ca = jacobian.cols[a];
          const double va = jacobian.values[a];
          for (int b = jacobian.rows[r]; b < jacobian.rows[r + 1]; ++b) {
            const int cb = jacobian.cols[b];
            const double v = va * jacobian.values[b];
            if (ca < nc && cb < nc) {
              H_cc(ca, cb) += v;
            } else if (ca < nc && cb >= nc) {
              H_cp(ca, cb - nc) += v;
            } else if (ca >= nc && cb >= nc && (ca - nc) / 3 == (cb - nc) / 3) {
              H_pp[(ca - nc) / 3]((ca - nc) % 3, (cb - nc) % 3) += v;
            }
          }
        }
      }
      Eigen::MatrixXd S = H_cc;
      for (size_t j = 0; j < np; ++j) {
        const Eigen::Matrix3d Hj = H_pp[j] + (1e-12 * H_pp[j].trace() + 1e-300) * Eigen::Matrix3d::Identity();
        const Eigen::Matrix<double, Eigen::Dynamic, 3> B = H_cp.middleCols<3>(3 * static_cast<int>(j));
        S.noalias() -= B * Hj.inverse() * B.transpose();
      }
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
      computed = ldlt.info() == Eigen::Success && ldlt.isPositive();
      if (computed) covariance_cc = ldlt.solve(Eigen::MatrixXd::Identity(nc, nc));
    }
    if (computed) {
      for (size_t st = 0; st < states.size(); ++st) {
        if (!state_used[st]) continue;
        const size_t k = keyframe_index.at(inertial.states[st].keyframe_id);
        const double* b[3] = {poses[k].q.data(), poses[k].t.data(), states[st].v.data()};
        if (!offset.count(b[0]) || !offset.count(b[1]) || !offset.count(b[2]) ||
            !offset.count(states[st].bg.data()) || !offset.count(states[st].ba.data()))
          continue;
        Eigen::Matrix<double, 9, 9> tangent;
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            tangent.block<3, 3>(3 * i, 3 * j) = covariance_cc.block<3, 3>(offset.at(b[i]), offset.at(b[j]));
        // Tangent space of q_cam_world: R_cam_world <- Exp(2 delta) R_cam_world (Ceres' quaternion
        // manifold, half-angle delta). Then theta_world = -2 R_world_cam delta and
        // p_world_cam = -R_world_cam t_cam_world moves by -2 R_world_cam [t]x delta - R_world_cam dt.
        const Pose& T_cw = problem->keyframes[k].T_cam_world;
        const Eigen::Matrix3d R_wc = T_cw.linear().transpose();
        Eigen::Matrix<double, 9, 9> J = Eigen::Matrix<double, 9, 9>::Zero();
        J.block<3, 3>(0, 0) = -2.0 * R_wc * skew(T_cw.translation());
        J.block<3, 3>(0, 3) = -R_wc;
        J.block<3, 3>(3, 0) = -2.0 * R_wc;
        J.block<3, 3>(6, 6) = Eigen::Matrix3d::Identity();
        inertial.states[st].covariance = J * tangent * J.transpose();
        const int o[2] = {offset.at(states[st].bg.data()), offset.at(states[st].ba.data())};
        for (int i = 0; i < 2; ++i)
          for (int j = 0; j < 2; ++j)
            inertial.states[st].bias_covariance.block<3, 3>(3 * i, 3 * j) =
                covariance_cc.block<3, 3>(o[i], o[j]);
        inertial.states[st].has_covariance = true;
      }
    }
    summary.covariance_ms = elapsedMs(covariance_start);
  }

  const std::vector<double> final_errors =
      usable ? reprojectionErrors(*problem, obs_keyframe, obs_point) : initial_errors;
  summary.final_rms_px = rms(final_errors);
  const double outlier_px = 3.0 * config.robust_loss_scale_px;
  for (size_t i = 0; i < num_obs; ++i) {
    if (final_errors[i] < 0.0 || final_errors[i] > outlier_px)
      summary.outliers.push_back(problem->observations[i]);
  }
  summary.solve_ms = elapsedMs(start);
  summary.solve_cpu_ms = threadCpuMs() - start_cpu_ms;
  return summary;
}

/// Moves the problem's world by `delta`: points, camera centres and the altimeter planes. Rotations,
/// velocities, biases, the IMU constraints (position differences) and the covariances do not change.
void translateCamera(Pose* T_cam_world, const Eigen::Vector3d& delta) {
  T_cam_world->translation() -= T_cam_world->linear() * delta;
}

void translateWorld(BaProblem* problem, const Eigen::Vector3d& delta) {
  for (BaKeyframe& kf : problem->keyframes) translateCamera(&kf.T_cam_world, delta);
  for (BaPoint& p : problem->points) p.p_world += delta;
  for (BaRangeObservation& r : problem->ranges) r.plane.centroid_world += delta;
}

/// solveBundle() on the problem moved so that the mean of its camera centres is the origin, its result moved
/// back. The same optimum, but the solver's conditioning no longer depends on where the window is: with
/// T_cam_world blocks, a rotation step moves t_cam_world by the rotation times the distance from the origin,
/// so far from it (a descent kilometres from the landing site, the soak's loops each continuing the last)
/// rotation and translation couple and Levenberg-Marquardt needs more iterations (issue 12: 23 instead of 4
/// for a window 200 km out, AdjustBundle.AWindowFarFromTheOriginIsSolvedAsNearIt; the slowest frames of a
/// looped replay, which wait for the adjustment, went from 11 to 20 ms over 14 loops). Only what the solve
/// changed is copied back, so fixed blocks keep their exact values.
BaSummary adjustBundleImpl(BaProblem* problem, const BundleAdjustmentConfig& config,
                           const std::atomic<bool>* abort, size_t* num_residuals) {
  if (problem == nullptr || problem->keyframes.empty())
    return solveBundle(problem, config, abort, num_residuals);
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (const BaKeyframe& kf : problem->keyframes)
    origin -= kf.T_cam_world.linear().transpose() * kf.T_cam_world.translation();
  origin /= static_cast<double>(problem->keyframes.size());
  if (!origin.allFinite()) return solveBundle(problem, config, abort, num_residuals);
  BaProblem local = *problem;
  translateWorld(&local, -origin);
  std::vector<Pose> moved_poses;
  std::vector<Eigen::Vector3d> moved_points;
  for (const BaKeyframe& kf : local.keyframes) moved_poses.push_back(kf.T_cam_world);
  for (const BaPoint& p : local.points) moved_points.push_back(p.p_world);
  const BaSummary summary = solveBundle(&local, config, abort, num_residuals);
  for (size_t k = 0; k < local.keyframes.size(); ++k) {
    if (local.keyframes[k].T_cam_world.matrix() == moved_poses[k].matrix()) continue;
    problem->keyframes[k].T_cam_world = local.keyframes[k].T_cam_world;
    translateCamera(&problem->keyframes[k].T_cam_world, origin);
  }
  for (size_t j = 0; j < local.points.size(); ++j) {
    if (local.points[j].p_world != moved_points[j])
      problem->points[j].p_world = local.points[j].p_world + origin;
  }
  problem->inertial.states = local.inertial.states;
  return summary;
}

}  // namespace

BaBiasPrior BaBiasPrior::diagonal(uint64_t keyframe_id, const ImuBias& mean, double gyro_sigma_radps,
                                  double accel_sigma_mps2) {
  BaBiasPrior p;
  p.keyframe_id = keyframe_id;
  p.mean = mean;
  p.covariance.diagonal() << Eigen::Vector3d::Constant(gyro_sigma_radps * gyro_sigma_radps),
      Eigen::Vector3d::Constant(accel_sigma_mps2 * accel_sigma_mps2);
  return p;
}

BaSummary adjustBundle(BaProblem* problem, const BundleAdjustmentConfig& config) {
  return adjustBundleImpl(problem, config, nullptr, nullptr);
}

BaSummary refinePose(Pose* T_cam_world, const std::vector<Eigen::Vector3d>& p_world,
                     const std::vector<Eigen::Vector2d>& px, double fx, double fy, double cx, double cy,
                     const BundleAdjustmentConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  if (T_cam_world == nullptr) throw std::invalid_argument("refinePose: null pose");
  if (p_world.size() != px.size()) {
    throw std::invalid_argument("refinePose: " + std::to_string(p_world.size()) + " points but " +
                                std::to_string(px.size()) + " pixels");
  }
  // The same problem as a one-keyframe window with every point fixed: same residual, same loss, same outlier
  // rule, and adjustBundleImpl picks the dense motion-only solver.
  BaProblem problem;
  problem.fx = fx;
  problem.fy = fy;
  problem.cx = cx;
  problem.cy = cy;
  problem.keyframes.push_back(BaKeyframe{0, *T_cam_world, false});
  problem.points.reserve(p_world.size());
  problem.observations.reserve(px.size());
  for (size_t i = 0; i < p_world.size(); ++i) {
    problem.points.push_back(BaPoint{i, p_world[i], true});
    problem.observations.push_back(BaObservation{0, i, px[i]});
  }
  size_t num_residuals = 0;
  BaSummary summary = adjustBundleImpl(&problem, config, nullptr, &num_residuals);
  if (num_residuals == 0) {
    summary.converged = false;  // nothing constrains the pose
  } else if (summary.converged) {
    *T_cam_world = problem.keyframes.front().T_cam_world;
  }
  summary.solve_ms = elapsedMs(start);
  return summary;
}

AsyncBundleAdjuster::AsyncBundleAdjuster(const BundleAdjustmentConfig& config)
    : config_(config), worker_([this] { run(); }) {}

AsyncBundleAdjuster::~AsyncBundleAdjuster() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    queued_.reset();
  }
  abort_.store(true);
  wake_.notify_all();
  covariance_done_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void AsyncBundleAdjuster::submit(BaProblem problem) { submit(std::move(problem), config_); }

void AsyncBundleAdjuster::submit(BaProblem problem, const BundleAdjustmentConfig& solve) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queued_ = std::move(problem);  // a newer window supersedes one that has not started
    queued_config_ = solve;        // the worker reads only the loss and the iteration cap of it
  }
  wake_.notify_one();
}

std::optional<std::pair<BaProblem, BaSummary>> AsyncBundleAdjuster::takeResult() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (error_) {
    std::exception_ptr error = error_;
    error_ = nullptr;
    std::rethrow_exception(error);
  }
  std::optional<std::pair<BaProblem, BaSummary>> result = std::move(finished_);
  finished_.reset();
  return result;
}

std::optional<std::vector<BaInertialState>> AsyncBundleAdjuster::takeCovariance() {
  std::unique_lock<std::mutex> lock(mutex_);
  covariance_done_.wait(lock, [this] { return !covariance_running_; });
  std::optional<std::vector<BaInertialState>> result = std::move(covariance_finished_);
  covariance_finished_.reset();
  return result;
}

void AsyncBundleAdjuster::waitIdle() {
  std::unique_lock<std::mutex> lock(mutex_);
  idle_.wait(lock, [this] { return !running_ && !queued_; });
}

bool AsyncBundleAdjuster::busy() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return running_ || queued_.has_value();
}

void AsyncBundleAdjuster::run() {
  // A lower priority than the tracking thread (Linux: nice is per thread). Raising the nice value needs no
  // privilege; if it fails anyway, the optimiser runs at the tracking's priority, as before.
  if (config_.thread_nice > 0)
    setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), config_.thread_nice);
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stop_ || queued_.has_value(); });
    if (stop_) break;
    BaProblem problem = std::move(*queued_);
    const BundleAdjustmentConfig solve = queued_config_;
    queued_.reset();
    running_ = true;
    lock.unlock();

    // The solve runs without the lock, so submit()/takeResult() never wait for it.
    std::optional<BaSummary> summary;
    std::exception_ptr error;
    const bool want_covariance = problem.inertial.compute_covariance;
    problem.inertial.compute_covariance = false;
    try {
      summary = adjustBundleImpl(&problem, solve, &abort_, nullptr);
    } catch (...) {
      error = std::current_exception();
    }
    // The covariance of the solution: the same problem, zero iterations.
    std::optional<BaProblem> covariance_problem;
    if (want_covariance && !error && summary->converged) {
      covariance_problem = problem;
      covariance_problem->inertial.compute_covariance = true;
    }

    lock.lock();
    running_ = false;
    if (!stop_) {  // an aborted solve is discarded, not published
      if (error) {
        error_ = error;
        finished_.reset();
      } else {
        error_ = nullptr;
        finished_.emplace(std::move(problem), std::move(*summary));
      }
    }
    covariance_running_ = covariance_problem.has_value() && !stop_;
    covariance_finished_.reset();
    idle_.notify_all();
    if (covariance_running_) {
      lock.unlock();
      BundleAdjustmentConfig evaluate_only = solve;
      evaluate_only.max_iterations = 0;
      try {
        adjustBundleImpl(&*covariance_problem, evaluate_only, &abort_, nullptr);
      } catch (...) {
        covariance_problem.reset();  // the solve itself succeeded on the same problem: not expected
      }
      lock.lock();
      if (covariance_problem) covariance_finished_ = std::move(covariance_problem->inertial.states);
      covariance_running_ = false;
      covariance_done_.notify_all();
    }
  }
}

}  // namespace planetary_vo
