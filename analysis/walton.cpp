#include "analysis/walton.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "analysis/format.hpp"

namespace collide {
namespace {

using detail::formatNumber;

std::string field(std::string_view name, std::string_view member) {
  return std::string(name) + "." + std::string(member);
}

Status checkFinite(const Vec3& v, std::string_view name, std::string_view member) {
  if (!v.allFinite()) return fail(field(name, member) + ": must be three finite numbers");
  return Ok{};
}

// A rigid body as the operator sees it. A wall is the limit of infinite mass
// and inertia: zero inverse mass and inverse inertia, so one code path serves
// both the sphere pair and the wall.
struct Body {
  double inv_mass_kg = 0.0;        // 1/m
  double radius_m = 0.0;           // centre to contact point
  double inv_inertia_kg_m2 = 0.0;  // 1/I
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 spin_rad_s = Vec3::Zero();
};

Body bodyOf(const Sphere& s) {
  return {1.0 / s.mass_kg, s.radius_m(), 1.0 / s.inertia_kg_m2(), s.velocity_m_s, s.spin_rad_s};
}

// How an impulse dP on body 1 (and -dP on body 2) changes the contact velocity
// v_c: the normal part responds to the reduced mass, the tangential part also
// to both bodies' rotation. From A.1-A.3: (sigma_i/2) d omega_i x n picks up
// (r_i^2 / I_i) dP_t, so
//   v_c' - v_c = dP_n / m_12 + dP_t (1/m_12 + sum_i r_i^2 / I_i),
// which for homogeneous spheres (r^2/I = 5/(2m)) is thesis eq. A.4.
struct PairResponse {
  double inv_m12 = 0.0;         // 1/m_12 = 1/m_1 + 1/m_2
  double inv_tangential = 0.0;  // 1/m_12 + sum_i r_i^2 / I_i
  double kappa = 0.0;           // K with 1/K = m_12 sum_i r_i^2 / I_i

  PairResponse(const Body& b1, const Body& b2) {
    inv_m12 = b1.inv_mass_kg + b2.inv_mass_kg;
    const double rot = b1.radius_m * b1.radius_m * b1.inv_inertia_kg_m2 +
                       b2.radius_m * b2.radius_m * b2.inv_inertia_kg_m2;
    inv_tangential = inv_m12 + rot;
    kappa = inv_m12 / rot;
  }

  Vec3 contactVelocityChange(const Vec3& n, const Vec3& dP) const {
    const Vec3 dP_n = dP.dot(n) * n;
    return inv_m12 * dP_n + inv_tangential * (dP - dP_n);
  }

