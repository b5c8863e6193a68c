#pragma once
/// @file patch_alignment.h
/// Stage 2b: sub-pixel alignment of a feature's anchor patch in a later image (SVO's feature alignment,
/// Forster et al. 2014, section on relaxation: "feature alignment" against the reference patch).
///
/// Frame-to-frame KLT chains its small per-frame errors: after n frames a track has wandered by a random walk
/// of n steps away from the true projection of its point, and the map and bundle adjustment see the wander as
/// geometry. Aligning the patch the feature had when it was anchored (detected, or last re-anchored) directly
/// in the new image replaces that chain by one step: the error no longer grows with the track's age.
///
/// The model is a translation and an affine brightness change (gain, bias), solved by Gauss-Newton with the
/// anchor patch's own gradients (inverse-compositional style: the Jacobian and its normal matrix are computed
/// once per anchor), on bilinear samples of the new image.

#include <vector>

#include <opencv2/core.hpp>

namespace planetary_vo {

/// The intensities of a square patch around an anchored feature, with what the alignment precomputes from
/// them.
struct AnchorPatch {
  int size_px = 0;            ///< side of the patch (odd)
  std::vector<float> values;  ///< size_px^2 intensities, row-major, centred on the anchor position
  std::vector<float> grad_x;  ///< central-difference gradients of the anchor image at the same samples
  std::vector<float> grad_y;
  float mean = 0.f;            ///< mean intensity (the gain acts on values - mean)
  float stddev = 0.f;          ///< standard deviation of the intensities (the patch's contrast)
  cv::Matx44d inverse_normal;  ///< (J^T J)^-1 of the 4 parameters (dx, dy, gain, bias)

  bool valid() const { return size_px > 0; }
};

/// Cuts the anchor patch of `size_px` (odd, >= 3) around `px` out of the 8-bit image `gray`. Returns an
/// invalid patch (size_px 0) when the patch and its gradient ring do not fit in the image or the patch is too
/// flat to be aligned (its normal matrix is singular).
AnchorPatch makeAnchorPatch(const cv::Mat& gray, const cv::Point2f& px, int size_px);

/// What alignPatch() found.
struct PatchAlignment {
  bool converged =
      false;         ///< the translation update fell below epsilon within the iteration cap, inside the image
  cv::Point2f px;    ///< the aligned position (the start position when not converged)
  float gain = 1.f;  ///< intensity in the new image = gain * (anchor - mean) + mean + bias
  float bias = 0.f;
  double rms_residual = 0.0;  ///< RMS intensity residual before the last update (8-bit grey levels)
  /// rms_residual / the anchor patch's stddev: near 0 for a true match (noise only); a local minimum on the
  /// wrong structure leaves a large part of the contrast unexplained.
  double residual_ratio = 0.0;
  int iterations = 0;
};

/// The linear part of the image motion of the homography `H` at `px` (its Jacobian there): the `warp` that
/// alignPatch() takes for a patch anchored at `px` and seen through H. False (and `warp` unchanged) when it
/// is not a plausible patch motion: `px` maps to infinity, the patch is mirrored, or zoomed by more than 4x
/// either way.
bool homographyWarp(const cv::Matx33d& H, const cv::Point2f& px, cv::Matx22f* warp);

/// Aligns `patch` in the 8-bit image `gray`, starting at `start_px`: Gauss-Newton on translation, gain and
/// bias; stops when the translation update is below `epsilon_px` or after `max_iterations`, or when the patch
/// leaves the image (not converged). `warp` is the linear part of the image motion since the anchor
/// (rotation, zoom, shear about the feature): the patch's sample at offset o from its centre is compared with
/// the new image at px + warp * o. It is not estimated here (the tracker takes it from the other tracks).
PatchAlignment alignPatch(const AnchorPatch& patch, const cv::Mat& gray, const cv::Point2f& start_px,
                          int max_iterations, double epsilon_px,
                          const cv::Matx22f& warp = cv::Matx22f::eye());

}  // namespace planetary_vo
