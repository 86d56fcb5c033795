#include "analysis/walton.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

using namespace collide;
using ::testing::HasSubstr;

namespace {

// Independent restatements of docs/SPEC.md, written out here rather than taken
// from the code under test.
Vec3 contactVelocity(const Sphere& s1, const Sphere& s2, const Vec3& n) {
  return s1.velocity_m_s - s2.velocity_m_s -
         (0.5 * s1.diameter_m * s1.spin_rad_s + 0.5 * s2.diameter_m * s2.spin_rad_s).cross(n);
}

Vec3 unitNormal(const Sphere& s1, const Sphere& s2) {
  return (s1.position_m - s2.position_m).normalized();
}

Vec3 linearMomentum(const std::array<Sphere, 2>& s) {
  return s[0].mass_kg * s[0].velocity_m_s + s[1].mass_kg * s[1].velocity_m_s;
}

// Angular momentum of one sphere about a fixed point: orbital + spin.
Vec3 angularMomentumAbout(const Sphere& s, const Vec3& point_m) {
  return s.mass_kg * (s.position_m - point_m).cross(s.velocity_m_s) +
         s.inertia_kg_m2() * s.spin_rad_s;
}

double kineticEnergy(const Sphere& s) {
  return 0.5 * s.mass_kg * s.velocity_m_s.squaredNorm() +
         0.5 * s.inertia_kg_m2() * s.spin_rad_s.squaredNorm();
}

Sphere nylon(const Vec3& position_m, const Vec3& velocity_m_s,
             const Vec3& spin_rad_s = Vec3::Zero()) {
  Sphere s;
  s.mass_kg = 0.00979;
  s.diameter_m = 0.0254;
  s.position_m = position_m;
  s.velocity_m_s = velocity_m_s;
  s.spin_rad_s = spin_rad_s;
  return s;
}

Vec3 randomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Vec3 v(g(rng), g(rng), g(rng));
  return v.normalized();
}

Vec3 randomVec(std::mt19937_64& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return Vec3(u(rng), u(rng), u(rng));
}

// Random touching, approaching pair of arbitrary masses, sizes, spins. Rejects
// near-grazing (|v_n| < 1 cm/s) and near-head-on (v_s < 1 cm/s) contacts: there
// e or beta are ratios of vanishing quantities and no measurement recovers them.
std::array<Sphere, 2> randomPair(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> mass(0.001, 0.05), diam(0.005, 0.05);
  for (;;) {
    Sphere s1, s2;
    s1.mass_kg = mass(rng);
    s2.mass_kg = mass(rng);
    s1.diameter_m = diam(rng);
    s2.diameter_m = diam(rng);
    const Vec3 n = randomUnit(rng);
    s2.position_m = randomVec(rng, 0.1);
    s1.position_m = s2.position_m + 0.5 * (s1.diameter_m + s2.diameter_m) * n;
    s1.velocity_m_s = randomVec(rng, 3.0);
    s2.velocity_m_s = randomVec(rng, 3.0);
    s1.spin_rad_s = randomVec(rng, 200.0);
    s2.spin_rad_s = randomVec(rng, 200.0);
    const Vec3 v_c = contactVelocity(s1, s2, n);
    const double v_n = v_c.dot(n);
    const double v_s = (v_c - v_n * n).norm();
    if (v_n < -0.01 && v_s > 0.01) return {s1, s2};
  }
}

Material randomMaterial(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> e(0.0, 1.0), mu(0.0, 0.8), b0(-1.0, 1.0);
  return {e(rng), mu(rng), b0(rng)};
}

// SPEC: beta for homogeneous spheres (K = 2/5), whichever regime gives the smaller.
double specBeta(const Material& m, double v_n, double v_s) {
  const double sliding = -1.0 - m.mu * 3.5 * (1.0 + m.e) * v_n / v_s;
  return std::min(sliding, m.beta0);
}

}  // namespace

