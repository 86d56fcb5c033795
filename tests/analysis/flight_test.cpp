#include "analysis/flight.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

using namespace collide;
using ::testing::HasSubstr;

namespace {

constexpr double kD = 0.0254;   // diameter, m
constexpr double kM = 0.00979;  // mass, kg

Sphere nylonAt(const Vec3& position_m, const Vec3& velocity_m_s,
               const Vec3& spin_rad_s = Vec3::Zero()) {
  Sphere s;
  s.mass_kg = kM;
  s.diameter_m = kD;
  s.position_m = position_m;
  s.velocity_m_s = velocity_m_s;
  s.spin_rad_s = spin_rad_s;
  return s;
}

// The rig: two tubes facing each other along x, launching towards each other.
FlightSetup facingTubes(double gap_m, double u1_m_s, double u2_m_s) {
  FlightSetup s;
  s.spheres[0] = nylonAt(Vec3(-0.5 * gap_m, 0.3, 0), Vec3(u1_m_s, 0, 0));
  s.spheres[1] = nylonAt(Vec3(0.5 * gap_m, 0.3, 0), Vec3(-u2_m_s, 0, 0));
  return s;
}

Vec3 parabola(const Vec3& r0, const Vec3& v0, const Vec3& g, double t) {
  return r0 + v0 * t + 0.5 * g * t * t;
}

}  // namespace

// Same height, same launch instant: contact when the gap closes to one diameter.
TEST(Flight, ContactTimeOfHeadOnLaunchIsAnalytic) {
  const double gap = 0.2, u1 = 1.5, u2 = 2.5;
  auto f = Flight::create(facingTubes(gap, u1, u2));
  ASSERT_TRUE(f.ok()) << f.error().message;
  ASSERT_TRUE(f->collides());
  EXPECT_NEAR(f->collisionTime_s(), (gap - kD) / (u1 + u2), 1e-15);
}

// Staggered launches: sphere 1 flies alone for 20 ms while sphere 2 rests in
// its tube, then both close the gap. No gravity here: sphere 1's head start
// in falling would tilt the line of approach (covered by the random test).
TEST(Flight, ContactTimeWithStaggeredLaunchIsAnalytic) {
  const double gap = 0.3, u1 = 2.0, u2 = 1.0, t1 = 0.1, t2 = 0.12;
  auto setup = facingTubes(gap, u1, u2);
  setup.launch_time_s = {t1, t2};
  setup.gravity_m_s2.setZero();
  auto f = Flight::create(setup);
  ASSERT_TRUE(f.ok()) << f.error().message;
  ASSERT_TRUE(f->collides());
  const double gap_at_t2 = gap - u1 * (t2 - t1);
  EXPECT_NEAR(f->collisionTime_s(), t2 + (gap_at_t2 - kD) / (u1 + u2), 1e-14);
}

// Tubes at different heights with different launch times, sizes and
// out-of-plane drift: contact distance is exactly (sigma1 + sigma2)/2, and
// the spheres never came closer before.
TEST(Flight, FirstContactIsAtSumOfRadiiOverRandomLaunches) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int collided = 0;
  for (int trial = 0; trial < 500; ++trial) {
    FlightSetup s;
    s.spheres[0] = nylonAt(Vec3(-0.15, 0.3 + 0.03 * u(rng), 0.002 * u(rng)),
                           Vec3(2 + u(rng), 0.5 * u(rng), 0.02 * u(rng)), Vec3(0, 0, 30 * u(rng)));
    s.spheres[1] = nylonAt(Vec3(0.15, 0.3 + 0.03 * u(rng), 0.002 * u(rng)),
                           Vec3(-2 + u(rng), 0.5 * u(rng), 0.02 * u(rng)), Vec3(10 * u(rng), 0, 0));
    s.spheres[1].diameter_m = 0.0127 + 0.0127 * (1 + u(rng));
    s.spheres[1].mass_kg = 0.003 + 0.003 * (1 + u(rng));
    s.launch_time_s = {0.01 * (1 + u(rng)), 0.01 * (1 + u(rng))};
    auto f = Flight::create(s);
    ASSERT_TRUE(f.ok()) << f.error().message;
    if (!f->collides()) continue;
    ++collided;
    const double contact_m = 0.5 * (s.spheres[0].diameter_m + s.spheres[1].diameter_m);
    const auto& b = f->justBefore();
    EXPECT_NEAR((b[0].position_m - b[1].position_m).norm(), contact_m, 1e-12);
    const double t_c = f->collisionTime_s();
    const double t_both = std::max(s.launch_time_s[0], s.launch_time_s[1]);
    for (int k = 1; k <= 20; ++k) {
      const double t = t_both + (t_c - t_both) * (k - 1) / 20.0;
      if (t >= t_c) break;
      const auto st = f->at(t);
      EXPECT_GT((st[0].position_m - st[1].position_m).norm(), contact_m - 1e-12);
    }
    // at() just before contact agrees with justBefore().
    const auto near = f->at(std::nextafter(t_c, 0.0));
    EXPECT_LT((near[0].position_m - b[0].position_m).norm(), 1e-12);
  }
  EXPECT_GT(collided, 100);  // enough hits to mean something
}

