// The Walton-inverse stage (analysis/shot_inverse.hpp): states from the
// forward operator (analysis/walton.hpp) with known material, analytic energy
// balances, and the physical bounds behind the "unphysical" flag.
#include "analysis/shot_inverse.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace collide;

namespace {

constexpr double kD = 0.0254, kM = 0.00978;

std::array<Sphere, 2> approach(double angle_rad, const Vec3& w1, const Vec3& w2) {
  std::array<Sphere, 2> s;
  for (Sphere& x : s) x.mass_kg = kM, x.diameter_m = kD;
  const Vec3 n(std::cos(angle_rad), std::sin(angle_rad), 0);
  s[0].position_m = -0.5 * kD * n;
  s[1].position_m = 0.5 * kD * n;
  s[0].velocity_m_s = Vec3(2.0, 0.1, 0);
  s[1].velocity_m_s = Vec3(-1.8, -0.05, 0);
  s[0].spin_rad_s = w1;
  s[1].spin_rad_s = w2;
  return s;
}

ContactState stateOf(const std::array<Sphere, 2>& b, const std::array<Sphere, 2>& a) {
  ContactState st;
  for (int i = 0; i < 2; ++i) {
    st.position_m[i] = b[i].position_m.head<2>();
    st.v_before[i] = b[i].velocity_m_s;
    st.v_after[i] = a[i].velocity_m_s;
    st.w_before[i] = b[i].spin_rad_s;
    st.w_after[i] = a[i].spin_rad_s;
  }
  return st;
}

ShotInverseSettings settings() {
  ShotInverseSettings s;
  s.diameter_m = {kD, kD};
  s.mass_kg = {kM, kM};
  s.nz_sigma = 1e-6;
  return s;
}

TEST(InvertShot, FrictionlessImpactLosesTheAnalyticEnergy) {
  // mu = 0: beta = -1, no spin change; the energy lost is that of the normal
  // relative motion, (1 - e^2) m_12 v_n^2 / 2.
  const Material mat{0.8, 0.0, 0.44};
  const auto b = approach(0.4, Vec3(0, 0, 30), Vec3(10, 0, -5));
  auto c = collideSpheres(b[0], b[1], mat);
  ASSERT_TRUE(c.ok()) << c.error().message;
  const ShotInverse r = invertShot(stateOf(b, c->after), settings());
  ASSERT_TRUE(r.ok);
  EXPECT_NEAR(r.m.e, 0.8, 1e-9);
  EXPECT_NEAR(r.m.beta, -1, 1e-9);
  EXPECT_NEAR(r.n_z, 0, 1e-9);
  const Vec3 n(std::cos(0.4), std::sin(0.4), 0);
  const double vn = (b[0].velocity_m_s - b[1].velocity_m_s).dot(-n);  // n from 2 to 1
  const double m12 = kM / 2;
  EXPECT_NEAR(r.kinetic_energy_change_J, -0.5 * (1 - 0.64) * m12 * vn * vn, 1e-12);
  EXPECT_LT(r.kinetic_energy_change_J, 0);
}

TEST(InvertShot, ElasticFrictionlessImpactConservesEnergy) {
  const auto b = approach(-0.3, Vec3(5, -3, 20), Vec3(0, 7, 0));
  auto c = collideSpheres(b[0], b[1], Material{1.0, 0.0, 0.44});
  ASSERT_TRUE(c.ok());
  const ShotInverse r = invertShot(stateOf(b, c->after), settings());
  ASSERT_TRUE(r.ok);
  EXPECT_NEAR(r.m.e, 1, 1e-9);
  EXPECT_NEAR(r.kinetic_energy_change_J, 0, 1e-12);
  // Before: 1/2 m v^2 + 1/2 (m d^2 / 10) w^2 of both spheres.
  double ke = 0;
  for (const Sphere& s : b)
    ke += 0.5 * kM * s.velocity_m_s.squaredNorm() +
          0.5 * kM * kD * kD / 10 * s.spin_rad_s.squaredNorm();
  EXPECT_NEAR(r.kinetic_energy_before_J, ke, 1e-12);
}

TEST(InvertShot, WaltonsSlidingAndRollingImpactsAreRecovered) {
  const Material mat{0.97, 0.176, 0.44};
  for (const double angle : {0.15, 0.9}) {  // near head-on (rolling), oblique (sliding)
    const auto b = approach(angle, Vec3(0, 0, 15), Vec3(0, 0, -10));
    auto c = collideSpheres(b[0], b[1], mat);
    ASSERT_TRUE(c.ok());
    const ShotInverse r = invertShot(stateOf(b, c->after), settings());
    ASSERT_TRUE(r.ok);
    EXPECT_NEAR(r.m.e, 0.97, 1e-9);
    EXPECT_NEAR(r.m.beta, c->contact.beta, 1e-9) << angle;
    EXPECT_NEAR(r.m.f, c->contact.f, 1e-9) << angle;
    // Walton's impacts dissipate: never energy gained.
    EXPECT_LT(r.kinetic_energy_change_J, 0);
  }
}

TEST(InvertShot, EnergyGainedWhenThePartingIsFasterThanTheMeeting) {
  const auto b = approach(0.4, Vec3::Zero(), Vec3::Zero());
  auto c = collideSpheres(b[0], b[1], Material{1.0, 0.0, 0.44});
  ASSERT_TRUE(c.ok());
  auto a = c->after;
  // Velocities after, about the centre of mass, 10 % faster: e = 1.1 and
  // (1.21 - 1) of the relative motion's energy gained.
  const Vec3 vcm = 0.5 * (a[0].velocity_m_s + a[1].velocity_m_s);
  for (Sphere& s : a) s.velocity_m_s = vcm + 1.1 * (s.velocity_m_s - vcm);
  const ShotInverse r = invertShot(stateOf(b, a), settings());
  ASSERT_TRUE(r.ok);
  EXPECT_NEAR(r.m.e, 1.1, 1e-9);
  const double vrel2 = (b[0].velocity_m_s - b[1].velocity_m_s).squaredNorm();
  EXPECT_NEAR(r.kinetic_energy_change_J, 0.5 * (kM / 2) * vrel2 * 0.21, 1e-12);
}

TEST(UnphysicalFindings, EachBoundBothWays) {
  const ValueSigma e_ok{0.97, 0.01}, beta_ok{0.3, 0.02}, dke_ok{-0.002, 0.0005};
  EXPECT_TRUE(unphysicalFindings(e_ok, beta_ok, dke_ok).empty());
  // e above 1: by 5 sigma yes, by 2 sigma no.
  EXPECT_EQ(unphysicalFindings({1.05, 0.01}, beta_ok, dke_ok).size(), 1u);
  EXPECT_TRUE(unphysicalFindings({1.02, 0.01}, beta_ok, dke_ok).empty());
  // e below 0.
  EXPECT_EQ(unphysicalFindings({-0.05, 0.01}, beta_ok, dke_ok).size(), 1u);
  EXPECT_TRUE(unphysicalFindings({-0.02, 0.01}, beta_ok, dke_ok).empty());
  // beta outside [-1, 1] on either side (the independent footage's -2.68).
  EXPECT_EQ(unphysicalFindings(e_ok, {-2.68, 0.1}, dke_ok).size(), 1u);
  EXPECT_EQ(unphysicalFindings(e_ok, {1.2, 0.05}, dke_ok).size(), 1u);
  EXPECT_TRUE(unphysicalFindings(e_ok, {-1.2, 0.1}, dke_ok).empty());
  EXPECT_TRUE(unphysicalFindings(e_ok, {1.1, 0.05}, dke_ok).empty());
  // Energy gained.
  EXPECT_EQ(unphysicalFindings(e_ok, beta_ok, {0.004, 0.001}).size(), 1u);
  EXPECT_TRUE(unphysicalFindings(e_ok, beta_ok, {0.002, 0.001}).empty());
  // Several at once, each said.
  EXPECT_EQ(unphysicalFindings({1.2, 0.01}, {-2.68, 0.1}, {0.01, 0.001}).size(), 3u);
  // A head-on impact's beta is NaN: no finding from it; NaN sigma counts as 0.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(unphysicalFindings(e_ok, {nan, nan}, dke_ok).empty());
  EXPECT_EQ(unphysicalFindings({1.001, nan}, beta_ok, dke_ok).size(), 1u);
}

// Angular momentum about the contact point: beta from the spins and from the
// impulse agree within k sigma of their difference; beyond it, one sentence
// that gives both values and the distance in sigma.
TEST(SpinImpulseDisagreement, OnlyBeyondKSigmaOfTheDifference) {
  EXPECT_FALSE(spinImpulseDisagreement(0.40, 0.44, 0.011));     // 3.6 sigma
  const auto far = spinImpulseDisagreement(0.40, 0.44, 0.009);  // 4.4 sigma
  ASSERT_TRUE(far);
  EXPECT_NE(far->find("+0.400"), std::string::npos) << *far;
  EXPECT_NE(far->find("+0.440"), std::string::npos) << *far;
  EXPECT_NE(far->find("4.4 sigma"), std::string::npos) << *far;
  EXPECT_TRUE(spinImpulseDisagreement(0.44, 0.40, 0.009));  // either sign
  EXPECT_FALSE(spinImpulseDisagreement(0.40, 0.44, 0.009, 5.0));
  // Nothing to compare: a value or the yardstick missing.
  EXPECT_FALSE(spinImpulseDisagreement(NAN, 0.44, 0.001));
  EXPECT_FALSE(spinImpulseDisagreement(0.40, 0.44, NAN));
  EXPECT_FALSE(spinImpulseDisagreement(0.40, 0.44, 0.0));
}

}  // namespace
