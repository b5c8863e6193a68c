/// @file camera_motion_blur.cpp
/// Image motion of a static scene during the exposure (from the z-depth of the mid-exposure image and the
/// camera poses at exposure start and end) and the blur along it.
///
/// Cost: the undistorted bearing of every pixel is computed once per camera (Newton, warm-started from the
/// neighbouring pixel) and cached; per frame each pixel then costs two rigid transforms and two evaluations
/// of the distortion polynomial.

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>

#include "planetary_vo/sensors/camera_sensor.h"

namespace planetary_vo::sensors {
namespace {

/// The lens distortion of a PinholeCamera on normalised coordinates (same models and conventions as
/// PinholeCamera::distortPixel, which the tests compare it with), without the per-call model dispatch.
struct Distortion {
  enum Model { kNone, kPlumbBob, kRational, kEquidistant } model = kNone;
  double k[8] = {0, 0, 0, 0, 0, 0, 0, 0};

  explicit Distortion(const PinholeCamera& camera) {
    if (!camera.hasDistortion()) return;
    const std::string& m = camera.distortionModel();
    model = m == "equidistant" ? kEquidistant : m == "rational_polynomial" ? kRational : kPlumbBob;
    const size_t used = model == kEquidistant ? 4 : model == kRational ? 8 : 5;
    for (size_t i = 0; i < used && i < camera.distortion().size(); ++i) k[i] = camera.distortion()[i];
  }

  void apply(double x, double y, double* xd, double* yd) const {
    if (model == kNone) {
      *xd = x, *yd = y;
      return;
    }
    const double r2 = x * x + y * y;
    if (model == kEquidistant) {
      const double r = std::sqrt(r2);
      if (r < 1e-15) {
        *xd = x, *yd = y;
        return;
      }
      const double th = std::atan(r), th2 = th * th;
      const double s = th * (1 + th2 * (k[0] + th2 * (k[1] + th2 * (k[2] + th2 * k[3])))) / r;
      *xd = x * s, *yd = y * s;
      return;
    }
    double radial = 1 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
    if (model == kRational) radial /= 1 + r2 * (k[5] + r2 * (k[6] + r2 * k[7]));
    *xd = x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x);
    *yd = y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y;
  }
};

/// Per pixel of one camera: the normalised undistorted coordinates (x/z, y/z) of its ray, and where the
/// distortion model puts them back (the pixel itself up to the Newton tolerance; the reference the frame's
/// displacements are measured from, so that no motion gives no displacement).
struct BearingMap {
  PinholeCamera camera;
  std::vector<double> normalised;  // 2 per pixel
  std::vector<double> reference;   // 2 per pixel (normalised, distorted)
};

std::shared_ptr<const BearingMap> computeBearingMap(const PinholeCamera& camera) {
  auto map = std::make_shared<BearingMap>();
  map->camera = camera;
  const int W = camera.width(), H = camera.height();
  map->normalised.resize(2 * static_cast<size_t>(W) * H);
  map->reference.resize(2 * static_cast<size_t>(W) * H);
  const Distortion distortion(camera);
  for (int r = 0; r < H; ++r) {
    double x = 0.0, y = 0.0;  // warm start: the previous pixel's solution
    for (int c = 0; c < W; ++c) {
      const double tx = (c - camera.cx()) / camera.fx(), ty = (r - camera.cy()) / camera.fy();
      if (c == 0) x = tx, y = ty;
      bool converged = distortion.model == Distortion::kNone;
      if (converged) x = tx, y = ty;
      // Newton on distort(x, y) = (tx, ty) with a central-difference Jacobian, to 1e-12 (normalised).
      for (int it = 0; it < 30 && !converged; ++it) {
        double fx, fy;
        distortion.apply(x, y, &fx, &fy);
        fx -= tx, fy -= ty;
        if (std::abs(fx) + std::abs(fy) < 1e-13) {
          converged = true;
          break;
        }
        constexpr double h = 1e-7;
        double a0, a1, b0, b1, c0, c1, d0, d1;
        distortion.apply(x + h, y, &a0, &a1);
        distortion.apply(x - h, y, &b0, &b1);
        distortion.apply(x, y + h, &c0, &c1);
        distortion.apply(x, y - h, &d0, &d1);
        const double j00 = (a0 - b0) / (2 * h), j10 = (a1 - b1) / (2 * h);
        const double j01 = (c0 - d0) / (2 * h), j11 = (c1 - d1) / (2 * h);
        const double det = j00 * j11 - j01 * j10;
        if (!(std::abs(det) > 1e-300)) break;
        x -= (j11 * fx - j01 * fy) / det;
        y -= (-j10 * fx + j00 * fy) / det;
      }
      if (!converged) {
        // Where the fast iteration fails (e.g. beyond a non-monotonic distortion), the camera's own inverse.
        const Eigen::Vector2d n = camera.pixelToNormalized(camera.undistortPixel(Eigen::Vector2d(c, r)));
        x = n.x(), y = n.y();
      }
      const size_t i = 2 * (static_cast<size_t>(r) * W + c);
      map->normalised[i] = x, map->normalised[i + 1] = y;
      distortion.apply(x, y, &map->reference[i], &map->reference[i + 1]);
    }
  }
  return map;
}

/// The bearing maps of the last few cameras (a sequence uses one; tests a handful).
std::shared_ptr<const BearingMap> bearingMap(const PinholeCamera& camera) {
  static std::mutex mutex;
  static std::vector<std::shared_ptr<const BearingMap>> cache;  // most recent last
  constexpr size_t kCacheSize = 4;
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (size_t i = 0; i < cache.size(); ++i) {
      if (cache[i]->camera == camera) {
        auto hit = cache[i];
        cache.erase(cache.begin() + static_cast<std::ptrdiff_t>(i));
        cache.push_back(hit);
        return hit;
      }
    }
  }
  auto map = computeBearingMap(camera);
  std::lock_guard<std::mutex> lock(mutex);
  cache.push_back(map);
  if (cache.size() > kCacheSize) cache.erase(cache.begin());
  return map;
}

}  // namespace