// The operator's outcome must satisfy every law it was built from, checked
// here with formulas independent of the implementation: momentum conservation,
// angular momentum of each sphere about the contact point (the impulse acts
// there), v_n' = -e v_n, v_s' = -beta v_s with SPEC's beta, f per regime, and
// no energy created. Any masses, sizes and 3-D spins.
TEST(Walton, RandomCollisionsObeyConservationAndWaltonsRule) {
  std::mt19937_64 rng(20240611);
  int sliding = 0, rolling = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    const auto before = randomPair(rng);
    const Material mat = randomMaterial(rng);
    auto c = collideSpheres(before[0], before[1], mat);
    ASSERT_TRUE(c.ok()) << c.error().message;
    const auto& after = c->after;

    const double p_scale = linearMomentum({before[0], before[1]}).norm() +
                           before[0].mass_kg * before[0].velocity_m_s.norm() +
                           before[1].mass_kg * before[1].velocity_m_s.norm();
    EXPECT_LT((linearMomentum(after) - linearMomentum(before)).norm(), 1e-14 * p_scale);

    const Vec3 n = unitNormal(before[0], before[1]);
    const Vec3 contact_m = before[1].position_m + 0.5 * before[1].diameter_m * n;
    for (int i = 0; i < 2; ++i) {
      const Vec3 L0 = angularMomentumAbout(before[i], contact_m);
      const Vec3 L1 = angularMomentumAbout(after[i], contact_m);
      const double scale =
          before[i].mass_kg * before[i].diameter_m *
          (before[i].velocity_m_s.norm() + before[i].diameter_m * before[i].spin_rad_s.norm());
      EXPECT_LT((L1 - L0).norm(), 1e-13 * scale) << "sphere " << i << " trial " << trial;
    }

    const double ke0 = kineticEnergy(before[0]) + kineticEnergy(before[1]);
    const double ke1 = kineticEnergy(after[0]) + kineticEnergy(after[1]);
    EXPECT_LE(ke1, ke0 * (1 + 1e-12));

    const Vec3 v_c = contactVelocity(before[0], before[1], n);
    const Vec3 v_c_after = contactVelocity(after[0], after[1], n);
    const double v_n = v_c.dot(n);
    const Vec3 v_s_vec = v_c - v_n * n;
    const double v_s = v_s_vec.norm();
    const double beta = specBeta(mat, v_n, v_s);
    EXPECT_NEAR(v_c_after.dot(n), -mat.e * v_n, 1e-12);
    EXPECT_LT((v_c_after - v_c_after.dot(n) * n + beta * v_s_vec).norm(), 1e-11);
    EXPECT_NEAR(c->contact.beta, beta, 1e-12);
    EXPECT_NEAR(c->contact.before.v_n_m_s, v_n, 1e-12);
    EXPECT_NEAR(c->contact.before.v_s_m_s, v_s, 1e-12);
    EXPECT_NEAR(c->contact.kappa, 0.4, 1e-12);
    EXPECT_LT((c->contact.impulse_N_s -
               before[0].mass_kg * (after[0].velocity_m_s - before[0].velocity_m_s))
                  .norm(),
              1e-15);
    if (c->contact.regime == Regime::Sliding) {
      ++sliding;
      EXPECT_NEAR(c->contact.f, mat.mu, 1e-12);
    } else {
      ++rolling;
      EXPECT_EQ(c->contact.beta, mat.beta0);
      EXPECT_NEAR(c->contact.f, -(1.0 / 3.5) * (1 + mat.beta0) / (1 + mat.e) * v_s / v_n, 1e-12);
    }
  }
  EXPECT_GT(sliding, 1000);
  EXPECT_GT(rolling, 1000);
}

// Forward, then the inverse on the forward's output, must give back the
// material (e), the regime's beta and f, both ways of getting beta, and dP.
TEST(Walton, InverseRecoversForwardOverRandomGeometries) {
  std::mt19937_64 rng(77);
  int sliding = 0, rolling = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    const auto before = randomPair(rng);
    const Material mat = randomMaterial(rng);
    auto c = collideSpheres(before[0], before[1], mat);
    ASSERT_TRUE(c.ok()) << c.error().message;
    auto m = measureCollision(before, c->after);
    ASSERT_TRUE(m.ok()) << m.error().message;
    EXPECT_NEAR(m->e, mat.e, 1e-9) << "trial " << trial;
    EXPECT_NEAR(m->beta, c->contact.beta, 1e-9) << "trial " << trial;
    EXPECT_NEAR(m->beta_from_impulse, c->contact.beta, 1e-9) << "trial " << trial;
    EXPECT_NEAR(m->f, c->contact.f, 1e-9) << "trial " << trial;
    EXPECT_LT((m->impulse_N_s - c->contact.impulse_N_s).norm(), 1e-12);
    EXPECT_LT((m->before.normal - c->contact.before.normal).norm(), 1e-15);
    EXPECT_NEAR(m->before.gamma_rad, c->contact.before.gamma_rad, 1e-12);
    EXPECT_NEAR(m->after.v_n_m_s, -mat.e * m->before.v_n_m_s, 1e-12);
    if (c->contact.regime == Regime::Sliding) {
      ++sliding;
      EXPECT_NEAR(m->f, mat.mu, 1e-9);
    } else {
      ++rolling;
      EXPECT_NEAR(m->beta, mat.beta0, 1e-9);
    }
  }
  EXPECT_GT(sliding, 1000);
  EXPECT_GT(rolling, 1000);
}

