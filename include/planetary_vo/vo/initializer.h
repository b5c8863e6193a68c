#pragma once
/// @file initializer.h
/// Stage 3: two-view motion between a reference frame and the current one (thesis 4.4.4: F, E or H,
/// selectable, or `auto` = H vs E by ORB-SLAM's R_H), with the quality checks of the geometry stage deciding
/// whether the motion is trusted; and the map initialisation that triangulates the inliers at a unit
/// baseline.
///
/// The homography's two-fold ambiguity (peer-results.md: ORB-SLAM2 never initialised on planar descent
/// imagery) is resolved in this order: in-front counts when they differ clearly, then the expected plane
/// normal if one is configured, and, when neither decides, estimateMotion() tries the essential matrix
/// instead. initialize() goes further, as ORB-SLAM does: both decompositions and the essential matrix are
/// triangulated, and the motion that triangulates clearly the most points wins (on ground seen obliquely
/// the wrong twin triangulates far fewer; the essential matrix on near-planar ground can land on that twin
/// too, which is what made the Main Brake 30-degree sequence fail from a slightly different set of tracks),
/// unless a clearly different motion explains the views at a fraction of its reprojection cost: moving
/// mostly along the optical axis, the right motion passes fewer points through the parallax threshold than
/// its more sideways twin, and only the relief's residual tells them apart.
/// A motion its points do not determine (too few of them, or in a small part of the view: a rotation passes
/// for a translation) is rejected as ill-conditioned: its rotation's 1-sigma for 1 px of pixel noise
/// (geometry/two_view_conditioning.h) above motion.max_rotation_sigma_deg.
/// A pose that no check can vouch for is rejected, never guessed.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/geometry/two_view_conditioning.h"
#include "planetary_vo/geometry/two_view_types.h"
#include "planetary_vo/vo/config.h"
#include "planetary_vo/vo/frame_result.h"

namespace planetary_vo {

/// Outcome of one two-view motion estimate.
struct RelativeMotion {
  bool valid = false;
  std::string reason;  ///< why it was rejected ("" when valid)
  MotionEstimate model = MotionEstimate::kNone;
  Pose T_c2_c1_unit = Pose::Identity();  ///< p_c2 = T * p_c1, |t| = 1
  std::vector<uint8_t> inlier_mask;      ///< per input correspondence
  int num_inliers = 0;
  double median_parallax_deg = 0.0;
  bool resolved_by_prior = false;  ///< homography: the plane-normal prior chose between look-alike solutions
};

/// A triangulated two-view map: camera 1 at the origin, camera 2 one unit away.
struct Initialization {
  RelativeMotion motion;
  bool valid = false;
  std::string reason;
  std::vector<uint64_t> track_ids;         ///< of the triangulated points
  std::vector<Eigen::Vector3d> points_c1;  ///< in camera 1, unit baseline
  std::vector<Eigen::Vector2d> px1, px2;   ///< their ideal pixels in both views
  double median_depth = 0.0;               ///< of points_c1, in baselines
  int rival_points = 0;  ///< points triangulated by the best clearly different motion hypothesis (0: none)
  /// The lowest reprojection cost of a clearly different motion on the common correspondences over the chosen
  /// motion's (0: no rival). Initialisation needs it at least 1.5 when the rival triangulates 3/4 as many
  /// points or more.
  double rival_cost_ratio = 0.0;
  /// How well the points determine the motion (1 px of pixel noise); computed for a start that passed the
  /// other checks.
  TwoViewConditioning conditioning;
  /// Rejected because the rotation's 1-sigma exceeds motion.max_rotation_sigma_deg: the points cannot tell a
  /// rotation from a translation, and more parallax with the same points will not change that.
  bool ill_conditioned = false;
};

/// Two-view motion and map initialisation. Stateless apart from its settings; cheap to copy.
class Initializer {
 public:
  /// @param motion model, RANSAC and acceptance thresholds; @param map triangulation thresholds of new
  /// points.
  /// @param prior_plane_normal_c1 expected unit normal of the ground in the camera, pointing away from the
  ///        camera (+z for a nadir camera); zero = no prior.
  Initializer(const MotionConfig& motion, const MapConfig& map,
              const Eigen::Vector3d& prior_plane_normal_c1 = Eigen::Vector3d::UnitZ());

  /// @brief Relative motion of camera 2 w.r.t. camera 1 from ideal pixel correspondences (equal sizes).
  /// @param K intrinsics of both views.
  RelativeMotion estimateMotion(const std::vector<cv::Point2d>& px1, const std::vector<cv::Point2d>& px2,
                                const Eigen::Matrix3d& K) const;

  /// @brief Two-view map: every motion hypothesis (see motionHypotheses()) triangulates its inliers, and the
  ///        one with the most points that pass the checks (in front, reprojection, parallax) wins, unless a
  ///        clearly different motion costs at most 1/1.5 of its reprojection cost on the common
  ///        correspondences (then that one wins). The winner is rejected (wait for more parallax) when a
  ///        rival triangulates at least 3/4 as many points without costing 1.5x more. Valid when at least
  ///        motion.min_inliers points are triangulated and they determine the motion (else ill_conditioned).
  Initialization initialize(const std::vector<uint64_t>& track_ids, const std::vector<cv::Point2d>& px1,
                            const std::vector<cv::Point2d>& px2, const Eigen::Matrix3d& K) const;

  void setPriorPlaneNormal(const Eigen::Vector3d& normal_c1) { prior_normal_c1_ = normal_c1; }
  const MotionConfig& motionConfig() const { return motion_; }

 private:
  TwoViewOptions twoViewOptions() const;
  /// The motions worth triangulating for a map: the configured model's estimate if it passes its checks, and
  /// for a homography (alone or under auto) both decompositions when only their in-front counts tie.
  /// Empty with `reason` set when there is none.
  std::vector<RelativeMotion> motionHypotheses(const std::vector<cv::Point2d>& px1,
                                               const std::vector<cv::Point2d>& px2, const Eigen::Matrix3d& K,
                                               std::string* reason) const;

  MotionConfig motion_;
  MapConfig map_;
  Eigen::Vector3d prior_normal_c1_;
};

}  // namespace planetary_vo