TEST(Flight, MomentumIsConservedAcrossTheCollision) {
  auto setup = facingTubes(0.2, 1.5, 2.5);
  setup.spheres[0].position_m.y() += 0.01;  // oblique
  setup.spheres[1].mass_kg = 0.0031;
  setup.spheres[1].diameter_m = 0.0127;
  setup.spheres[0].spin_rad_s = Vec3(5, -20, 60);
  auto f = Flight::create(setup);
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f->collides());
  const auto& b = f->justBefore();
  const auto& a = f->justAfter();
  const double m1 = setup.spheres[0].mass_kg, m2 = setup.spheres[1].mass_kg;
  const Vec3 p0 = m1 * b[0].velocity_m_s + m2 * b[1].velocity_m_s;
  const Vec3 p1 = m1 * a[0].velocity_m_s + m2 * a[1].velocity_m_s;
  EXPECT_LT((p1 - p0).norm(), 1e-15);
  EXPECT_GT((a[0].velocity_m_s - b[0].velocity_m_s).norm(), 0.5);  // something happened
  // Positions do not jump; e is the material's.
  EXPECT_EQ(a[0].position_m, b[0].position_m);
  EXPECT_EQ(f->materialUsed().e, setup.material.e);
}

// Before the collision each centre follows its launch parabola; after it, the
// parabola from the contact state; before launch it rests.
TEST(Flight, GravityParabolaBeforeAndAfter) {
  auto setup = facingTubes(0.25, 2.0, 1.0);
  setup.spheres[0].velocity_m_s.y() = 0.8;
  setup.spheres[1].velocity_m_s.y() = 0.8;
  setup.launch_time_s = {0.0, 0.005};
  auto f = Flight::create(setup);
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f->collides());
  const double t_c = f->collisionTime_s();
  const Vec3 g = setup.gravity_m_s2;

  const auto rest = f->at(0.004);
  EXPECT_EQ(rest[1].position_m, setup.spheres[1].position_m);
  EXPECT_EQ(rest[1].velocity_m_s, Vec3::Zero());

  for (double t : {0.001, 0.02, 0.9 * t_c}) {
    const auto st = f->at(t);
    for (int i = 0; i < 2; ++i) {
      const double tau = t - setup.launch_time_s[i];
      if (tau < 0) continue;
      EXPECT_LT((st[i].position_m -
                 parabola(setup.spheres[i].position_m, setup.spheres[i].velocity_m_s, g, tau))
                    .norm(),
                1e-14);
      EXPECT_LT((st[i].velocity_m_s - (setup.spheres[i].velocity_m_s + g * tau)).norm(), 1e-14);
    }
  }
  const auto& a = f->justAfter();
  for (double dt : {0.001, 0.05}) {
    const auto st = f->at(t_c + dt);
    for (int i = 0; i < 2; ++i)
      EXPECT_LT((st[i].position_m - parabola(a[i].position_m, a[i].velocity_m_s, g, dt)).norm(),
                1e-14);
  }
  // Independent of the formula: the second difference of position is g.
  const double h = 1e-3;
  for (double t : {0.5 * t_c, t_c + 0.02}) {
    const Vec3 acc =
        (f->at(t + h)[0].position_m - 2 * f->at(t)[0].position_m + f->at(t - h)[0].position_m) /
        (h * h);
    EXPECT_LT((acc - g).norm(), 1e-6);
  }
}