  // Inverse of contactVelocityChange: the impulse that changes v_c by dv_c.
  Vec3 impulseFor(const Vec3& n, const Vec3& dv_c) const {
    const Vec3 dv_n = dv_c.dot(n) * n;
    return dv_n / inv_m12 + (dv_c - dv_n) / inv_tangential;
  }
};

ContactKinematics kinematicsAlong(const Vec3& n, const Body& b1, const Body& b2) {
  ContactKinematics k;
  k.normal = n;
  k.v_c_m_s = b1.velocity_m_s - b2.velocity_m_s -
              (b1.radius_m * b1.spin_rad_s + b2.radius_m * b2.spin_rad_s).cross(n);
  k.v_n_m_s = k.v_c_m_s.dot(n);
  k.v_s_vec_m_s = k.v_c_m_s - k.v_n_m_s * n;
  k.v_s_m_s = k.v_s_vec_m_s.norm();
  k.tangent = k.v_s_m_s > 0 ? Vec3(k.v_s_vec_m_s / k.v_s_m_s) : Vec3::Zero();
  k.gamma_rad = std::atan2(k.v_s_m_s, k.v_n_m_s);
  return k;
}

// Changes each body's velocity and spin by the impulse dP on body 1 (A.1, A.2):
// -n x dP = (2 I_i / sigma_i) d omega_i for both bodies.
void applyImpulse(const Vec3& n, const Vec3& dP, Body& b1, Body& b2) {
  const Vec3 torque_arm = n.cross(dP);
  b1.velocity_m_s += b1.inv_mass_kg * dP;
  b2.velocity_m_s -= b2.inv_mass_kg * dP;
  b1.spin_rad_s -= b1.radius_m * b1.inv_inertia_kg_m2 * torque_arm;
  b2.spin_rad_s -= b2.radius_m * b2.inv_inertia_kg_m2 * torque_arm;
}

double impulseRatio(const Vec3& n, const Vec3& dP) {
  const double dP_n = dP.dot(n);
  return (dP - dP_n * n).norm() / std::abs(dP_n);
}

// Tangential restitution from a post-impact contact velocity: v_s' = -beta v_s,
// projected on t so that noise out of the (n, t) plane does not bias it.
double betaFrom(const ContactKinematics& before, const Vec3& v_c_after) {
  if (before.v_s_m_s == 0) return std::numeric_limits<double>::quiet_NaN();
  const Vec3 v_s_after = v_c_after - v_c_after.dot(before.normal) * before.normal;
  return -v_s_after.dot(before.tangent) / before.v_s_m_s;
}

Status checkApproaching(const ContactKinematics& k, std::string_view where) {
  if (!(k.v_n_m_s < 0))
    return fail(std::string(where) +
                ".velocity_m_s: the bodies are not approaching at contact (v_n = " +
                formatNumber(k.v_n_m_s) + " m/s, must be < 0); check the velocity and spin signs");
  return Ok{};
}

// Walton's rule at one contact. Preconditions (validated by the callers): n is
// a unit vector, v_n < 0, the material is valid.
ContactOutcome walton(const Vec3& n, const Body& b1, const Body& b2, const Material& m) {
  const PairResponse pair(b1, b2);
  ContactOutcome out;
  out.before = kinematicsAlong(n, b1, b2);
  out.e = m.e;
  out.kappa = pair.kappa;
  const ContactKinematics& k = out.before;
  const double c = (1.0 + 1.0 / pair.kappa) * (1.0 + m.e);
  // Head-on (v_s = 0) has no tangential motion to restitute: rolling with
  // beta0 gives dP_t = 0, so treat sliding's beta as +inf rather than 0/0.
  const double beta_sliding = k.v_s_m_s > 0 ? -1.0 - m.mu * c * k.v_n_m_s / k.v_s_m_s
                                            : std::numeric_limits<double>::infinity();
  out.regime = beta_sliding < m.beta0 ? Regime::Sliding : Regime::Rolling;
  out.beta = out.regime == Regime::Sliding ? beta_sliding : m.beta0;
  const Vec3 dv_c = -(1.0 + m.e) * k.v_n_m_s * n - (1.0 + out.beta) * k.v_s_vec_m_s;
  out.impulse_N_s = pair.impulseFor(n, dv_c);
  out.f = impulseRatio(n, out.impulse_N_s);
  return out;
}

Sphere withMotion(Sphere s, const Body& b) {
  s.velocity_m_s = b.velocity_m_s;
  s.spin_rad_s = b.spin_rad_s;
  return s;
}

Status checkSpheres(const std::array<Sphere, 2>& s) {
  for (int i = 0; i < 2; ++i) {
    auto st = validateSphere(s[i], "spheres[" + std::to_string(i) + "]");
    if (!st) return st;
  }
  if (s[0].position_m == s[1].position_m)
    return fail(
        "spheres[].position_m: both centres are at the same point; the normal is undefined");
  return Ok{};
}

Vec3 normalOf(const Sphere& s1, const Sphere& s2) {
  return (s1.position_m - s2.position_m).normalized();
}

// Both spheres before and after the impact, as bodies, along the measured n.
struct MeasuredShot {
  Vec3 n;
  std::array<Body, 2> before, after;

