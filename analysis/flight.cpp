#include "analysis/flight.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "analysis/format.hpp"
#include "analysis/walton.hpp"

namespace collide {
namespace {

using detail::formatNumber;

// The orientation turned by exp(spin dt) in the world frame (the spin is a
// world-frame vector, so it multiplies on the left); the spin stays constant.
void turn(SphereState& s, double dt_s) {
  const double rate_rad_s = s.spin_rad_s.norm();
  if (rate_rad_s > 0) {
    const Quat q(Eigen::AngleAxisd(rate_rad_s * dt_s, s.spin_rad_s / rate_rad_s));
    s.orientation = (q * s.orientation).normalized();
  }
}

// Free flight for dt seconds from a state: a parabola under gravity in a
// vacuum; through air, the drag integrated by classical Runge-Kutta in equal
// steps of at most kDragStepS. Gravity alone the steps integrate exactly; the
// drag (1e-4 of the motion) changes with the velocity's turn over ~0.1 s, so
// a step's error is ~1e-4 (5 ms / 0.1 s)^5 of it: picometres over a flight.
// Past kDragHorizonS a sphere falls at its terminal speed (the drag
// balances gravity to 1e-6 by then): the flight goes on at that velocity.
constexpr double kDragStepS = 5e-3;
constexpr double kDragHorizonS = 120.0;
SphereState propagate(const SphereState& s, double dt_s, const Vec3& g_m_s2, const AirDrag& drag) {
  SphereState out = s;
  turn(out, dt_s);
  if (!drag.acts() || dt_s == 0) {
    out.position_m = s.position_m + s.velocity_m_s * dt_s + 0.5 * g_m_s2 * dt_s * dt_s;
    out.velocity_m_s = s.velocity_m_s + g_m_s2 * dt_s;
    return out;
  }
  const auto acc = [&](const Vec3& v) { return Vec3(g_m_s2 + drag.acceleration(v)); };
  const double integrated = std::clamp(dt_s, -kDragHorizonS, kDragHorizonS);
  const int n = std::max(1, static_cast<int>(std::ceil(std::abs(integrated) / kDragStepS)));
  const double h = integrated / n;
  Vec3 p = s.position_m, v = s.velocity_m_s;
  for (int i = 0; i < n; ++i) {
    const Vec3 a1 = acc(v), v2 = v + 0.5 * h * a1;
    const Vec3 a2 = acc(v2), v3 = v + 0.5 * h * a2;
    const Vec3 a3 = acc(v3), v4 = v + h * a3;
    const Vec3 a4 = acc(v4);
    p += h / 6 * (v + 2 * v2 + 2 * v3 + v4);
    v += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
  }
  p += v * (dt_s - integrated);
  out.position_m = p;
  out.velocity_m_s = v;
  return out;
}

// Sphere i's air (its mass and diameter, the setup's air).
AirDrag dragOf(const FlightSetup& setup, int i) {
  AirDrag d;
  d.diameter_m = setup.spheres[i].diameter_m;
  d.mass_kg = setup.spheres[i].mass_kg;
  d.air_density_kg_m3 = setup.air_density_kg_m3;
  d.air_viscosity_Pa_s = setup.air_viscosity_Pa_s;
  d.drag_coefficient = setup.drag_coefficient;
  return d;
}

SphereState launchState(const FlightSetup& setup, int i) {
  const Sphere& s = setup.spheres[i];
  return {s.position_m, s.velocity_m_s, s.spin_rad_s, setup.orientation_at_launch[i].normalized()};
}

Sphere withState(Sphere s, const SphereState& st) {
  s.position_m = st.position_m;
  s.velocity_m_s = st.velocity_m_s;
  s.spin_rad_s = st.spin_rad_s;
  return s;
}

Status validateSetup(const FlightSetup& setup) {
  for (int i = 0; i < 2; ++i) {
    // Built with append: GCC 12 warns falsely on "[" + std::to_string(i).
    const std::string idx = std::string("[").append(std::to_string(i)).append("]");
    if (auto st = validateSphere(setup.spheres[i], "spheres" + idx); !st) return st;
    const Quat& q = setup.orientation_at_launch[i];
    if (!q.coeffs().allFinite() || q.coeffs().squaredNorm() == 0)
      return fail("orientation_at_launch" + idx + ": must be a finite, non-zero quaternion");
    if (!std::isfinite(setup.launch_time_s[i]))
      return fail("launch_time_s" + idx + ": must be finite");
  }
  if (!setup.gravity_m_s2.allFinite()) return fail("gravity_m_s2: must be three finite numbers");
  if (!(setup.air_density_kg_m3 >= 0) || !std::isfinite(setup.air_density_kg_m3))
    return fail("air_density_kg_m3: must be >= 0 (0: a vacuum), got " +
                formatNumber(setup.air_density_kg_m3));
  if (setup.air_density_kg_m3 > 0 && !(setup.air_viscosity_Pa_s > 0))
    return fail("air_viscosity_Pa_s: must be > 0, got " + formatNumber(setup.air_viscosity_Pa_s));
  if (!(setup.drag_coefficient >= 0) || !std::isfinite(setup.drag_coefficient))
    return fail("drag_coefficient: must be >= 0 (0: the smooth sphere's), got " +
                formatNumber(setup.drag_coefficient));
  if (setup.wall) {
    if (!setup.wall->point_m.allFinite()) return fail("wall.point_m: must be three finite numbers");
    if (!setup.wall->normal.allFinite() || setup.wall->normal.squaredNorm() == 0)
      return fail("wall.normal: must be three finite numbers, not all zero");
  }
  return validateMaterial(setup.material);
}

// A contact instant found in a vacuum (`s`, s from the start state), moved
// `through_air` to where `gap(s, rate)` (the distance still to close, m, and
// its rate, m/s) is zero, by Newton's steps: the drag moves it by
// microseconds; to 1e-12 s (the Runge-Kutta steps' count changes with s, by
// ~1e-14 s). NaN when the spheres no longer approach there or the steps do
// not settle; a contact at the start stays there.
template <class Gap>
double refineContact(double s, bool through_air, const Gap& gap) {
  if (!through_air || std::isnan(s) || s == 0) return s;
  for (int it = 0; it < 30; ++it) {
    double rate = 0;
    const double g = gap(s, rate);
    if (!(rate < 0)) return std::numeric_limits<double>::quiet_NaN();
    const double step = -g / rate;
    s = std::max(0.0, s + step);
    if (std::abs(step) < 1e-12) return s;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// The first instant s >= 0 after `from` at which the sphere's centre is one
// radius from the wall while approaching it: the height above the plane is
// h(s) = h0 + w s + g_n s^2 / 2 (n towards the sphere's side). NaN: never.
double wallContactAfter(const SphereState& from, double radius_m, const Wall& wall,
                        const Vec3& g_m_s2, Vec3& n_out) {
  Vec3 n = wall.normal.normalized();
  double h0 = (from.position_m - wall.point_m).dot(n);
  if (h0 < 0) {
    n = -n;
    h0 = -h0;
  }
  n_out = n;
  const double c = h0 - radius_m, b = from.velocity_m_s.dot(n), a = 0.5 * g_m_s2.dot(n);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (c <= 0) return b < 0 ? 0.0 : nan;  // launched touching the wall
  double root = nan;
  if (a == 0) {
    if (b < 0) root = -c / b;
  } else {
    const double disc = b * b - 4 * a * c;
    if (disc < 0) return nan;
    const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));
    for (const double r : {q / a, q == 0 ? nan : c / q})
      if (r >= 0 && (std::isnan(root) || r < root)) root = r;
  }
  return root;
}

// The material at impact: `material` with e from setup.restitution_of_vn at
// this normal speed, when the setup gives e as a function of it.
Status restitutionAt(const FlightSetup& setup, double v_n_m_s, Material& material) {
  if (!setup.restitution_of_vn) return Ok{};
  const double e = setup.restitution_of_vn(std::abs(v_n_m_s));
  if (!(e >= 0 && e <= 1))
    return fail("restitution_of_vn: gave e = " + formatNumber(e) +
                " at |v_n| = " + formatNumber(std::abs(v_n_m_s)) + " m/s; e must be in [0, 1]");
  material.e = e;
  return Ok{};
}

}  // namespace

Result<Flight> Flight::createWithWall(const FlightSetup& setup) {
  Flight f;
  f.setup_ = setup;
  f.material_used_ = setup.material;
  f.t_collision_ = std::numeric_limits<double>::quiet_NaN();
  const Wall& wall = *setup.wall;
  const SphereState start = launchState(setup, 0);
  Vec3 n;
  double s = wallContactAfter(start, setup.spheres[0].radius_m(), wall, setup.gravity_m_s2, n);
  if (std::isnan(s)) return f;  // never reaches the wall
  const AirDrag drag = dragOf(setup, 0);
  const double radius_m = setup.spheres[0].radius_m();
  s = refineContact(s, drag.acts(), [&](double at, double& rate) {
    const SphereState st = propagate(start, at, setup.gravity_m_s2, drag);
    rate = st.velocity_m_s.dot(n);
    return (st.position_m - wall.point_m).dot(n) - radius_m;
  });
  if (std::isnan(s)) return f;
  f.before_[0] = propagate(start, s, setup.gravity_m_s2, drag);
  f.before_[1] = launchState(setup, 1);
  const Sphere s1 = withState(setup.spheres[0], f.before_[0]);
  const double v_n = s1.velocity_m_s.dot(n);
  if (!(v_n < 0)) return f;
  if (auto e = restitutionAt(setup, v_n, f.material_used_); !e) return e.error();
  // The contact point on the plane under the centre: the wall as found.
  auto hit = collideWithWall(s1, wall, f.material_used_);
  if (!hit) return hit.error();
  f.after_ = f.before_;
  f.after_[0].velocity_m_s = hit->after.velocity_m_s;
  f.after_[0].spin_rad_s = hit->after.spin_rad_s;
  f.collides_ = true;
  f.t_collision_ = setup.launch_time_s[0] + s;
  return f;
}

Result<Flight> Flight::create(const FlightSetup& setup) {
  if (auto st = validateSetup(setup); !st) return st.error();
  if (setup.wall) return createWithWall(setup);
  Flight f;
  f.setup_ = setup;
  f.material_used_ = setup.material;
  f.t_collision_ = std::numeric_limits<double>::quiet_NaN();

  // Once both fly, gravity acts on both alike: the relative position is
  // linear in time, d(s) = d0 + w s, and contact is the first root of
  // |d(s)|^2 = D^2.
  const double t_both_s = std::max(setup.launch_time_s[0], setup.launch_time_s[1]);
  std::array<SphereState, 2> at_both;
  const std::array<AirDrag, 2> drag{dragOf(setup, 0), dragOf(setup, 1)};
  for (int i = 0; i < 2; ++i)
    at_both[i] = propagate(launchState(setup, i), t_both_s - setup.launch_time_s[i],
                           setup.gravity_m_s2, drag[i]);
  const Vec3 d0 = at_both[0].position_m - at_both[1].position_m;
  const Vec3 w = at_both[0].velocity_m_s - at_both[1].velocity_m_s;
  const double contact_m = 0.5 * (setup.spheres[0].diameter_m + setup.spheres[1].diameter_m);
  // Setups placed exactly in contact must not fail on the last bit.
  if (d0.norm() < contact_m * (1 - 1e-12))
    return fail("spheres[].position_m: the spheres overlap when the later one is launched (t = " +
                formatNumber(t_both_s) + " s, centres " + formatNumber(d0.norm()) +
                " m apart, contact at " + formatNumber(contact_m) +
                " m); move the launch positions apart");
  const double a = w.squaredNorm(), half_b = d0.dot(w);
  const double c = std::max(0.0, d0.squaredNorm() - contact_m * contact_m);
  const double disc = half_b * half_b - a * c;
  if (!(half_b < 0) || disc < 0) return f;  // separating, at rest together, or missing
  // Smaller root written as c / (-b/2 + sqrt(.)): no cancellation since -b > 0.
  // Through air the drags differ (unequal spheres, speeds): from there on.
  const double s =
      refineContact(c / (-half_b + std::sqrt(disc)), drag[0].acts() || drag[1].acts(),
                    [&](double at, double& rate) {
                      const SphereState a = propagate(at_both[0], at, setup.gravity_m_s2, drag[0]);
                      const SphereState b = propagate(at_both[1], at, setup.gravity_m_s2, drag[1]);
                      const Vec3 d = a.position_m - b.position_m;
                      rate = d.dot(a.velocity_m_s - b.velocity_m_s) / d.norm();
                      return d.norm() - contact_m;
                    });
  if (std::isnan(s)) return f;
  const double t_c = t_both_s + s;

  for (int i = 0; i < 2; ++i) f.before_[i] = propagate(at_both[i], s, setup.gravity_m_s2, drag[i]);
  const Sphere s1 = withState(setup.spheres[0], f.before_[0]);
  const Sphere s2 = withState(setup.spheres[1], f.before_[1]);
  // A tangent touch (disc = 0) has v_n = 0 at contact: no impulse, no collision.
  const double v_n = contactKinematics(s1, s2).v_n_m_s;
  if (!(v_n < 0)) return f;
  if (auto e = restitutionAt(setup, v_n, f.material_used_); !e) return e.error();
  auto hit = collideSpheres(s1, s2, f.material_used_);
  if (!hit) return hit.error();
  for (int i = 0; i < 2; ++i) {
    f.after_[i] = f.before_[i];
    f.after_[i].velocity_m_s = hit->after[i].velocity_m_s;
    f.after_[i].spin_rad_s = hit->after[i].spin_rad_s;
  }
  f.collides_ = true;
  f.t_collision_ = t_c;
  return f;
}

SphereState freeFlight(const SphereState& s, double dt_s, const Vec3& gravity_m_s2,
                       const AirDrag& air) {
  return propagate(s, dt_s, gravity_m_s2, air);
}

std::array<SphereState, 2> Flight::at(double t_s) const {
  std::array<SphereState, 2> out;
  for (int i = 0; i < 2; ++i) {
    const double t_launch = setup_.launch_time_s[i];
    if (t_s < t_launch) {
      out[i] = launchState(setup_, i);
      out[i].velocity_m_s.setZero();
      out[i].spin_rad_s.setZero();
    } else if (collides_ && t_s >= t_collision_ && !(setup_.wall && i == 1)) {
      out[i] = propagate(after_[i], t_s - t_collision_, setup_.gravity_m_s2, dragOf(setup_, i));
    } else {
      out[i] =
          propagate(launchState(setup_, i), t_s - t_launch, setup_.gravity_m_s2, dragOf(setup_, i));
    }
  }
  return out;
}

}  // namespace collide