// SPEC: beta = -1 - (1 + 1/K)(1 + e) f cot(gamma) ties any measured triple.
TEST(Walton, MeasuredTripleSatisfiesSpecRelation) {
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 1000; ++trial) {
    const auto before = randomPair(rng);
    const Material mat = randomMaterial(rng);
    auto c = collideSpheres(before[0], before[1], mat);
    ASSERT_TRUE(c.ok());
    auto m = measureCollision(before, c->after);
    ASSERT_TRUE(m.ok());
    const double cot_gamma = 1.0 / std::tan(m->before.gamma_rad);
    EXPECT_NEAR(m->beta, -1.0 - 3.5 * (1 + m->e) * m->f * cot_gamma, 1e-9);
  }
}

// Identical spheres in the image plane, the second at rest, the first arriving
// at incidence angle set by v_s/|v_n| (no spin: v_c = v_1).
std::array<Sphere, 2> identicalAtTangent(double tan_incidence) {
  const Vec3 n(std::cos(0.3), std::sin(0.3), 0.0);
  const Vec3 t = Vec3::UnitZ().cross(n);
  const Sphere s2 = nylon(Vec3(0.1, 0.2, 0.0), Vec3::Zero());
  const Sphere s1 = nylon(s2.position_m + 0.0254 * n, -1.5 * n + 1.5 * tan_incidence * t);
  return {s1, s2};
}

TEST(Walton, SwitchSitsAtSpecTanGamma0) {
  const Material mat{0.97, 0.176, 0.44};
  const double tan_gamma0 = mat.mu * (1 + 1 / 0.4) * (1 + mat.e) / (1 + mat.beta0);
  // Thesis, 2.54 cm Nylon: gamma0 about 40 degrees.
  EXPECT_NEAR(std::atan(tan_gamma0) * 180 / std::numbers::pi, 40.0, 1.0);
  auto below = identicalAtTangent(tan_gamma0 * (1 - 1e-6));
  auto above = identicalAtTangent(tan_gamma0 * (1 + 1e-6));
  auto cb = collideSpheres(below[0], below[1], mat);
  auto ca = collideSpheres(above[0], above[1], mat);
  ASSERT_TRUE(cb.ok() && ca.ok());
  EXPECT_EQ(cb->contact.regime, Regime::Rolling);
  EXPECT_EQ(ca->contact.regime, Regime::Sliding);
  // beta is continuous across the switch: both sides sit at beta0.
  EXPECT_NEAR(ca->contact.beta, mat.beta0, 1e-5);
  EXPECT_NEAR(cb->contact.f, mat.mu, 1e-5);
  // Far on either side the regimes stay put.
  auto head_on_ish = identicalAtTangent(0.2 * tan_gamma0);
  auto grazing = identicalAtTangent(5 * tan_gamma0);
  EXPECT_EQ(collideSpheres(head_on_ish[0], head_on_ish[1], mat)->contact.regime, Regime::Rolling);
  EXPECT_EQ(collideSpheres(grazing[0], grazing[1], mat)->contact.regime, Regime::Sliding);
}

