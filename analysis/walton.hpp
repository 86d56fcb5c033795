#pragma once
// Walton's collision operator (docs/SPEC.md "Walton's collision operator", thesis
// ch. 3 and appendices A, B), both ways:
//  - forward: pre-collision spheres + material -> post-collision spheres;
//  - inverse: pre- and post-collision kinematics -> e, beta, f, ... of one shot;
//  - the out-of-plane velocity after impact from the spin changes (appendix B).
// Sign conventions as in docs/SPEC.md: n points from sphere 2 to sphere 1, the
// impulse dP acts on sphere 1, v_n = v_c . n < 0 while approaching.
//
// Field names in error messages: the two spheres are "spheres[0]" and
// "spheres[1]" (the C++ field names follow: "spheres[1].diameter_m"), the
// material is "material", a wall is "wall".
#include <array>
#include <string_view>

#include "analysis/result.hpp"
#include "analysis/types.hpp"

namespace collide {

/// Which branch of Walton's rule applied: Coulomb sliding throughout the
/// contact (f = mu), or sliding that stops before separation (beta = beta0).
enum class Regime { Sliding, Rolling };

/// A fixed flat wall of infinite mass. The normal need not be unit length nor
/// point towards the sphere: the side the sphere's centre is on decides.
struct Wall {
  Vec3 point_m = Vec3::Zero();  ///< any point on the plane (m)
  Vec3 normal = Vec3::UnitY();  ///< plane normal, non-zero
};

/// Relative motion at the contact point of two bodies (docs/SPEC.md symbols).
struct ContactKinematics {
  Vec3 normal = Vec3::Zero();       ///< n, unit, from body 2 towards body 1
  Vec3 v_c_m_s = Vec3::Zero();      ///< contact-point (sliding) velocity of 1 relative to 2
  Vec3 v_s_vec_m_s = Vec3::Zero();  ///< tangential part of v_c (vector)
  double v_n_m_s = 0.0;             ///< v_c . n, < 0 on approach
  double v_s_m_s = 0.0;             ///< |tangential part of v_c|, >= 0
  Vec3 tangent = Vec3::Zero();      ///< t = v_s / |v_s|; zero when v_s = 0
  double gamma_rad = 0.0;           ///< incidence angle, cot gamma = v_n / v_s; pi head-on
};

/// What the operator did at one contact.
struct ContactOutcome {
  ContactKinematics before;  ///< n, v_c, v_n, v_s, t, gamma before the impact
  Regime regime = Regime::Rolling;
  double e = 0.0;      ///< normal restitution used
  double beta = 0.0;   ///< tangential restitution, v_s' = -beta v_s
  double f = 0.0;      ///< impulse ratio |dP_t| / |dP_n| (0 head-on)
  double kappa = 0.0;  ///< K of the pair: 1/K = m_12 sum_i (sigma_i/2)^2 / I_i; 2/5 homogeneous
  Vec3 impulse_N_s = Vec3::Zero();  ///< dP, impulse on sphere 1 (N s)
};

struct Collision {
  std::array<Sphere, 2> after;  ///< post-collision spheres (positions unchanged)
  ContactOutcome contact;
};

struct WallCollision {
  Sphere after;  ///< post-collision sphere (position unchanged)
  ContactOutcome contact;
};

/// Checks one sphere: finite position/velocity/spin, mass_kg > 0, diameter_m > 0.
/// `name` prefixes the field in the message, e.g. "spheres[1]" ->
/// "spheres[1].diameter_m: must be > 0 (got -0.01)".
Status validateSphere(const Sphere& s, std::string_view name);

/// Checks e in [0, 1], mu >= 0 (finite), beta0 in [-1, 1]; messages name "material.<field>".
Status validateMaterial(const Material& m);

/// Contact kinematics of two spheres whose centres are at their positions
/// (docs/SPEC.md: n, v_c, v_n, v_s, t, gamma). Exact head-on (v_s = 0) gives t = 0,
/// gamma = pi. Precondition: distinct centres (else n is NaN); no validation.
ContactKinematics contactKinematics(const Sphere& s1, const Sphere& s2);

/// Forward operator for two spheres touching at their current positions.
/// Rolling or sliding, whichever gives the smaller beta (switch at
/// tan gamma0 = mu (1 + 1/K)(1 + e)/(1 + beta0), with -tan gamma = v_s/|v_n|).
/// Errors (message names the field): invalid sphere or material (see the
/// validators); centre distance not within 1 % of (sigma1 + sigma2)/2
/// ("spheres[].position_m"); not approaching, v_n >= 0 ("spheres[].velocity_m_s").
Result<Collision> collideSpheres(const Sphere& s1, const Sphere& s2, const Material& material);

/// Forward operator for a sphere against a fixed wall (infinite mass, no spin).
/// Errors: invalid sphere ("spheres[0]") or material; non-finite wall point or
/// zero/non-finite normal ("wall.point_m", "wall.normal"); centre not at one
/// radius from the plane within 1 % ("spheres[0].position_m"); not approaching.
Result<WallCollision> collideWithWall(const Sphere& s, const Wall& wall, const Material& material);

/// One shot measured from kinematics at the contact instant (docs/SPEC.md step 6).
struct WaltonMeasurement {
  ContactKinematics before;  ///< n, v_c, v_n, v_s, t, gamma before the impact
  ContactKinematics after;   ///< the same after the impact (same n)
  double e = 0.0;            ///< -v_n' / v_n
  /// -v_s' . t / v_s from the post-impact sliding velocity (uses post spins).
  /// NaN when v_s = 0: a head-on impact carries no tangential information.
  double beta = 0.0;
  /// beta from the impulse alone (thesis eq. A.4, generalised to any pair),
  /// without post-impact spins. NaN when v_s = 0.
  double beta_from_impulse = 0.0;
  double f = 0.0;                   ///< |dP_t| / |dP_n|
  double kappa = 0.0;               ///< K of the pair (2/5 for homogeneous spheres)
  Vec3 impulse_N_s = Vec3::Zero();  ///< dP on sphere 1, m_12 [(v1' - v1) - (v2' - v2)]
};

/// Inverse operator, one shot: `before` and `after` hold both spheres' masses,
/// diameters, velocities and spins just before and just after the impact; the
/// positions (centres at contact) are read from `before` only. The impulse is
/// taken as m_12 [(v1' - v1) - (v2' - v2)], which equals m1 (v1' - v1) when
/// momentum is conserved and averages the two estimates when noise breaks it.
/// Contact is not checked to 1 % here: measured centres come from fits and n
/// only needs their direction.
/// Errors: invalid sphere ("spheres[i]" for before, "after.spheres[i]" for
/// after); coincident centres; not approaching (v_n >= 0).
Result<WaltonMeasurement> measureCollision(const std::array<Sphere, 2>& before,
                                           const std::array<Sphere, 2>& after);

/// Inverse operator against a fixed wall (Walton's infinite-mass limit: the
/// wall neither moves nor spins). `before` and `after` are the sphere just
/// before and just after the impact (mass, diameter, velocity, spin; the
/// position, from `before`, only decides which side of the wall it is on).
/// n is the wall's unit normal towards the sphere; the impulse is
/// m (v' - v); e, beta, beta_from_impulse, f and gamma as for two spheres,
/// with kappa = 2/5 for a homogeneous sphere. The two-sphere measureCollision
/// tends to this as the second sphere's mass and inertia grow without bound.
/// Errors: invalid sphere ("spheres[0]", "after.spheres[0]"), bad wall
/// ("wall.point_m", "wall.normal"), not approaching (v_n >= 0).
Result<WaltonMeasurement> measureWallCollision(const Sphere& before, const Sphere& after,
                                               const Wall& wall);

/// Appendix B for a wall: the sphere's out-of-plane (z) velocity after the
/// impact, v_z' = v_z + dP_z / m, when the in-plane velocities and all spin
/// components were measured. The tangential impulse follows from the spin
/// change alone, dP_t = (2 I / sigma) n x d omega (eq. A.2 with the wall's
/// side absent); its z part is dP_z (plus n_z dP_n, from the in-plane impulse,
/// when the normal leans out of the image). Reads position (side), mass,
/// diameter, velocity and spin from `before`, velocity (x, y) and spin from
/// `after`. Errors: as measureWallCollision's validation; a normal within 0.1
/// of the z axis ("wall.normal": the impulse is then mostly along z).
Result<double> wallOutOfPlaneVelocity(const Sphere& before, const Sphere& after, const Wall& wall);

/// Appendix B: the out-of-plane (z) velocities after impact, when only the
/// in-plane velocities but all spin components were measured.
struct OutOfPlaneVelocity {
  double impulse_z_N_s = 0.0;  ///< dP_z, weighted mean of the per-sphere estimates
  double v1z_m_s = 0.0;        ///< v_1z' = v_1z + dP_z / m_1
  double v2z_m_s = 0.0;        ///< v_2z' = v_2z - dP_z / m_2
  int estimates_used = 0;      ///< 2 or 4 (pairs from the x and/or y spin changes)
};

/// dP_z from -n x dP = (2 I_i / sigma_i) d omega_i (eq. A.2), x and y rows, for
/// each sphere (any masses and diameters; identical spheres give thesis eq. B.2).
/// The x pair is left out when |n_y| <= 0.1 |n_x|, the y pair when
/// |n_x| <= 0.1 |n_y|. n_z (zero in the thesis) is allowed: its term uses the
/// in-plane impulse dP_x, dP_y = m_12 [(v1' - v1) - (v2' - v2)].
/// Reads positions, masses, diameters, velocities (x, y; z before) and spins
/// from `before`; x, y velocities and spins from `after` (its z velocities are ignored).
/// Errors: invalid sphere; coincident centres; n within 0.1 of the z axis
/// (no usable estimate: "spheres[].position_m").
Result<OutOfPlaneVelocity> outOfPlaneVelocity(const std::array<Sphere, 2>& before,
                                              const std::array<Sphere, 2>& after);

}  // namespace collide
