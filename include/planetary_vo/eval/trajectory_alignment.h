#pragma once
/// @file trajectory_alignment.h
/// Association of an estimated trajectory with its ground truth by time stamp, and their alignment: Umeyama
/// (with or without scale, as in evo and rpg_trajectory_evaluation), or on the first pose only (what a
/// navigation system handed its initial state produces, with optional errors on that state for Monte Carlo
/// runs).

#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

/// Thrown on input that cannot be evaluated (nothing associated, degenerate alignment, bad option).
class EvalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// How the estimate is aligned to the ground truth before the errors are computed.
enum class AlignmentMode {
  kNone,  ///< compare as they are (the estimate is expressed in the ground-truth world frame)
  kSe3,   ///< rotation + translation (metric estimates, e.g. with an altimeter)
  kSim3,  ///< rotation + translation + scale (monocular estimates, scale unobservable)
  /// rigid transform that puts the first associated estimated pose on the (handed-over) true one:
  /// T_gt_est = T_gt_0 * T_est_0^-1; scale 1 or from a window at the start (see FirstPoseHandover)
  kFirstPose,
};
const char* toString(AlignmentMode mode);
/// "none", "se3", "sim3" or "first" -> mode. Throws EvalError otherwise.
AlignmentMode parseAlignmentMode(const std::string& text);

/// Pairs of poses that were associated: ground_truth[k] and estimate[k] are at (nearly) the same time.
struct AssociatedTrajectories {
  Trajectory ground_truth;
  Trajectory estimate;
  std::vector<size_t> ground_truth_indices;  ///< index of each pair's pose in the input ground truth
  std::vector<size_t> estimate_indices;      ///< index of each pair's pose in the input estimate
  size_t size() const { return ground_truth.size(); }
};

/// Associates each estimated pose with the ground-truth pose nearest in time if |dt| <= max_dt_s, one to one
/// (greedily, smallest |dt| first, as TUM's associate.py), returned in increasing estimate time. Both inputs
/// must be sorted by time.
AssociatedTrajectories associateByTimestamp(const Trajectory& ground_truth, const Trajectory& estimate,
                                            double max_dt_s);

/// Similarity transform mapping estimate-world coordinates into ground-truth-world coordinates:
/// p_gt = scale * R_gt_est * p_est + t_gt_est.
struct Sim3Transform {
  double scale = 1.0;
  Eigen::Matrix3d R_gt_est = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_gt_est_m = Eigen::Vector3d::Zero();

  Eigen::Vector3d transformPoint(const Eigen::Vector3d& p_est) const {
    return scale * R_gt_est * p_est + t_gt_est_m;
  }
  /// The pose T_estworld_cam expressed in the ground-truth world: rotation R * R_cam, position
  /// transformPoint().
  Pose transformPose(const Pose& T_estworld_cam) const;
  Trajectory transformTrajectory(const Trajectory& trajectory) const;
};

/// Least-squares alignment (Umeyama 1991) of the estimate positions onto the ground-truth positions of
/// associated pairs. `num_pairs` > 0 uses only the first num_pairs pairs (e.g. the first second of a
/// descent), 0 all of them. kNone returns the identity; kFirstPose is alignFirstPose() with a default
/// FirstPoseHandover (num_pairs unused). Throws EvalError with fewer than 3 pairs or collinear/coincident
/// positions (rotation unobservable).
Sim3Transform alignTrajectories(const AssociatedTrajectories& pairs, AlignmentMode mode,
                                size_t num_pairs = 0);

/// The state handed over to the navigation at the first associated pose (AlignmentMode::kFirstPose), with the
/// errors a Monte Carlo run may put on it. All zero: the exact true pose, scale 1.
struct FirstPoseHandover {
  /// > 0: an estimate without metric scale (monocular VO) gets the scale ground-truth path length / estimate
  /// path length over the associated poses of the first scale_window_s seconds (what a handed-over velocity
  /// would give; uses the ground truth over that window only). 0: scale 1 (metric estimates). [s]
  double scale_window_s = 0.0;
  /// Error of the handed-over position, added to the true first position, ground-truth world [m].
  Eigen::Vector3d position_error_m = Eigen::Vector3d::Zero();
  /// Error of the handed-over attitude: rotation vector e in the ground-truth world, R_handed = Exp(e) R_gt_0
  /// [deg].
  Eigen::Vector3d attitude_error_deg = Eigen::Vector3d::Zero();
  /// Relative scale error: the scale (1 or the window's) is multiplied by (1 + scale_error). [-]
  double scale_error = 0.0;
};

/// Scale of the first-pose alignment from the first `window_s` seconds of associated pairs (stamps of the
/// ground truth, t - t_0 <= window_s): ground-truth path length / estimate path length. Throws EvalError with
/// fewer than 2 pairs in the window or an estimate that does not move within it.
double firstPoseWindowScale(const AssociatedTrajectories& pairs, double window_s);

/// Alignment on the first associated pair: p_gt = s R p_est + t with R = Exp(e) R_gt_0 R_est_0^T,
/// t = p_gt_0 + dp - s R p_est_0 and s = (window scale or 1) (1 + scale_error), so that the first estimated
/// pose becomes the handed-over one. Throws EvalError without pairs or on a bad window (see
/// firstPoseWindowScale).
Sim3Transform alignFirstPose(const AssociatedTrajectories& pairs, const FirstPoseHandover& handover);

}  // namespace planetary_vo