// Thesis Fig. 3.4 forms for identical spheres, with v_s' the post-impact
// tangential contact velocity along t (signed):
//   sliding -v_s'/v_n = -v_s/v_n - (7/2) mu (1 + e);  rolling v_s'/v_n = -beta0 v_s/v_n.
TEST(Walton, TangentOfAngleFormsHoldForIdenticalSpheres) {
  const Material mat{0.9, 0.2, 0.35};
  int checked_sliding = 0, checked_rolling = 0;
  for (double tan_in : {0.05, 0.3, 0.6, 0.9, 1.5, 3.0, 10.0}) {
    auto s = identicalAtTangent(tan_in);
    // Spin on both spheres, in and out of the plane, to exercise the full v_c.
    s[0].spin_rad_s = Vec3(30, -20, 50);
    s[1].spin_rad_s = Vec3(-10, 40, 5);
    auto c = collideSpheres(s[0], s[1], mat);
    ASSERT_TRUE(c.ok());
    const Vec3 n = unitNormal(s[0], s[1]);
    const Vec3 v_c = contactVelocity(s[0], s[1], n);
    const double v_n = v_c.dot(n);
    const Vec3 t = (v_c - v_n * n).normalized();
    const double v_s = (v_c - v_n * n).norm();
    const double v_s_after = contactVelocity(c->after[0], c->after[1], n).dot(t);
    if (c->contact.regime == Regime::Sliding) {
      ++checked_sliding;
      EXPECT_NEAR(-v_s_after / v_n, -v_s / v_n - 3.5 * mat.mu * (1 + mat.e), 1e-12);
    } else {
      ++checked_rolling;
      EXPECT_NEAR(v_s_after / v_n, -mat.beta0 * v_s / v_n, 1e-12);
    }
  }
  EXPECT_GE(checked_sliding, 2);
  EXPECT_GE(checked_rolling, 2);
}

// Thesis eq. A.4 for homogeneous spheres: v_c' - v_c = (7/2) dP/m_12 - (5/2) dP_n/m_12,
// checked on unequal spheres with 3-D spins, and beta from it equals beta direct.
TEST(Walton, EquationA4HoldsAndGivesDirectBeta) {
  std::mt19937_64 rng(99);
  for (int trial = 0; trial < 500; ++trial) {
    const auto before = randomPair(rng);
    const Material mat = randomMaterial(rng);
    auto c = collideSpheres(before[0], before[1], mat);
    ASSERT_TRUE(c.ok());
    const Vec3 n = unitNormal(before[0], before[1]);
    const double m12 =
        before[0].mass_kg * before[1].mass_kg / (before[0].mass_kg + before[1].mass_kg);
    const Vec3 dP = c->contact.impulse_N_s;
    const Vec3 lhs =
        contactVelocity(c->after[0], c->after[1], n) - contactVelocity(before[0], before[1], n);
    const Vec3 rhs = 3.5 * dP / m12 - 2.5 * dP.dot(n) * n / m12;
    EXPECT_LT((lhs - rhs).norm(), 1e-11);
    auto m = measureCollision(before, c->after);
    ASSERT_TRUE(m.ok());
    EXPECT_NEAR(m->beta_from_impulse, m->beta, 1e-9);
  }
}

// beta_from_impulse must not read the post-impact spins: scrambling them
// changes beta (direct) but not beta_from_impulse.
TEST(Walton, BetaFromImpulseIgnoresPostSpins) {
  auto s = identicalAtTangent(0.7);
  auto c = collideSpheres(s[0], s[1], Material{});
  ASSERT_TRUE(c.ok());
  auto scrambled = c->after;
  scrambled[0].spin_rad_s += Vec3(0, 0, 80);
  auto m0 = measureCollision(s, c->after);
  auto m1 = measureCollision(s, scrambled);
  ASSERT_TRUE(m0.ok() && m1.ok());
  EXPECT_EQ(m1->beta_from_impulse, m0->beta_from_impulse);
  EXPECT_GT(std::abs(m1->beta - m0->beta), 0.1);
}

TEST(Walton, HeadOnIsFiniteAndAnalytic) {
  const double u = 2.0, e = 0.8;
  const Sphere s1 = nylon(Vec3(0.0254, 0, 0), Vec3(-u, 0, 0));
  const Sphere s2 = nylon(Vec3(0, 0, 0), Vec3(u, 0, 0));
  auto c = collideSpheres(s1, s2, Material{e, 0.3, 0.4});
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->contact.regime, Regime::Rolling);
  EXPECT_EQ(c->contact.f, 0.0);
  EXPECT_EQ(c->contact.before.v_s_m_s, 0.0);
  EXPECT_NEAR(c->contact.before.gamma_rad, std::numbers::pi, 1e-15);
  EXPECT_TRUE(c->contact.impulse_N_s.allFinite());
  EXPECT_LT((c->after[0].velocity_m_s - Vec3(e * u, 0, 0)).norm(), 1e-14);
  EXPECT_LT((c->after[1].velocity_m_s - Vec3(-e * u, 0, 0)).norm(), 1e-14);
  EXPECT_EQ(c->after[0].spin_rad_s, Vec3::Zero());
  // The inverse still gives e and f; beta is undefined head-on.
  auto m = measureCollision({s1, s2}, c->after);
  ASSERT_TRUE(m.ok());
  EXPECT_NEAR(m->e, e, 1e-14);
  EXPECT_EQ(m->f, 0.0);
  EXPECT_TRUE(std::isnan(m->beta));
}

