#include "planetary_vo/geometry/camera_model.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <Eigen/LU>
#include <opencv2/calib3d.hpp>

namespace planetary_vo {

PinholeCamera::PinholeCamera(int width_px, int height_px, double fx, double fy, double cx, double cy,
                             std::string distortion_model, std::vector<double> distortion)
    : width_px_(width_px),
      height_px_(height_px),
      fx_(fx),
      fy_(fy),
      cx_(cx),
      cy_(cy),
      distortion_model_(std::move(distortion_model)),
      distortion_(std::move(distortion)) {
  if (distortion_model_ == "none") distortion_model_.clear();
}

PinholeCamera PinholeCamera::fromFieldOfView(int width_px, int height_px, double horizontal_fov_deg) {
  const double f = 0.5 * width_px / std::tan(0.5 * horizontal_fov_deg * M_PI / 180.0);
  // Pixel centres are at integer coordinates, so the optical centre of a W-wide image is at (W-1)/2.
  return PinholeCamera(width_px, height_px, f, f, 0.5 * (width_px - 1), 0.5 * (height_px - 1));
}

bool PinholeCamera::hasDistortion() const {
  if (distortion_model_.empty()) return false;
  for (double d : distortion_)
    if (d != 0.0) return true;
  return false;
}

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d K;
  K << fx_, 0, cx_, 0, fy_, cy_, 0, 0, 1;
  return K;
}

cv::Matx33d PinholeCamera::Kcv() const { return cv::Matx33d(fx_, 0, cx_, 0, fy_, cy_, 0, 0, 1); }

namespace {

/// Number of coefficients of each supported distortion model (ROS camera_info / OpenCV conventions).
size_t coefficientCount(const std::string& model) {
  if (model == "plumb_bob") return 5;
  if (model == "rational_polynomial") return 8;
  if (model == "equidistant") return 4;
  return 0;
}

Eigen::Vector2d distortNormalized(const std::string& model, const std::vector<double>& d,
                                  const Eigen::Vector2d& n);

}  // namespace

