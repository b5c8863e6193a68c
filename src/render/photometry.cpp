#include "planetary_vo/render/photometry.h"

#include <algorithm>
#include <cmath>

namespace planetary_vo::render {

double lunarLambertL(double a) {
  // McEwen 1996 polynomial fit of the limb-darkening parameter for lunar highland/mare photometry.
  const double l = 1.0 - 0.019 * a + 2.42e-4 * a * a - 1.46e-6 * a * a * a;
  return std::clamp(l, 0.0, 1.0);
}

double lunarLambertReflectance(double albedo, double cos_i, double cos_e, double phase_deg) {
  if (cos_i <= 0.0 || cos_e <= 0.0) return 0.0;
  const double L = lunarLambertL(phase_deg);
  return albedo * (2.0 * L * cos_i / (cos_i + cos_e) + (1.0 - L) * cos_i);
}

double lunarLambertReflectance(double albedo, const Eigen::Vector3d& n, const Eigen::Vector3d& s,
                               const Eigen::Vector3d& v) {
  const double phase = std::acos(std::clamp(s.dot(v), -1.0, 1.0)) * 180.0 / M_PI;
  return lunarLambertReflectance(albedo, n.dot(s), n.dot(v), phase);
}

Eigen::Vector3d sunDirection(double elevation_deg, double azimuth_deg) {
  const double el = elevation_deg * M_PI / 180.0, az = azimuth_deg * M_PI / 180.0;
  return {std::cos(el) * std::sin(az), std::cos(el) * std::cos(az), std::sin(el)};
}

}  // namespace planetary_vo::render
