#pragma once
/// @file two_view_conditioning.h
/// How well a two-view motion is determined by its points: the 1-sigma of its rotation and of its direction
/// of travel for a given pixel noise, with every point free (the Schur complement of a two-view adjustment
/// over the motion's 5 degrees of freedom and the points). Points in a small part of the view, or too few,
/// let a rotation pass for a translation: the motion then fits the pixels and is still wrong by degrees.

#include <vector>

#include <Eigen/Core>

#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

struct TwoViewConditioning {
  bool valid = false;  ///< false: no point in front of both cameras, or the motion is not determined at all
  double rotation_sigma_deg = 0.0;   ///< largest 1-sigma of the rotation (any axis)
  double direction_sigma_deg = 0.0;  ///< largest 1-sigma of the direction of travel
};

/// @brief The motion's uncertainty from the geometry of its points.
/// @param points_c1 triangulated points in camera 1 (camera 2 at T_c2_c1: p_c2 = T_c2_c1 * p_c1)
/// @param T_c2_c1 the motion; its translation is a direction (any non-zero length)
/// @param fx, fy focal lengths (px); @param sigma_px pixel noise of each coordinate in both views
/// Points behind either camera are skipped. An undetermined motion is reported invalid (sigmas infinite).
TwoViewConditioning twoViewConditioning(const std::vector<Eigen::Vector3d>& points_c1, const Pose& T_c2_c1,
                                        double fx, double fy, double sigma_px);

}  // namespace planetary_vo