void imageMotionFromDepth(const cv::Mat1f& depth_m, const PinholeCamera& camera, const Pose& T_mid_start,
                          const Pose& T_mid_end, cv::Mat2f* disp_start_px, cv::Mat2f* disp_end_px) {
  std::string why;
  if (!camera.isValid(&why)) throw std::invalid_argument("imageMotionFromDepth: bad camera: " + why);
  if (depth_m.rows != camera.height() || depth_m.cols != camera.width())
    throw std::invalid_argument("imageMotionFromDepth: depth image size differs from the camera's");
  const auto map = bearingMap(camera);
  const Distortion distortion(camera);
  const int W = camera.width(), H = camera.height();
  const double fx = camera.fx(), fy = camera.fy();
  disp_start_px->create(H, W);
  disp_end_px->create(H, W);
  const Pose T_start_mid = T_mid_start.inverse(), T_end_mid = T_mid_end.inverse();
  const Eigen::Matrix3d Rs = T_start_mid.linear(), Re = T_end_mid.linear();
  const Eigen::Vector3d ts = T_start_mid.translation(), te = T_end_mid.translation();

  for (int r = 0; r < H; ++r) {
    const float* depth = depth_m.ptr<float>(r);
    cv::Vec2f* out_s = disp_start_px->ptr<cv::Vec2f>(r);
    cv::Vec2f* out_e = disp_end_px->ptr<cv::Vec2f>(r);
    for (int c = 0; c < W; ++c) {
      const size_t i = 2 * (static_cast<size_t>(r) * W + c);
      const double nx = map->normalised[i], ny = map->normalised[i + 1];
      const double z = depth[c];
      Eigen::Vector3d ps, pe;
      if (z > 0.0 && std::isfinite(z)) {
        const Eigen::Vector3d p(z * nx, z * ny, z);
        ps = Rs * p + ts;
        pe = Re * p + te;
      } else {
        const Eigen::Vector3d d(nx, ny, 1.0);  // no terrain: a direction, moved by the rotation only
        ps = Rs * d;
        pe = Re * d;
      }
      if (!(ps.z() > 0.0) || !(pe.z() > 0.0)) {
        out_s[c] = cv::Vec2f(0.0f, 0.0f);
        out_e[c] = cv::Vec2f(0.0f, 0.0f);
        continue;
      }
      double xs, ys, xe, ye;
      distortion.apply(ps.x() / ps.z(), ps.y() / ps.z(), &xs, &ys);
      distortion.apply(pe.x() / pe.z(), pe.y() / pe.z(), &xe, &ye);
      const double rx = map->reference[i], ry = map->reference[i + 1];
      out_s[c] = cv::Vec2f(static_cast<float>(fx * (xs - rx)), static_cast<float>(fy * (ys - ry)));
      out_e[c] = cv::Vec2f(static_cast<float>(fx * (xe - rx)), static_cast<float>(fy * (ye - ry)));
    }
  }
}

