#pragma once
/// @file photometry.h
/// Lunar surface reflectance. The Moon is not a Lambertian surface: its regolith back-scatters, so limb
/// darkening is weak and brightness depends on the phase angle. McEwen's lunar-Lambert law blends
/// Lommel-Seeliger (the single-scattering term 2 cos i / (cos i + cos e)) and Lambert with a phase-dependent
/// weight L(alpha).

#include <Eigen/Core>

namespace planetary_vo::render {

/// McEwen (1991, 1996) phase function of the lunar-Lambert law, alpha in degrees, clamped to [0, 1].
double lunarLambertL(double phase_deg);

/// Bidirectional reflectance factor (I/F) of the lunar-Lambert law for albedo A:
/// R = A * [2 L cos i / (cos i + cos e) + (1 - L) cos i]; 0 when the surface faces away from the Sun or
/// viewer.
double lunarLambertReflectance(double albedo, double cos_i, double cos_e, double phase_deg);

/// Reflectance of a surface point with unit normal n, unit direction to the Sun s and unit direction to the
/// camera v.
double lunarLambertReflectance(double albedo, const Eigen::Vector3d& n, const Eigen::Vector3d& s,
                               const Eigen::Vector3d& v);

/// Unit vector toward the Sun in the world frame from elevation above the horizon and azimuth measured from
/// world +y (downrange) toward +x (crossrange), both in degrees.
Eigen::Vector3d sunDirection(double elevation_deg, double azimuth_deg);

}  // namespace planetary_vo::render
