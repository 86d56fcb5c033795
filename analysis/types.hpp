#pragma once
// Physical types shared by every layer. SI units throughout: metres, seconds,
// kilograms, radians. Axes (as seen by the camera): x right, y up, z towards
// the camera.
#include <Eigen/Dense>

namespace collide {

using Vec3 = Eigen::Vector3d;
using Quat = Eigen::Quaterniond;

/// Walton's three material properties (docs/SPEC.md).
struct Material {
  double e = 0.97;      ///< normal restitution, [0, 1]
  double mu = 0.176;    ///< sliding friction coefficient, >= 0
  double beta0 = 0.44;  ///< largest tangential restitution, [-1, 1]
};

/// A homogeneous sphere: I = m sigma^2 / 10.
struct Sphere {
  double mass_kg = 0.0;
  double diameter_m = 0.0;
  Vec3 position_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 spin_rad_s = Vec3::Zero();

  double radius_m() const { return 0.5 * diameter_m; }
  double inertia_kg_m2() const { return mass_kg * diameter_m * diameter_m / 10.0; }
};

/// Standard gravity, pointing down the image (-y).
inline const Vec3 kGravity_m_s2{0.0, -9.80665, 0.0};

}  // namespace collide