cv::Mat1f motionBlur(const cv::Mat1f& sharp, const cv::Mat2f& disp_start_px, const cv::Mat2f& disp_end_px,
                     int max_samples) {
  if (disp_start_px.size() != sharp.size() || disp_end_px.size() != sharp.size())
    throw std::invalid_argument("motionBlur: displacement images differ in size from the image");
  if (max_samples < 1) throw std::invalid_argument("motionBlur: max_samples must be >= 1");
  const int W = sharp.cols, H = sharp.rows;
  cv::Mat1f out(H, W);
  const float x_max = static_cast<float>(W - 1), y_max = static_cast<float>(H - 1);
  const size_t stride = sharp.step1();
  auto bilinear = [&](float x, float y) {
    x = std::clamp(x, 0.0f, x_max);
    y = std::clamp(y, 0.0f, y_max);
    const int x0 = std::min(static_cast<int>(x), W - 1), y0 = std::min(static_cast<int>(y), H - 1);
    const int x1 = std::min(x0 + 1, W - 1), y1 = std::min(y0 + 1, H - 1);
    const float ax = x - x0, ay = y - y0;
    const float* r0 = sharp.ptr<float>(y0);
    const float* r1 = sharp.ptr<float>(y1);
    return (1 - ay) * ((1 - ax) * r0[x0] + ax * r0[x1]) + ay * ((1 - ax) * r1[x0] + ax * r1[x1]);
  };
  for (int r = 0; r < H; ++r) {
    const cv::Vec2f* ds = disp_start_px.ptr<cv::Vec2f>(r);
    const cv::Vec2f* de = disp_end_px.ptr<cv::Vec2f>(r);
    const float* in = sharp.ptr<float>(r);
    float* o = out.ptr<float>(r);
    for (int c = 0; c < W; ++c) {
      const float sx = ds[c][0], sy = ds[c][1], ex = de[c][0], ey = de[c][1];
      const float length = std::sqrt(sx * sx + sy * sy) + std::sqrt(ex * ex + ey * ey);
      int whole = static_cast<int>(length);  // ceil without a libm call (length >= 0)
      whole += whole < length;
      const int n = length < 1e-6f ? 1 : std::min(max_samples, whole + 1);
      if (n == 1) {
        o[c] = in[c];  // the mid-exposure sample: the pixel itself
        continue;
      }
      // Path p(s), s in [-1, 1] (start, mid, end): the quadratic through disp_start, 0 and disp_end.
      // |p(s)| <= |disp_start| + |disp_end| on [-1, 1]: away from the border no sample needs clamping.
      float sum = 0.0f;
      const float inv_n = 1.0f / n;
      const bool interior = c - length >= 0.0f && c + length + 1.0f <= x_max && r - length >= 0.0f &&
                            r + length + 1.0f <= y_max;
      for (int k = 0; k < n; ++k) {
        const float s = -1.0f + (2 * k + 1) * inv_n;
        const float a = 0.5f * s * (s - 1.0f), b = 0.5f * s * (s + 1.0f);
        const float x = c + a * sx + b * ex, y = r + a * sy + b * ey;
        if (interior) {
          const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
          const float ax = x - x0, ay = y - y0;
          const float* r0 = sharp.ptr<float>(y0) + x0;
          const float* r1 = r0 + stride;
          sum += (1 - ay) * ((1 - ax) * r0[0] + ax * r0[1]) + ay * ((1 - ax) * r1[0] + ax * r1[1]);
        } else {
          sum += bilinear(x, y);
        }
      }
      o[c] = sum * inv_n;
    }
  }
  return out;
}

}  // namespace planetary_vo::sensors