bool PinholeCamera::isValid(std::string* why) const {
  auto fail = [&](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  if (width_px_ <= 0 || height_px_ <= 0) return fail("image size is not positive");
  if (!std::isfinite(fx_) || !std::isfinite(fy_) || fx_ <= 0.0 || fy_ <= 0.0)
    return fail("focal length is zero, negative or not finite");
  if (!std::isfinite(cx_) || !std::isfinite(cy_)) return fail("principal point is not finite");
  // Inside the image, pixel edges included (pixel centres are at integer coordinates).
  if (cx_ < -0.5 || cx_ > width_px_ - 0.5 || cy_ < -0.5 || cy_ > height_px_ - 0.5)
    return fail("principal point (" + std::to_string(cx_) + ", " + std::to_string(cy_) +
                ") px is outside the " + std::to_string(width_px_) + "x" + std::to_string(height_px_) +
                " image");
  const double fov_x_deg = 2.0 * std::atan(0.5 * width_px_ / fx_) * 180.0 / M_PI;
  const double fov_y_deg = 2.0 * std::atan(0.5 * height_px_ / fy_) * 180.0 / M_PI;
  for (double fov : {fov_x_deg, fov_y_deg})
    if (!(fov >= kMinFieldOfViewDeg && fov <= kMaxFieldOfViewDeg))
      return fail("focal length (fx " + std::to_string(fx_) + ", fy " + std::to_string(fy_) +
                  " px) gives a field of view of " + std::to_string(fov_x_deg) + " x " +
                  std::to_string(fov_y_deg) + " deg, outside the plausible " +
                  std::to_string(kMinFieldOfViewDeg) + " - " + std::to_string(kMaxFieldOfViewDeg) + " deg");
  for (double d : distortion_)
    if (!std::isfinite(d)) return fail("distortion coefficient is not finite");
  if (distortion_model_.empty()) {
    // Coefficients without a model cannot be applied; ignoring them would track on a distorted image as if
    // it were ideal.
    for (double d : distortion_)
      if (d != 0.0)
        return fail(
            "non-zero distortion coefficients without a distortion model (accepted: plumb_bob, "
            "rational_polynomial, equidistant; zeros or none for an ideal camera)");
    return true;
  }
  const size_t needed = coefficientCount(distortion_model_);
  if (needed == 0)
    return fail("unsupported distortion model '" + distortion_model_ +
                "' (accepted: plumb_bob, rational_polynomial, equidistant)");
  // No coefficients at all is an ideal camera (ROS sends plumb_bob with D = []); otherwise exactly the
  // model's.
  if (!distortion_.empty() && distortion_.size() != needed)
    return fail(distortion_model_ + " distortion needs " + std::to_string(needed) + " coefficients, got " +
                std::to_string(distortion_.size()));
  if (hasDistortion() && !distortionInvertible(why)) return false;
  return true;
}

bool PinholeCamera::distortionInvertible(std::string* why) const {
  // Along the ray from the principal point to each image corner (the farthest pixels), the distorted radius
  // must grow strictly with the ideal radius until it reaches the corner: then every measured pixel of the
  // image has exactly one ideal pixel (radially; a small tangential part only shifts it), and the Newton
  // iteration of undistortPixel() converges. Steps of 1/512 of the corner radius, growing by 1 % once larger
  // (the ideal radius of a barrel lens's corner exceeds the measured one), up to 1000x the corner radius.
  const Eigen::Vector2d corners[4] = {{0.0, 0.0},
                                      {double(width_px_ - 1), 0.0},
                                      {0.0, double(height_px_ - 1)},
                                      {double(width_px_ - 1), double(height_px_ - 1)}};
  for (const Eigen::Vector2d& corner : corners) {
    const Eigen::Vector2d n_corner = pixelToNormalized(corner);
    const double r_corner = n_corner.norm();
    if (r_corner < 1e-12) continue;
    const Eigen::Vector2d u = n_corner / r_corner;
    const double step = r_corner / 512.0;
    double r = 0.0, r_distorted = 0.0;
    bool reached = false;
    for (int k = 0; k < 20000 && r < 1000.0 * r_corner; ++k) {
      r += std::max(step, 0.01 * r);
      const double next = distortNormalized(distortion_model_, distortion_, r * u).dot(u);
      if (!std::isfinite(next) || next <= r_distorted) break;
      r_distorted = next;
      if (r_distorted >= r_corner) {
        reached = true;
        break;
      }
    }
    // Huge coefficients squeeze the image into a sliver of view (or stretch it): no lens changes the corner's
    // radius by more than kMaxRadiusRatio (a fisheye's corner at 85 deg off the axis: about 8).
    constexpr double kMaxRadiusRatio = 20.0;
    if (reached && (r_corner > kMaxRadiusRatio * r || r > kMaxRadiusRatio * r_corner)) {
      if (why)
        *why = distortion_model_ + " distortion changes the radius of the image corner from " +
               std::to_string(r * std::max(fx_, fy_)) + " to " +
               std::to_string(r_corner * std::max(fx_, fy_)) + " px: not a plausible field of view";
      return false;
    }
    if (!reached) {
      if (why)
        *why = distortion_model_ +
               " distortion is not invertible over the image: the radial mapping towards "
               "the corner (" +
               std::to_string(int(corner.x())) + ", " + std::to_string(int(corner.y())) +
               ") turns back or saturates at " + std::to_string(r_distorted * std::max(fx_, fy_)) +
               " px from the principal point, before the corner at " +
               std::to_string(r_corner * std::max(fx_, fy_)) + " px";
      return false;
    }
  }
  return true;
}

Eigen::Vector2d PinholeCamera::project(const Eigen::Vector3d& p_in_cam) const {
  return {fx_ * p_in_cam.x() / p_in_cam.z() + cx_, fy_ * p_in_cam.y() / p_in_cam.z() + cy_};
}

Eigen::Vector2d PinholeCamera::pixelToNormalized(const Eigen::Vector2d& px) const {
  return {(px.x() - cx_) / fx_, (px.y() - cy_) / fy_};
}

Eigen::Vector3d PinholeCamera::pixelToBearing(const Eigen::Vector2d& px) const {
  const Eigen::Vector2d n = pixelToNormalized(px);
  return Eigen::Vector3d(n.x(), n.y(), 1.0).normalized();
}

bool PinholeCamera::isInImage(const Eigen::Vector2d& px, double border_px) const {
  return px.x() >= border_px && px.y() >= border_px && px.x() <= width_px_ - 1 - border_px &&
         px.y() <= height_px_ - 1 - border_px;
}

std::vector<cv::Point2f> PinholeCamera::undistortPixels(const std::vector<cv::Point2f>& distorted_px) const {
  if (!hasDistortion() || distorted_px.empty()) return distorted_px;
  std::vector<cv::Point2f> ideal_px;
  const cv::Mat K(Kcv());
  if (distortion_model_ == "equidistant") {
    cv::fisheye::undistortPoints(distorted_px, ideal_px, K, cv::Mat(distortion_).rowRange(0, 4),
                                 cv::noArray(), K);
  } else {
    cv::undistortPoints(distorted_px, ideal_px, K, cv::Mat(distortion_), cv::noArray(), K);
  }
  return ideal_px;
}

namespace {

/// Distortion of normalised coordinates (x/z, y/z) by the ROS camera_info models (OpenCV's conventions).
Eigen::Vector2d distortNormalized(const std::string& model, const std::vector<double>& d,
                                  const Eigen::Vector2d& n) {
  auto coef = [&](size_t i) { return i < d.size() ? d[i] : 0.0; };
  const double x = n.x(), y = n.y(), r2 = x * x + y * y;
  if (model == "equidistant") {
    const double r = std::sqrt(r2);
    if (r < 1e-15) return n;
    const double th = std::atan(r), th2 = th * th;
    const double thd = th * (1 + th2 * (coef(0) + th2 * (coef(1) + th2 * (coef(2) + th2 * coef(3)))));
    return n * (thd / r);
  }
  // plumb_bob: k1 k2 p1 p2 k3; rational_polynomial: k1 k2 p1 p2 k3 k4 k5 k6.
  const double k1 = coef(0), k2 = coef(1), p1 = coef(2), p2 = coef(3), k3 = coef(4);
  double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  if (model == "rational_polynomial") radial /= 1 + r2 * (coef(5) + r2 * (coef(6) + r2 * coef(7)));
  return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
          y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
}

}  // namespace

Eigen::Vector2d PinholeCamera::distortPixel(const Eigen::Vector2d& ideal_px) const {
  if (!hasDistortion()) return ideal_px;
  const Eigen::Vector2d d = distortNormalized(distortion_model_, distortion_, pixelToNormalized(ideal_px));
  return {fx_ * d.x() + cx_, fy_ * d.y() + cy_};
}

Eigen::Vector2d PinholeCamera::undistortPixel(const Eigen::Vector2d& distorted_px, bool* converged) const {
  if (converged) *converged = true;
  if (!hasDistortion()) return distorted_px;
  const Eigen::Vector2d target = pixelToNormalized(distorted_px);
  // Newton on f(n) = distort(n) - target with a central-difference Jacobian, from n = target.
  Eigen::Vector2d n = target;
  const double tol = 1e-10 / std::max(fx_, fy_);
  for (int it = 0; it < 50; ++it) {
    const Eigen::Vector2d f = distortNormalized(distortion_model_, distortion_, n) - target;
    if (f.norm() < tol) {
      return {fx_ * n.x() + cx_, fy_ * n.y() + cy_};
    }
    constexpr double h = 1e-7;
    Eigen::Matrix2d J;
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector2d e = Eigen::Vector2d::Zero();
      e[k] = h;
      J.col(k) = (distortNormalized(distortion_model_, distortion_, n + e) -
                  distortNormalized(distortion_model_, distortion_, n - e)) /
                 (2 * h);
    }
    const Eigen::Vector2d step = J.inverse() * f;  // 2x2: closed form
    if (!step.allFinite()) break;
    n -= step;
  }
  if (converged) *converged = false;
  return {fx_ * n.x() + cx_, fy_ * n.y() + cy_};
}

bool PinholeCamera::operator==(const PinholeCamera& o) const {
  return width_px_ == o.width_px_ && height_px_ == o.height_px_ && fx_ == o.fx_ && fy_ == o.fy_ &&
         cx_ == o.cx_ && cy_ == o.cy_ && distortion_model_ == o.distortion_model_ &&
         distortion_ == o.distortion_;
}

}  // namespace planetary_vo
