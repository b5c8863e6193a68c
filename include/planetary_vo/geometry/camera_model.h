#pragma once
/// @file camera_model.h
/// Pinhole camera with optional lens distortion (ROS camera_info conventions: plumb_bob or equidistant).
///
/// Frames follow REP-103: the camera optical frame has z forward along the boresight, x right, y down.
/// Pixel coordinates have their origin at the centre of the top-left pixel.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace planetary_vo {

class PinholeCamera {
 public:
  PinholeCamera() = default;
  PinholeCamera(int width_px, int height_px, double fx, double fy, double cx, double cy,
                std::string distortion_model = "", std::vector<double> distortion = {});

  /// Square pixels, principal point at the image centre, horizontal field of view in degrees.
  static PinholeCamera fromFieldOfView(int width_px, int height_px, double horizontal_fov_deg);

  int width() const { return width_px_; }
  int height() const { return height_px_; }
  double fx() const { return fx_; }
  double fy() const { return fy_; }
  double cx() const { return cx_; }
  double cy() const { return cy_; }
  /// "" or "none" (no distortion), "plumb_bob" (k1 k2 p1 p2 k3), "rational_polynomial" (k1 k2 p1 p2 k3 k4 k5
  /// k6) or "equidistant" (k1 k2 k3 k4).
  const std::string& distortionModel() const { return distortion_model_; }
  const std::vector<double>& distortion() const { return distortion_; }
  bool hasDistortion() const;

  Eigen::Matrix3d K() const;
  cv::Matx33d Kcv() const;

  /// Plausible field of view of either axis, 2 atan(size / 2f): outside it a focal length is a unit or
  /// calibration error (a 1 mm lens given as 1e9 px, a focal length in metres).
  static constexpr double kMinFieldOfViewDeg = 0.1;
  static constexpr double kMaxFieldOfViewDeg = 170.0;

  /// Usable by the geometry: positive size; finite positive focal lengths giving a field of view within
  /// [kMinFieldOfViewDeg, kMaxFieldOfViewDeg] on both axes; principal point inside the image (pixel edges
  /// included); a known distortion model with exactly its number of finite coefficients (plumb_bob 5,
  /// rational_polynomial 8, equidistant 4; none at all = no distortion; non-zero coefficients with no model
  /// are refused, not ignored); and a distortion that is invertible over the image (distortionInvertible()).
  /// On failure, `why` (if given) says what is wrong.
  bool isValid(std::string* why = nullptr) const;
  /// Whether the distortion maps the ideal radius strictly increasingly onto the measured radius all the way
  /// to each image corner, so that every pixel of the image has one ideal pixel; `why` says where not.
  bool distortionInvertible(std::string* why = nullptr) const;

  /// Projects a point in the camera optical frame (z > 0) to ideal (undistorted) pixel coordinates.
  Eigen::Vector2d project(const Eigen::Vector3d& p_in_cam) const;
  /// Ideal pixel -> normalised image coordinates (x/z, y/z).
  Eigen::Vector2d pixelToNormalized(const Eigen::Vector2d& px) const;
  /// Ideal pixel -> unit bearing vector in the camera frame.
  Eigen::Vector3d pixelToBearing(const Eigen::Vector2d& px) const;
  bool isInImage(const Eigen::Vector2d& px, double border_px = 0.0) const;

  /// Removes lens distortion from measured pixels, returning ideal pixels of the same K. No-op without
  /// distortion.
  std::vector<cv::Point2f> undistortPixels(const std::vector<cv::Point2f>& distorted_px) const;

  /// Lens distortion of one ideal pixel (the forward model of the distortion: where the lens puts it).
  Eigen::Vector2d distortPixel(const Eigen::Vector2d& ideal_px) const;
  /// Inverse of distortPixel() by Newton iteration to 1e-10 px (exact where the model is invertible; the
  /// renderer casts its rays through it). `converged` (if given) says whether the iteration met the
  /// tolerance.
  Eigen::Vector2d undistortPixel(const Eigen::Vector2d& distorted_px, bool* converged = nullptr) const;
  /// Unit bearing in the camera frame of a measured (distorted) pixel.
  Eigen::Vector3d distortedPixelToBearing(const Eigen::Vector2d& distorted_px) const {
    return pixelToBearing(undistortPixel(distorted_px));
  }

  bool operator==(const PinholeCamera& other) const;
  bool operator!=(const PinholeCamera& other) const { return !(*this == other); }

 private:
  int width_px_ = 0;
  int height_px_ = 0;
  double fx_ = 0.0, fy_ = 0.0, cx_ = 0.0, cy_ = 0.0;
  std::string distortion_model_;
  std::vector<double> distortion_;
};

}  // namespace planetary_vo