// Unequal masses head-on: the textbook 1-D result with restitution e.
TEST(Walton, UnequalMassesHeadOnMatchesOneDimensionalFormula) {
  Sphere s1 = nylon(Vec3(0.03, 0, 0), Vec3(-1.0, 0, 0));
  Sphere s2 = nylon(Vec3(0, 0, 0), Vec3(0.5, 0, 0));
  s1.mass_kg = 0.02;
  s1.diameter_m = 0.0346;  // contact distance (0.0346 + 0.0254)/2 = 0.03
  const double e = 0.6, m1 = s1.mass_kg, m2 = s2.mass_kg, u1 = -1.0, u2 = 0.5;
  auto c = collideSpheres(s1, s2, Material{e, 0.2, 0.4});
  ASSERT_TRUE(c.ok());
  const double v1 = (m1 * u1 + m2 * u2 + m2 * e * (u2 - u1)) / (m1 + m2);
  const double v2 = (m1 * u1 + m2 * u2 + m1 * e * (u1 - u2)) / (m1 + m2);
  EXPECT_NEAR(c->after[0].velocity_m_s.x(), v1, 1e-14);
  EXPECT_NEAR(c->after[1].velocity_m_s.x(), v2, 1e-14);
}

// Appendix B: the forward collision's v_z' is recovered from the spin changes
// and the in-plane velocities alone (the z velocities after are hidden).
TEST(Walton, OutOfPlaneVelocityRecoveredFromSpinChanges) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(0, 2 * std::numbers::pi);
  int with_z = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const double a = angle(rng);
    const Vec3 n(std::cos(a), std::sin(a), 0.0);
    Sphere s2 = nylon(Vec3(0, 0.1, 0), Vec3(randomVec(rng, 2).x(), randomVec(rng, 2).y(), 0));
    Sphere s1 =
        nylon(s2.position_m + 0.0254 * n, Vec3(randomVec(rng, 2).x(), randomVec(rng, 2).y(), 0));
    if (trial % 2) {  // unequal spheres: the general form, not only eq. B.2
      s1.mass_kg = 0.0031;
      s1.diameter_m = 0.0127;
      s1.position_m = s2.position_m + 0.5 * (0.0127 + 0.0254) * n;
    }
    // In-plane spin components give v_c a z part: an out-of-plane tangential
    // impulse, so v_z' is non-zero.
    s1.spin_rad_s = randomVec(rng, 150);
    s2.spin_rad_s = randomVec(rng, 150);
    if (contactVelocity(s1, s2, n).dot(n) > -0.05) continue;
    auto c = collideSpheres(s1, s2, Material{0.95, 0.2, 0.4});
    ASSERT_TRUE(c.ok());
    if (std::abs(c->after[0].velocity_m_s.z()) > 0.01) ++with_z;
    auto hidden = c->after;
    hidden[0].velocity_m_s.z() = 123.0;
    hidden[1].velocity_m_s.z() = -77.0;
    auto z = outOfPlaneVelocity({s1, s2}, hidden);
    ASSERT_TRUE(z.ok()) << z.error().message;
    EXPECT_NEAR(z->v1z_m_s, c->after[0].velocity_m_s.z(), 1e-9);
    EXPECT_NEAR(z->v2z_m_s, c->after[1].velocity_m_s.z(), 1e-9);
    EXPECT_NEAR(z->impulse_z_N_s, c->contact.impulse_N_s.z(), 1e-12);
  }
  EXPECT_GT(with_z, 100);
}

