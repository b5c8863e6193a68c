#pragma once
/// @file trajectory_alignment.h
/// Association of an estimated trajectory with its ground truth by time stamp, and their alignment (Umeyama,
/// with or without scale), as in evo and rpg_trajectory_evaluation.

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
};
const char* toString(AlignmentMode mode);
/// "none", "se3" or "sim3" -> mode. Throws EvalError otherwise.
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
/// descent), 0 all of them. kNone returns the identity. Throws EvalError with fewer than 3 pairs or
/// collinear/coincident positions (rotation unobservable).
Sim3Transform alignTrajectories(const AssociatedTrajectories& pairs, AlignmentMode mode,
                                size_t num_pairs = 0);

}  // namespace planetary_vo
