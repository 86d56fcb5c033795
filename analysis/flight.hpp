#pragma once
// Ground-truth flight of two spheres for the simulator: launch, free flight
// under gravity, one collision through Walton's operator (analysis/walton.hpp),
// free flight again. In a vacuum exact (closed form); through air (the
// setup's air density > 0) the drag of analysis/air_drag.hpp is integrated
// (classical Runge-Kutta in steps of at most 5 ms: picometres over a flight,
// against the drag's tens of micrometres).
#include <array>
#include <functional>
#include <optional>

#include "analysis/air_drag.hpp"
#include "analysis/result.hpp"
#include "analysis/types.hpp"
#include "analysis/walton.hpp"

namespace collide {

/// Full state of one sphere at one instant (world frame, SI).
struct SphereState {
  Vec3 position_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 spin_rad_s = Vec3::Zero();
  Quat orientation = Quat::Identity();  ///< body -> world rotation
};

struct FlightSetup {
  /// Each sphere's mass, diameter, and its state at its launch instant
  /// (position_m = where it leaves the tube, velocity_m_s = exit velocity,
  /// spin_rad_s = spin at exit).
  std::array<Sphere, 2> spheres;
  std::array<Quat, 2> orientation_at_launch{Quat::Identity(), Quat::Identity()};
  /// Launch instant of each sphere, seconds on the simulation clock. Before it
  /// the sphere rests at its launch position with no velocity or spin.
  std::array<double, 2> launch_time_s{0.0, 0.0};
  Material material;
  /// Optional: normal restitution as a function of |v_n| (m/s); empty -> material.e.
  std::function<double(double)> restitution_of_vn;
  Vec3 gravity_m_s2 = kGravity_m_s2;
  /// The air the spheres fly through (kg/m^3); 0, the default: a vacuum.
  double air_density_kg_m3 = 0.0;
  double air_viscosity_Pa_s = kAirViscosity_Pa_s;
  /// > 0: this drag coefficient at every speed, else the smooth sphere's C_D(Re).
  double drag_coefficient = 0.0;
  /// A fixed wall (infinite mass): when set, sphere 1 (index 0) strikes it
  /// through collideWithWall and sphere 2 takes no part in any collision
  /// (keep it in its tube with a launch time no shot reaches).
  std::optional<Wall> wall;
};

/// A sphere's state `dt_s` seconds on (either way) in free flight: gravity,
/// constant spin and, when it acts, `air`'s drag; what Flight::at does between
/// the launch, the collision and any time asked for.
SphereState freeFlight(const SphereState& s, double dt_s, const Vec3& gravity_m_s2,
                       const AirDrag& air = {});

/// Trajectories of both spheres, with the first collision (if any, after both
/// are launched) resolved through Walton's operator; with a wall, sphere 1's
/// first contact with the wall instead.
class Flight {
 public:
  /// Errors: non-positive mass/diameter, non-finite values, a negative air
  /// density or drag coefficient, spheres overlapping at the later launch instant.
  static Result<Flight> create(const FlightSetup& setup);

  bool collides() const { return collides_; }
  /// Instant of contact (seconds, simulation clock); NaN if they never meet.
  double collisionTime_s() const { return t_collision_; }
  /// Material actually used at the collision (e from restitution_of_vn if given).
  const Material& materialUsed() const { return material_used_; }
  /// Both spheres' full state at time t (any t; before/after collision as appropriate).
  std::array<SphereState, 2> at(double t_s) const;
  /// The states just before and just after the collision (only if collides()).
  const std::array<SphereState, 2>& justBefore() const { return before_; }
  const std::array<SphereState, 2>& justAfter() const { return after_; }
  const FlightSetup& setup() const { return setup_; }

 private:
  static Result<Flight> createWithWall(const FlightSetup& setup);

  FlightSetup setup_;
  bool collides_ = false;
  double t_collision_ = 0.0;
  Material material_used_;
  std::array<SphereState, 2> before_{}, after_{};
};

}  // namespace collide
