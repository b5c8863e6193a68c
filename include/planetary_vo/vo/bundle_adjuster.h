#pragma once
/// @file bundle_adjuster.h
/// Stage 6: windowed bundle adjustment with Ceres (thesis 3.5.2) over a plain problem description, so that the
/// optimiser knows nothing of the map's bookkeeping: the pipeline copies the local window out, the adjuster
/// optimises the copy (in its own thread if asked), and the pipeline writes back what is still alive.
///
/// Poses are T_cam_world (world -> camera, the form the reprojection residual needs); observations are IDEAL
/// (undistorted) pixels of a pinhole camera with intrinsics K.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/config.h"

namespace planetary_vo {

struct BaKeyframe {
  uint64_t id = 0;
  Pose T_cam_world = Pose::Identity();
  bool fixed = false;  ///< held constant (gauge: at least the oldest keyframe of the window, plus those outside)
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

struct BaProblem {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  std::vector<BaKeyframe> keyframes;
  std::vector<BaPoint> points;
  std::vector<BaObservation> observations;
};

struct BaSummary {
  bool converged = false;        ///< Ceres reported a usable solution
  int iterations = 0;
  double initial_rms_px = 0.0;   ///< RMS reprojection error over all observations before
  double final_rms_px = 0.0;     ///< and after the adjustment
  double solve_ms = 0.0;
  /// Observations whose error after the adjustment exceeds the robust-loss scale times 3: the pipeline drops them.
  std::vector<BaObservation> outliers;
};

/// Optimises the non-fixed keyframe poses and points of `problem` in place.
BaSummary adjustBundle(BaProblem* problem, const BundleAdjustmentConfig& config);

/// Motion-only refinement: the camera pose that minimises the robust reprojection error of fixed world points.
/// Returns the summary; `T_cam_world` is updated in place.
BaSummary refinePose(Pose* T_cam_world, const std::vector<Eigen::Vector3d>& p_world,
                     const std::vector<Eigen::Vector2d>& px, double fx, double fy, double cx, double cy,
                     const BundleAdjustmentConfig& config);

/// Runs adjustBundle() in a background thread so that tracking never waits for it (thesis Phase 2).
/// At most one problem is in flight; submitting while busy replaces the queued (not yet started) problem.
/// Threading: submit() and takeResult() may be called from the tracking thread; the worker only touches its own
/// copy of the problem.
class AsyncBundleAdjuster {
 public:
  explicit AsyncBundleAdjuster(const BundleAdjustmentConfig& config);
  ~AsyncBundleAdjuster();  ///< stops and joins the worker
  AsyncBundleAdjuster(const AsyncBundleAdjuster&) = delete;
  AsyncBundleAdjuster& operator=(const AsyncBundleAdjuster&) = delete;

  void submit(BaProblem problem);
  /// The most recent finished adjustment, if one finished since the last call.
  std::optional<std::pair<BaProblem, BaSummary>> takeResult();
  /// Blocks until nothing is queued or running (for reproducible offline runs and tests).
  void waitIdle();
  bool busy() const;

 private:
  void run();
  BundleAdjustmentConfig config_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::optional<BaProblem> queued_;
  std::optional<std::pair<BaProblem, BaSummary>> finished_;
  bool running_ = false;
  bool stop_ = false;
  std::thread worker_;
};

}  // namespace planetary_vo
