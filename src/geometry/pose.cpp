#include "planetary_vo/geometry/pose.h"

#include <algorithm>
#include <cmath>

namespace planetary_vo {

double rotationAngleDeg(const Eigen::Matrix3d& R) {
  // acos of the trace is ill-conditioned near 0; the quaternion form is accurate everywhere.
  const Eigen::Quaterniond q(R);
  const double half = std::atan2(q.vec().norm(), std::abs(q.w()));
  return 2.0 * half * 180.0 / M_PI;
}

double angleBetweenDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double na = a.norm(), nb = b.norm();
  if (na == 0.0 || nb == 0.0) return 0.0;
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return S;
}

}  // namespace planetary_vo