  // The impulse on sphere 1 from both spheres' velocity changes:
  // m_12 [(v1' - v1) - (v2' - v2)] equals m1 (v1' - v1) = -m2 (v2' - v2) when
  // momentum is conserved, and weighs the two by mass when noise breaks that.
  Vec3 impulse_N_s() const {
    const Vec3 dv_rel = (after[0].velocity_m_s - before[0].velocity_m_s) -
                        (after[1].velocity_m_s - before[1].velocity_m_s);
    return dv_rel / (before[0].inv_mass_kg + before[1].inv_mass_kg);
  }
};

Result<MeasuredShot> readShot(const std::array<Sphere, 2>& before,
                              const std::array<Sphere, 2>& after) {
  if (auto st = checkSpheres(before); !st) return st.error();
  MeasuredShot shot;
  shot.n = normalOf(before[0], before[1]);
  for (int i = 0; i < 2; ++i) {
    const std::string name = "after.spheres[" + std::to_string(i) + "]";
    if (auto st = checkFinite(after[i].velocity_m_s, name, "velocity_m_s"); !st) return st.error();
    if (auto st = checkFinite(after[i].spin_rad_s, name, "spin_rad_s"); !st) return st.error();
    shot.before[i] = bodyOf(before[i]);
    shot.after[i] = shot.before[i];
    shot.after[i].velocity_m_s = after[i].velocity_m_s;
    shot.after[i].spin_rad_s = after[i].spin_rad_s;
  }
  return shot;
}

}  // namespace

Status validateSphere(const Sphere& s, std::string_view name) {
  if (!std::isfinite(s.mass_kg) || !(s.mass_kg > 0))
    return fail(field(name, "mass_kg") + ": must be > 0 (got " + formatNumber(s.mass_kg) + ")");
  if (!std::isfinite(s.diameter_m) || !(s.diameter_m > 0))
    return fail(field(name, "diameter_m") + ": must be > 0 (got " + formatNumber(s.diameter_m) +
                ")");
  for (auto [v, member] :
       {std::pair{&s.position_m, "position_m"}, std::pair{&s.velocity_m_s, "velocity_m_s"},
        std::pair{&s.spin_rad_s, "spin_rad_s"}}) {
    auto st = checkFinite(*v, name, member);
    if (!st) return st;
  }
  return Ok{};
}

Status validateMaterial(const Material& m) {
  if (!(m.e >= 0 && m.e <= 1))
    return fail("material.e: must be in [0, 1] (got " + formatNumber(m.e) + ")");
  if (!(m.mu >= 0) || !std::isfinite(m.mu))
    return fail("material.mu: must be a finite number >= 0 (got " + formatNumber(m.mu) + ")");
  if (!(m.beta0 >= -1 && m.beta0 <= 1))
    return fail("material.beta0: must be in [-1, 1] (got " + formatNumber(m.beta0) + ")");
  return Ok{};
}

ContactKinematics contactKinematics(const Sphere& s1, const Sphere& s2) {
  return kinematicsAlong(normalOf(s1, s2), bodyOf(s1), bodyOf(s2));
}

Result<Collision> collideSpheres(const Sphere& s1, const Sphere& s2, const Material& material) {
  if (auto st = checkSpheres({s1, s2}); !st) return st.error();
  if (auto st = validateMaterial(material); !st) return st.error();
  const double distance_m = (s1.position_m - s2.position_m).norm();
  const double contact_m = 0.5 * (s1.diameter_m + s2.diameter_m);
  if (std::abs(distance_m - contact_m) > 0.01 * contact_m)
    return fail("spheres[].position_m: centres are " + formatNumber(distance_m) +
                " m apart but touch at (sigma1 + sigma2)/2 = " + formatNumber(contact_m) +
                " m; place them in contact (within 1 %)");
  const Vec3 n = normalOf(s1, s2);
  Body b1 = bodyOf(s1), b2 = bodyOf(s2);
  if (auto st = checkApproaching(kinematicsAlong(n, b1, b2), "spheres[]"); !st) return st.error();
  Collision c;
  c.contact = walton(n, b1, b2, material);
  applyImpulse(n, c.contact.impulse_N_s, b1, b2);
  c.after = {withMotion(s1, b1), withMotion(s2, b2)};
  return c;
}

Result<WallCollision> collideWithWall(const Sphere& s, const Wall& wall, const Material& material) {
  if (auto st = validateSphere(s, "spheres[0]"); !st) return st.error();
  if (auto st = checkFinite(wall.point_m, "wall", "point_m"); !st) return st.error();
  if (!wall.normal.allFinite() || wall.normal.squaredNorm() == 0)
    return fail("wall.normal: must be three finite numbers, not all zero");
  if (auto st = validateMaterial(material); !st) return st.error();
  Vec3 n = wall.normal.normalized();
  const double height_m = (s.position_m - wall.point_m).dot(n);
  if (height_m < 0) n = -n;  // n points from the wall (body 2) to the sphere (body 1)
  if (std::abs(std::abs(height_m) - s.radius_m()) > 0.01 * s.radius_m())
    return fail("spheres[0].position_m: centre is " + formatNumber(std::abs(height_m)) +
                " m from the wall but touches it at diameter_m/2 = " + formatNumber(s.radius_m()) +
                " m; place it in contact (within 1 %)");
  Body b1 = bodyOf(s), wall_body;  // wall: zero inverse mass and inertia, at rest
  if (auto st = checkApproaching(kinematicsAlong(n, b1, wall_body), "spheres[0]"); !st)
    return st.error();
  WallCollision c;
  c.contact = walton(n, b1, wall_body, material);
  applyImpulse(n, c.contact.impulse_N_s, b1, wall_body);
  c.after = withMotion(s, b1);
  return c;
}

Result<WaltonMeasurement> measureCollision(const std::array<Sphere, 2>& before,
                                           const std::array<Sphere, 2>& after) {
  auto shot = readShot(before, after);
  if (!shot) return shot.error();
  const Vec3& n = shot->n;
  WaltonMeasurement m;
  m.before = kinematicsAlong(n, shot->before[0], shot->before[1]);
  if (auto st = checkApproaching(m.before, "spheres[]"); !st) return st.error();
  m.after = kinematicsAlong(n, shot->after[0], shot->after[1]);
  const PairResponse pair(shot->before[0], shot->before[1]);
  m.kappa = pair.kappa;
  m.e = -m.after.v_n_m_s / m.before.v_n_m_s;
  m.beta = betaFrom(m.before, m.after.v_c_m_s);
  m.impulse_N_s = shot->impulse_N_s();
  m.beta_from_impulse =
      betaFrom(m.before, m.before.v_c_m_s + pair.contactVelocityChange(n, m.impulse_N_s));
  m.f = impulseRatio(n, m.impulse_N_s);
  return m;
}

Result<WaltonMeasurement> measureWallCollision(const Sphere& before, const Sphere& after,
                                               const Wall& wall) {
  if (auto st = validateSphere(before, "spheres[0]"); !st) return st.error();
  if (auto st = checkFinite(after.velocity_m_s, "after.spheres[0]", "velocity_m_s"); !st)
    return st.error();
  if (auto st = checkFinite(after.spin_rad_s, "after.spheres[0]", "spin_rad_s"); !st)
    return st.error();
  if (auto st = checkFinite(wall.point_m, "wall", "point_m"); !st) return st.error();
  if (!wall.normal.allFinite() || wall.normal.squaredNorm() == 0)
    return fail("wall.normal: must be three finite numbers, not all zero");
  Vec3 n = wall.normal.normalized();
  if ((before.position_m - wall.point_m).dot(n) < 0) n = -n;  // from the wall to the sphere
  const Body b_before = bodyOf(before), wall_body;
  Body b_after = b_before;
  b_after.velocity_m_s = after.velocity_m_s;
  b_after.spin_rad_s = after.spin_rad_s;
  WaltonMeasurement m;
  m.before = kinematicsAlong(n, b_before, wall_body);
  if (auto st = checkApproaching(m.before, "spheres[0]"); !st) return st.error();
  m.after = kinematicsAlong(n, b_after, wall_body);
  const PairResponse pair(b_before, wall_body);
  m.kappa = pair.kappa;
  m.e = -m.after.v_n_m_s / m.before.v_n_m_s;
  m.beta = betaFrom(m.before, m.after.v_c_m_s);
  m.impulse_N_s = before.mass_kg * (after.velocity_m_s - before.velocity_m_s);
  m.beta_from_impulse =
      betaFrom(m.before, m.before.v_c_m_s + pair.contactVelocityChange(n, m.impulse_N_s));
  m.f = impulseRatio(n, m.impulse_N_s);
  return m;
}

Result<double> wallOutOfPlaneVelocity(const Sphere& before, const Sphere& after, const Wall& wall) {
  if (auto st = validateSphere(before, "spheres[0]"); !st) return st.error();
  if (auto st = checkFinite(after.spin_rad_s, "after.spheres[0]", "spin_rad_s"); !st)
    return st.error();
  if (!wall.normal.allFinite() || wall.normal.squaredNorm() == 0)
    return fail("wall.normal: must be three finite numbers, not all zero");
  Vec3 n = wall.normal.normalized();
  if ((before.position_m - wall.point_m).dot(n) < 0) n = -n;
  if (std::hypot(n.x(), n.y()) <= 0.1)
    return fail("wall.normal: within 6 degrees of the camera axis; dP_z cannot be had");
  const double c = 2.0 * before.inertia_kg_m2() / before.diameter_m;  // 2 I / sigma
  const Vec3 dP_t = c * n.cross(after.spin_rad_s - before.spin_rad_s);
  // The normal impulse from the in-plane velocity change along n's in-plane part.
  const Vec3 dv = after.velocity_m_s - before.velocity_m_s;
  const double n_xy2 = n.x() * n.x() + n.y() * n.y();
  const double dP_n = before.mass_kg *
                      (dv.x() * n.x() + dv.y() * n.y() - dP_t.x() / before.mass_kg * n.x() -
                       dP_t.y() / before.mass_kg * n.y()) /
                      n_xy2;
  return before.velocity_m_s.z() + (dP_t.z() + dP_n * n.z()) / before.mass_kg;
}

Result<OutOfPlaneVelocity> outOfPlaneVelocity(const std::array<Sphere, 2>& before,
                                              const std::array<Sphere, 2>& after) {
  auto shot = readShot(before, after);
  if (!shot) return shot.error();
  const Vec3& n = shot->n;
  if (std::hypot(n.x(), n.y()) <= 0.1)
    return fail(
        "spheres[].position_m: the line of centres is within 6 degrees of the camera axis; "
        "dP_z cannot be had from the spin changes");
  // Only the in-plane impulse is measured; it enters through n_z alone.
  const Vec3 dP = shot->impulse_N_s();
  const double dP_x = dP.x(), dP_y = dP.y();
  // Rows x and y of -n x dP = (2 I_i / sigma_i) d omega_i, solved for dP_z:
  //   x: dP_z = (n_z dP_y - c_i d omega_ix) / n_y
  //   y: dP_z = (n_z dP_x + c_i d omega_iy) / n_x
  const bool use_x = !(std::abs(n.y()) <= 0.1 * std::abs(n.x()));
  const bool use_y = !(std::abs(n.x()) <= 0.1 * std::abs(n.y()));
  double sum = 0.0;
  int count = 0;
  for (int i = 0; i < 2; ++i) {
    const double c = 2.0 * before[i].inertia_kg_m2() / before[i].diameter_m;  // 2 I_i / sigma_i
    const Vec3 d_omega = after[i].spin_rad_s - before[i].spin_rad_s;
    if (use_x) {
      sum += (n.z() * dP_y - c * d_omega.x()) / n.y();
      ++count;
    }
    if (use_y) {
      sum += (n.z() * dP_x + c * d_omega.y()) / n.x();
      ++count;
    }
  }
  OutOfPlaneVelocity out;
  out.impulse_z_N_s = sum / count;
  out.v1z_m_s = before[0].velocity_m_s.z() + out.impulse_z_N_s / before[0].mass_kg;
  out.v2z_m_s = before[1].velocity_m_s.z() - out.impulse_z_N_s / before[1].mass_kg;
  out.estimates_used = count;
  return out;
}

}  // namespace collide