// Constant spin about a fixed axis turns the launch orientation by |w| t
// about that axis, in the world frame; orientation is continuous through the
// collision and then follows the new spin.
TEST(Flight, OrientationIntegratesSpin) {
  auto setup = facingTubes(0.2, 1.5, 1.5);
  const Vec3 spin(0, 0, 40.0);
  setup.spheres[0].spin_rad_s = spin;
  const Quat q0(Eigen::AngleAxisd(0.7, Vec3(1, 1, 0).normalized()));
  setup.orientation_at_launch[0] = q0;
  auto f = Flight::create(setup);
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f->collides());
  const double t = 0.5 * f->collisionTime_s();
  const Quat expected = Quat(Eigen::AngleAxisd(40.0 * t, Vec3::UnitZ())) * q0;
  EXPECT_LT(f->at(t)[0].orientation.angularDistance(expected), 1e-12);
  // World frame, not body frame: a body-frame turn would differ here.
  const Quat body_frame = q0 * Quat(Eigen::AngleAxisd(40.0 * t, Vec3::UnitZ()));
  EXPECT_GT(f->at(t)[0].orientation.angularDistance(body_frame), 0.1);

  const auto& b = f->justBefore();
  const auto& a = f->justAfter();
  EXPECT_LT(a[0].orientation.angularDistance(b[0].orientation), 1e-15);
  const double t_c = f->collisionTime_s(), dt = 0.01;
  const Vec3 w = a[0].spin_rad_s;
  const Quat after_expected =
      Quat(Eigen::AngleAxisd(w.norm() * dt, w.normalized())) * a[0].orientation;
  EXPECT_LT(f->at(t_c + dt)[0].orientation.angularDistance(after_expected), 1e-12);
  // Sphere 2 never spins before the collision: its orientation is unchanged.
  EXPECT_LT(f->at(t)[1].orientation.angularDistance(Quat::Identity()), 1e-15);
}

TEST(Flight, RestitutionOfNormalSpeedIsUsed) {
  auto setup = facingTubes(0.2, 1.5, 2.5);
  double seen_vn = -1;
  setup.restitution_of_vn = [&](double vn) {
    seen_vn = vn;
    return 1.0 - 0.1 * vn;
  };
  auto f = Flight::create(setup);
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f->collides());
  EXPECT_NEAR(seen_vn, 4.0, 1e-12);  // head-on, closing speed u1 + u2
  EXPECT_NEAR(f->materialUsed().e, 0.6, 1e-12);
  const auto& a = f->justAfter();
  EXPECT_NEAR(a[0].velocity_m_s.x() - a[1].velocity_m_s.x(), -0.6 * 4.0, 1e-12);

  setup.restitution_of_vn = [](double) { return 1.3; };
  auto bad = Flight::create(setup);
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.error().message, HasSubstr("restitution_of_vn"));
}

TEST(Flight, SpheresMovingApartNeverCollide) {
  auto f = Flight::create(facingTubes(0.2, -1.0, -1.0));
  ASSERT_TRUE(f.ok());
  EXPECT_FALSE(f->collides());
  EXPECT_TRUE(std::isnan(f->collisionTime_s()));
  const Vec3 expected = parabola(Vec3(-0.1, 0.3, 0), Vec3(-1, 0, 0), kGravity_m_s2, 1.0);
  EXPECT_LT((f->at(1.0)[0].position_m - expected).norm(), 1e-14);
}

// Parallel paths a little more than a diameter apart pass each other.
TEST(Flight, NearMissDoesNotCollide) {
  auto setup = facingTubes(0.2, 1.0, 1.0);
  setup.spheres[0].position_m.y() += 1.001 * kD;
  auto f = Flight::create(setup);
  ASSERT_TRUE(f.ok());
  EXPECT_FALSE(f->collides());
  setup.spheres[0].position_m.y() -= 0.002 * kD;
  auto g = Flight::create(setup);
  ASSERT_TRUE(g.ok());
  EXPECT_TRUE(g->collides());
}

TEST(Flight, RejectsBadSetups) {
  auto check = [](FlightSetup s, const std::string& field) {
    auto f = Flight::create(s);
    ASSERT_FALSE(f.ok()) << field;
    EXPECT_THAT(f.error().message, HasSubstr(field));
  };
  const auto good = facingTubes(0.2, 1.0, 1.0);
  ASSERT_TRUE(Flight::create(good).ok());
  auto s = good;
  s.spheres[1].mass_kg = 0;
  check(s, "spheres[1].mass_kg");
  s = good;
  s.spheres[0].diameter_m = -kD;
  check(s, "spheres[0].diameter_m");
  s = good;
  s.spheres[0].velocity_m_s.x() = std::numeric_limits<double>::infinity();
  check(s, "spheres[0].velocity_m_s");
  s = good;
  s.launch_time_s[1] = std::numeric_limits<double>::quiet_NaN();
  check(s, "launch_time_s[1]");
  s = good;
  s.orientation_at_launch[0].coeffs().setZero();
  check(s, "orientation_at_launch[0]");
  s = good;
  s.gravity_m_s2.y() = std::numeric_limits<double>::quiet_NaN();
  check(s, "gravity_m_s2");
  s = good;
  s.material.mu = -1;
  check(s, "material.mu");
  // Overlap at the later launch: sphere 1 flies into sphere 2's tube mouth
  // before sphere 2 is launched.
  s = good;
  s.launch_time_s = {0.0, 0.1};
  s.spheres[0].velocity_m_s.x() = 2.0;
  s.gravity_m_s2.setZero();
  check(s, "overlap");
}