// Thesis eq. B.2, identical spheres, both pairs used: the mean of four
// estimates (sigma m / 5) d omega / (+-n), computed here by hand.
TEST(Walton, OutOfPlaneIsThesisWeightedMean) {
  const Vec3 n = Vec3(0.8, 0.6, 0.0);
  Sphere s2 = nylon(Vec3::Zero(), Vec3::Zero());
  Sphere s1 = nylon(0.0254 * n, Vec3(-1, 0, 0));
  auto after = std::array<Sphere, 2>{s1, s2};
  // Inconsistent spin changes (noise): the answer is their thesis average.
  after[0].spin_rad_s = Vec3(1.0, 2.0, 0);
  after[1].spin_rad_s = Vec3(3.0, -1.0, 0);
  after[0].velocity_m_s = s1.velocity_m_s;
  auto z = outOfPlaneVelocity({s1, s2}, after);
  ASSERT_TRUE(z.ok());
  const double k = 0.0254 * 0.00979 / 5;
  const double expected = (k * 1.0 / -0.6 + k * 3.0 / -0.6 + k * 2.0 / 0.8 + k * -1.0 / 0.8) / 4;
  EXPECT_EQ(z->estimates_used, 4);
  EXPECT_NEAR(z->impulse_z_N_s, expected, 1e-15);
  EXPECT_NEAR(z->v1z_m_s, expected / 0.00979, 1e-12);
  EXPECT_NEAR(z->v2z_m_s, -expected / 0.00979, 1e-12);
}

// The 0.1 exclusion rule: with n nearly along x, |n_y| <= 0.1 |n_x|, the x
// spin changes are left out, so disturbing them changes nothing; just past
// the threshold they count.
TEST(Walton, OutOfPlaneExclusionRule) {
  auto dPz = [](const Vec3& n_raw, double d_omega_x) {
    const Vec3 n = n_raw.normalized();
    Sphere s2 = nylon(Vec3::Zero(), Vec3::Zero());
    Sphere s1 = nylon(0.0254 * n, Vec3(-1, 0, 0));
    auto after = std::array<Sphere, 2>{s1, s2};
    after[0].spin_rad_s = Vec3(d_omega_x, 2.0, 0);
    after[1].spin_rad_s = Vec3(d_omega_x, 2.0, 0);
    auto z = outOfPlaneVelocity({s1, s2}, after);
    EXPECT_TRUE(z.ok());
    return std::pair{z->impulse_z_N_s, z->estimates_used};
  };
  // Just either side of the threshold (exactly 0.1 is at the mercy of rounding in n).
  const Vec3 excluded(1.0, 0.099, 0.0), included(1.0, 0.101, 0.0);
  EXPECT_EQ(dPz(excluded, 0.0).second, 2);
  EXPECT_EQ(dPz(excluded, 0.0).first, dPz(excluded, 500.0).first);
  EXPECT_EQ(dPz(included, 0.0).second, 4);
  EXPECT_NE(dPz(included, 0.0).first, dPz(included, 500.0).first);
  // Symmetric rule for the y pair.
  EXPECT_EQ(dPz(Vec3(0.099, 1.0, 0.0), 0.0).second, 2);
}

// Sphere on a fixed floor, analytic cases (K = 2/5, m_12 = m, 1/m_t = 7/(2m)).
TEST(Walton, WallNormalBounceIsMinusEV) {
  const double R = 0.0127, e = 0.85;
  const Sphere s = nylon(Vec3(0.3, R, 0.1), Vec3(0, -2.0, 0));
  auto c = collideWithWall(s, Wall{Vec3(0, 0, 0), Vec3(0, 1, 0)}, Material{e, 0.2, 0.4});
  ASSERT_TRUE(c.ok());
  EXPECT_LT((c->after.velocity_m_s - Vec3(0, 2.0 * e, 0)).norm(), 1e-14);
  EXPECT_EQ(c->after.spin_rad_s, Vec3::Zero());
  EXPECT_NEAR(c->contact.before.gamma_rad, std::numbers::pi, 1e-15);
}

TEST(Walton, WallSlidingRemovesMuTimesNormalImpulse) {
  const double R = 0.0127, e = 0.9, mu = 0.15, vx = 3.0, vy = 1.0;
  const Sphere s = nylon(Vec3(0, R, 0), Vec3(vx, -vy, 0));
  // Normal given unnormalised and pointing into the floor: the side the
  // sphere is on decides.
  auto c = collideWithWall(s, Wall{Vec3(5, 0, 2), Vec3(0, -3, 0)}, Material{e, mu, 0.4});
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_EQ(c->contact.regime, Regime::Sliding);  // vx/vy = 3 > tan gamma0
  EXPECT_NEAR(c->after.velocity_m_s.x(), vx - mu * (1 + e) * vy, 1e-14);
  EXPECT_NEAR(c->after.velocity_m_s.y(), e * vy, 1e-14);
  // Friction at the bottom, pointing -x, spins the ball clockwise seen from +z.
  EXPECT_NEAR(c->after.spin_rad_s.z(), -2.5 / R * mu * (1 + e) * vy, 1e-10);
  EXPECT_NEAR(c->contact.f, mu, 1e-14);
  EXPECT_LT((c->contact.before.normal - Vec3(0, 1, 0)).norm(), 1e-15);
}

