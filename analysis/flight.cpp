#include "analysis/flight.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "analysis/format.hpp"
#include "analysis/walton.hpp"

namespace collide {
namespace {

using detail::formatNumber;

// Free flight for dt seconds from a state: a parabola under gravity, constant
// spin, and the orientation turned by exp(spin dt) in the world frame (the
// spin is a world-frame vector, so it multiplies on the left).
SphereState propagate(const SphereState& s, double dt_s, const Vec3& g_m_s2) {
  SphereState out = s;
  out.position_m = s.position_m + s.velocity_m_s * dt_s + 0.5 * g_m_s2 * dt_s * dt_s;
  out.velocity_m_s = s.velocity_m_s + g_m_s2 * dt_s;
  const double rate_rad_s = s.spin_rad_s.norm();
  if (rate_rad_s > 0) {
    const Quat turn(Eigen::AngleAxisd(rate_rad_s * dt_s, s.spin_rad_s / rate_rad_s));
    out.orientation = (turn * s.orientation).normalized();
  }
  return out;
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
  return validateMaterial(setup.material);
}

}  // namespace

Result<Flight> Flight::create(const FlightSetup& setup) {
  if (auto st = validateSetup(setup); !st) return st.error();
  Flight f;
  f.setup_ = setup;
  f.material_used_ = setup.material;
  f.t_collision_ = std::numeric_limits<double>::quiet_NaN();

  // Once both fly, gravity acts on both alike: the relative position is
  // linear in time, d(s) = d0 + w s, and contact is the first root of
  // |d(s)|^2 = D^2.
  const double t_both_s = std::max(setup.launch_time_s[0], setup.launch_time_s[1]);
  std::array<SphereState, 2> at_both;
  for (int i = 0; i < 2; ++i)
    at_both[i] =
        propagate(launchState(setup, i), t_both_s - setup.launch_time_s[i], setup.gravity_m_s2);
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
  const double s = c / (-half_b + std::sqrt(disc));
  const double t_c = t_both_s + s;

  for (int i = 0; i < 2; ++i) f.before_[i] = propagate(at_both[i], s, setup.gravity_m_s2);
  const Sphere s1 = withState(setup.spheres[0], f.before_[0]);
  const Sphere s2 = withState(setup.spheres[1], f.before_[1]);
  // A tangent touch (disc = 0) has v_n = 0 at contact: no impulse, no collision.
  const double v_n = contactKinematics(s1, s2).v_n_m_s;
  if (!(v_n < 0)) return f;
  if (setup.restitution_of_vn) {
    const double e = setup.restitution_of_vn(std::abs(v_n));
    if (!(e >= 0 && e <= 1))
      return fail("restitution_of_vn: gave e = " + formatNumber(e) +
                  " at |v_n| = " + formatNumber(std::abs(v_n)) + " m/s; e must be in [0, 1]");
    f.material_used_.e = e;
  }
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

std::array<SphereState, 2> Flight::at(double t_s) const {
  std::array<SphereState, 2> out;
  for (int i = 0; i < 2; ++i) {
    const double t_launch = setup_.launch_time_s[i];
    if (t_s < t_launch) {
      out[i] = launchState(setup_, i);
      out[i].velocity_m_s.setZero();
      out[i].spin_rad_s.setZero();
    } else if (collides_ && t_s >= t_collision_) {
      out[i] = propagate(after_[i], t_s - t_collision_, setup_.gravity_m_s2);
    } else {
      out[i] = propagate(launchState(setup_, i), t_s - t_launch, setup_.gravity_m_s2);
    }
  }
  return out;
}

}  // namespace collide
