#pragma once
// Air drag on a sphere in flight. A 25.4 mm nylon sphere at 1.5 m/s is slowed
// by about 0.03 m/s^2: over a 30 ms track the fitted velocity at the contact
// is then off by half the speed lost (0.4 mm/s), before the impact too fast
// and after it too slow, which takes about 0.0006 off e on every shot
// (docs/benchmarks.md, "Session 41: air drag"). The spheres are slowed by
// F = rho C_D A |v| v / 2 (A the cross-section), C_D from the Reynolds number
// Re = rho |v| d / eta. Lift from spin (Magnus) and the air's own motion are
// not modelled. SI units.
#include "analysis/types.hpp"

namespace collide {

/// Dry air at 20 degrees C and 101.325 kPa.
inline constexpr double kAirDensity_kg_m3 = 1.204;
inline constexpr double kAirViscosity_Pa_s = 1.81e-5;

/// The drag coefficient of a smooth sphere at Reynolds number `re` (> 0):
/// F. A. Morrison's correlation of the measured drag curve (An Introduction
/// to Fluid Mechanics, Cambridge 2013; within a few per cent of
/// Schlichting's data up to Re = 1e6), 24 / Re in creeping flow. NaN for
/// re <= 0 or not finite.
double sphereDragCoefficient(double re);

/// The air a sphere flies through and what it slows it by.
struct AirDrag {
  double diameter_m = 0;
  double mass_kg = 0;
  double air_density_kg_m3 = kAirDensity_kg_m3;  ///< 0: a vacuum, no drag
  double air_viscosity_Pa_s = kAirViscosity_Pa_s;
  /// > 0: this drag coefficient at every speed (a measured one, a rough or
  /// dimpled sphere), else sphereDragCoefficient(Re).
  double drag_coefficient = 0;

  /// Whether there is any drag (a positive density, mass and diameter).
  bool acts() const { return air_density_kg_m3 > 0 && mass_kg > 0 && diameter_m > 0; }
  /// The drag's acceleration (m/s^2) at velocity `v_m_s` (relative to still
  /// air): -(rho C_D(Re) pi d^2 / 8 m) |v| v. Zero at rest or when it does not act.
  Vec3 acceleration(const Vec3& v_m_s) const;
  /// The time (s) to cover `distance_m` along a straight line from the speed
  /// `speed_m_s`, slowed by the drag alone: (e^(k d) - 1) / (k v0) with the
  /// drag coefficient at the starting speed (the speed falls by 0.1 % over
  /// 10 cm: C_D barely moves); distance / speed when the drag does not act.
  /// Gravity across the line is left out (it bends the path, not the time).
  double travelTime_s(double distance_m, double speed_m_s) const;
};

}  // namespace collide