// Rolling with beta0 = 0: the contact point stops slipping, the classic 5/7 v.
TEST(Walton, WallRollingWithBeta0ZeroEndsRollingAtFiveSevenths) {
  const double R = 0.0127, vx = 1.0, vy = 2.0;
  const Sphere s = nylon(Vec3(0, R, 0), Vec3(vx, -vy, 0));
  auto c = collideWithWall(s, Wall{Vec3::Zero(), Vec3::UnitY()}, Material{0.5, 0.5, 0.0});
  ASSERT_TRUE(c.ok());
  ASSERT_EQ(c->contact.regime, Regime::Rolling);
  EXPECT_NEAR(c->after.velocity_m_s.x(), 5.0 / 7.0 * vx, 1e-14);
  EXPECT_NEAR(c->after.spin_rad_s.z(), -5.0 / 7.0 * vx / R, 1e-11);
}

// A wall is the limit of an infinitely heavy, infinitely large partner.
TEST(Walton, WallIsLimitOfHeavySphere) {
  const double R = 0.0127;
  const Sphere s = nylon(Vec3(0, R, 0), Vec3(1.2, -0.7, 0.3), Vec3(10, -40, 25));
  Sphere big;
  big.mass_kg = 1e12;
  big.diameter_m = 1e4;
  big.position_m = Vec3(0, -0.5e4, 0);
  const Material mat{0.9, 0.25, 0.3};
  auto w = collideWithWall(s, Wall{Vec3::Zero(), Vec3::UnitY()}, mat);
  auto b = collideSpheres(s, big, mat);
  ASSERT_TRUE(w.ok() && b.ok());
  EXPECT_LT((w->after.velocity_m_s - b->after[0].velocity_m_s).norm(), 1e-8);
  EXPECT_LT((w->after.spin_rad_s - b->after[0].spin_rad_s).norm(), 1e-6);
  EXPECT_EQ(w->contact.regime, b->contact.regime);
}

namespace {
void expectRejected(const Result<Collision>& r, const std::string& field) {
  ASSERT_FALSE(r.ok()) << "accepted input with bad " << field;
  EXPECT_THAT(r.error().message, HasSubstr(field));
}
}  // namespace

TEST(Walton, RejectsEveryBadInputNamingTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const Sphere s2 = nylon(Vec3::Zero(), Vec3::Zero());
  const Sphere s1 = nylon(Vec3(0.0254, 0, 0), Vec3(-1, 0.2, 0));
  const Material mat;
  ASSERT_TRUE(collideSpheres(s1, s2, mat).ok());

  auto with = [&](auto change) {
    Sphere a = s1, b = s2;
    change(a, b);
    return collideSpheres(a, b, mat);
  };
  expectRejected(with([](Sphere& a, Sphere&) { a.mass_kg = 0; }), "spheres[0].mass_kg");
  expectRejected(with([](Sphere&, Sphere& b) { b.mass_kg = -1; }), "spheres[1].mass_kg");
  expectRejected(with([&](Sphere& a, Sphere&) { a.mass_kg = nan; }), "spheres[0].mass_kg");
  expectRejected(with([](Sphere&, Sphere& b) { b.diameter_m = -0.0254; }), "spheres[1].diameter_m");
  expectRejected(with([](Sphere& a, Sphere&) { a.diameter_m = 0; }), "spheres[0].diameter_m");
  expectRejected(with([&](Sphere& a, Sphere&) { a.diameter_m = inf; }), "spheres[0].diameter_m");
  expectRejected(with([&](Sphere& a, Sphere&) { a.position_m.y() = inf; }),
                 "spheres[0].position_m");
  expectRejected(with([&](Sphere&, Sphere& b) { b.velocity_m_s.z() = nan; }),
                 "spheres[1].velocity_m_s");
  expectRejected(with([&](Sphere& a, Sphere&) { a.spin_rad_s.x() = nan; }),
                 "spheres[0].spin_rad_s");
  // Not touching: outside 1 % either way; inside is accepted.
  expectRejected(with([](Sphere& a, Sphere&) { a.position_m.x() = 0.0254 * 1.011; }), "position_m");
  expectRejected(with([](Sphere& a, Sphere&) { a.position_m.x() = 0.0254 * 0.989; }), "position_m");
  EXPECT_TRUE(with([](Sphere& a, Sphere&) { a.position_m.x() = 0.0254 * 1.009; }).ok());
  expectRejected(with([](Sphere& a, Sphere&) { a.position_m.setZero(); }), "position_m");
  // Not approaching: separating, and purely tangential (v_n = 0).
  expectRejected(with([](Sphere& a, Sphere&) { a.velocity_m_s = Vec3(1, 0, 0); }), "velocity_m_s");
  expectRejected(with([](Sphere& a, Sphere&) { a.velocity_m_s = Vec3(0, 1, 0); }), "velocity_m_s");

  auto withMat = [&](Material m) { return collideSpheres(s1, s2, m); };
  expectRejected(withMat({1.1, 0.2, 0.4}), "material.e");
  expectRejected(withMat({-0.1, 0.2, 0.4}), "material.e");
  expectRejected(withMat({nan, 0.2, 0.4}), "material.e");
  expectRejected(withMat({0.9, -0.1, 0.4}), "material.mu");
  expectRejected(withMat({0.9, inf, 0.4}), "material.mu");
  expectRejected(withMat({0.9, 0.2, 1.5}), "material.beta0");
  expectRejected(withMat({0.9, 0.2, -1.01}), "material.beta0");
  expectRejected(withMat({0.9, 0.2, nan}), "material.beta0");
  // Edges of the ranges are valid.
  EXPECT_TRUE(withMat({0.0, 0.0, -1.0}).ok());
  EXPECT_TRUE(withMat({1.0, 2.0, 1.0}).ok());
}

TEST(Walton, WallRejectsBadInputNamingTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double R = 0.0127;
  const Sphere s = nylon(Vec3(0, R, 0), Vec3(0.5, -1, 0));
  const Wall floor{Vec3::Zero(), Vec3::UnitY()};
  ASSERT_TRUE(collideWithWall(s, floor, Material{}).ok());
  auto check = [](const Result<WallCollision>& r, const std::string& field) {
    ASSERT_FALSE(r.ok()) << field;
    EXPECT_THAT(r.error().message, HasSubstr(field));
  };
  check(collideWithWall(s, Wall{Vec3::Zero(), Vec3::Zero()}, Material{}), "wall.normal");
  check(collideWithWall(s, Wall{Vec3::Zero(), Vec3(0, nan, 0)}, Material{}), "wall.normal");
  check(collideWithWall(s, Wall{Vec3(nan, 0, 0), Vec3::UnitY()}, Material{}), "wall.point_m");
  Sphere far = s;
  far.position_m.y() = 1.02 * R;
  check(collideWithWall(far, floor, Material{}), "spheres[0].position_m");
  Sphere leaving = s;
  leaving.velocity_m_s = Vec3(0.5, 1, 0);
  check(collideWithWall(leaving, floor, Material{}), "velocity_m_s");
  Sphere light = s;
  light.mass_kg = -0.01;
  check(collideWithWall(light, floor, Material{}), "spheres[0].mass_kg");
  check(collideWithWall(s, floor, Material{2, 0.1, 0.1}), "material.e");
}

TEST(Walton, InverseRejectsBadInput) {
  const Sphere s2 = nylon(Vec3::Zero(), Vec3::Zero());
  const Sphere s1 = nylon(Vec3(0.0254, 0, 0), Vec3(-1, 0.2, 0));
  auto after = std::array<Sphere, 2>{s1, s2};
  after[1].velocity_m_s.x() = std::numeric_limits<double>::quiet_NaN();
  auto r = measureCollision({s1, s2}, after);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("after.spheres[1].velocity_m_s"));

  Sphere leaving = s1;
  leaving.velocity_m_s = Vec3(1, 0, 0);
  r = measureCollision({leaving, s2}, {leaving, s2});
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("velocity_m_s"));

  Sphere on_top = s1;
  on_top.position_m = s2.position_m;
  r = measureCollision({on_top, s2}, {on_top, s2});
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("position_m"));

  // Line of centres along the camera axis: no in-plane spin change constrains dP_z.
  Sphere front = s1;
  front.position_m = Vec3(0, 0, 0.0254);
  auto z = outOfPlaneVelocity({front, s2}, {front, s2});
  ASSERT_FALSE(z.ok());
  EXPECT_THAT(z.error().message, HasSubstr("position_m"));
}
