// Sphere-on-wall: Walton's infinite-mass limit forward, then inverse, and the
// simulator's closed-form flight into a wall.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "analysis/flight.hpp"
#include "analysis/walton.hpp"

using namespace collide;
using ::testing::HasSubstr;

namespace {

Sphere nylon() {
  Sphere s;
  s.mass_kg = 0.00978;
  s.diameter_m = 0.0254;
  return s;
}

// A sphere touching a wall through the origin with normal `n`, coming in at
// `gamma_deg` from the normal at 2 m/s, with spin `spin`.
Sphere incoming(const Vec3& n, double gamma_deg, const Vec3& spin) {
  Sphere s = nylon();
  const Vec3 un = n.normalized();
  const Vec3 t = un.unitOrthogonal();
  const double g = gamma_deg * M_PI / 180.0;
  s.position_m = s.radius_m() * un;
  s.velocity_m_s = 2.0 * (-std::cos(g) * un + std::sin(g) * t);
  s.spin_rad_s = spin;
  return s;
}

TEST(WallInverse, ForwardThenInverseGivesTheMaterialBack) {
  const Material m{0.9, 0.15, 0.4};
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 30.0);
  int sliding = 0, rolling = 0;
  for (int k = 0; k < 200; ++k) {
    const Vec3 n(std::cos(0.1 * k), std::sin(0.1 * k), 0.2);
    const Sphere s = incoming(n, 2.0 + 0.43 * k * 80.0 / 86.0, Vec3(g(rng), g(rng), g(rng)));
    const Wall wall{Vec3::Zero(), 3.0 * n};
    auto hit = collideWithWall(s, wall, m);
    ASSERT_TRUE(hit) << hit.error().message;
    (hit->contact.regime == Regime::Sliding ? sliding : rolling)++;
    auto meas = measureWallCollision(s, hit->after, wall);
    ASSERT_TRUE(meas) << meas.error().message;
    EXPECT_NEAR(meas->e, m.e, 1e-12);
    EXPECT_NEAR(meas->beta, hit->contact.beta, 1e-9);
    EXPECT_NEAR(meas->beta_from_impulse, hit->contact.beta, 1e-9);
    EXPECT_NEAR(meas->f, hit->contact.f, 1e-9);
    EXPECT_NEAR(meas->kappa, 0.4, 1e-12);
    EXPECT_NEAR(meas->before.gamma_rad, hit->contact.before.gamma_rad, 1e-12);
    // Independently: v_n' = -e v_n along the unit normal (the sphere's side).
    const Vec3 un = n.normalized();
    EXPECT_NEAR(hit->after.velocity_m_s.dot(un), -m.e * s.velocity_m_s.dot(un), 1e-12);
    if (hit->contact.regime == Regime::Sliding) {
      EXPECT_NEAR(meas->f, m.mu, 1e-9);
    }
  }
  EXPECT_GT(sliding, 20);
  EXPECT_GT(rolling, 20);
}

TEST(WallInverse, TwoSphereInverseTendsToTheWallAsTheSecondMassGrows) {
  const Material m{0.8, 0.2, 0.3};
  const Vec3 n(0.0, 1.0, 0.0);
  const Sphere s = incoming(n, 40.0, Vec3(0, 0, 25.0));
  const Wall wall{Vec3::Zero(), n};
  auto hit = collideWithWall(s, wall, m);
  ASSERT_TRUE(hit);
  auto wall_meas = measureWallCollision(s, hit->after, wall);
  ASSERT_TRUE(wall_meas);
  // A huge, still sphere below the wall's contact point, touching s there.
  Sphere big;
  big.mass_kg = 1e12;
  big.diameter_m = 1e3;
  big.position_m = s.position_m - (s.radius_m() + big.radius_m()) * n;
  auto pair = measureCollision({s, big}, {hit->after, big});
  ASSERT_TRUE(pair) << pair.error().message;
  EXPECT_NEAR(pair->e, wall_meas->e, 1e-9);
  EXPECT_NEAR(pair->beta, wall_meas->beta, 1e-6);
  EXPECT_NEAR(pair->beta_from_impulse, wall_meas->beta_from_impulse, 1e-6);
  EXPECT_NEAR(pair->kappa, wall_meas->kappa, 1e-6);
  EXPECT_NEAR(pair->before.gamma_rad, wall_meas->before.gamma_rad, 1e-9);
}

TEST(WallInverse, OutOfPlaneVelocityAfterComesBackFromTheSpinChange) {
  const Material m{0.9, 0.3, 0.4};
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0.0, 30.0);
  for (int k = 0; k < 50; ++k) {
    // Normals in the image plane and leaning out of it by up to ~0.3.
    const Vec3 n(std::cos(0.3 * k), std::sin(0.3 * k), 0.3 * std::sin(0.7 * k));
    Sphere s = incoming(n, 10.0 + k, Vec3(g(rng), g(rng), g(rng)));
    s.velocity_m_s.z() += 0.1 * std::cos(0.5 * k);
    const Wall wall{Vec3::Zero(), n};
    auto hit = collideWithWall(s, wall, m);
    ASSERT_TRUE(hit);
    Sphere seen = hit->after;
    seen.velocity_m_s.z() = 12.0;  // not measured: must not be read
    auto vz = wallOutOfPlaneVelocity(s, seen, wall);
    ASSERT_TRUE(vz) << vz.error().message;
    EXPECT_NEAR(*vz, hit->after.velocity_m_s.z(), 1e-12);
  }
  Sphere s = incoming(Vec3::UnitZ(), 20.0, Vec3::Zero());
  auto bad = wallOutOfPlaneVelocity(s, s, Wall{Vec3::Zero(), Vec3::UnitZ()});
  ASSERT_FALSE(bad);
  EXPECT_THAT(bad.error().message, HasSubstr("wall.normal"));
}

TEST(WallInverse, RefusesARecedingSphereAndABadWall) {
  Sphere s = incoming(Vec3::UnitY(), 30.0, Vec3::Zero());
  Sphere away = s;
  away.velocity_m_s.y() = -away.velocity_m_s.y();
  auto r = measureWallCollision(away, s, Wall{Vec3::Zero(), Vec3::UnitY()});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message, HasSubstr("not approaching"));
  auto w = measureWallCollision(s, s, Wall{Vec3::Zero(), Vec3::Zero()});
  ASSERT_FALSE(w);
  EXPECT_THAT(w.error().message, HasSubstr("wall.normal"));
}

TEST(FlightWall, HitsTheWallWhereGravityAndTheLineOfFlightSay) {
  FlightSetup setup;
  setup.spheres[0] = nylon();
  setup.spheres[1] = nylon();
  setup.spheres[0].position_m = Vec3(-0.08, 0.0, 0.0);
  setup.spheres[0].velocity_m_s = Vec3(2.0, 0.3, 0.0);
  setup.spheres[0].spin_rad_s = Vec3(0, 0, 10.0);
  setup.spheres[1].position_m = Vec3(0.5, 0.5, 0.0);
  setup.launch_time_s = {0.01, 1e6};
  setup.material = Material{0.9, 0.15, 0.4};
  // A vertical wall x = 0.03, normal pointing either way.
  setup.wall = Wall{Vec3(0.03, 0.0, 0.0), Vec3(-1.0, 0.0, 0.0)};
  auto f = Flight::create(setup);
  ASSERT_TRUE(f) << f.error().message;
  ASSERT_TRUE(f->collides());
  const double r = setup.spheres[0].radius_m();
  const double t_hit = 0.01 + (0.03 - r + 0.08) / 2.0;  // x motion is uniform
  EXPECT_NEAR(f->collisionTime_s(), t_hit, 1e-12);
  const double s = t_hit - 0.01;
  EXPECT_NEAR(f->justBefore()[0].position_m.y(), 0.3 * s - 0.5 * 9.80665 * s * s, 1e-12);
  EXPECT_NEAR(f->justAfter()[0].velocity_m_s.x(), -0.9 * 2.0, 1e-12);
  // After the impact it flies back; sphere 2 never moves.
  const auto later = f->at(t_hit + 0.01);
  EXPECT_NEAR(later[0].position_m.x(), 0.03 - r - 0.018, 1e-12);
  EXPECT_EQ(later[1].position_m, setup.spheres[1].position_m);
  // Aimed away from the wall: no collision.
  setup.spheres[0].velocity_m_s = Vec3(-2.0, 0.3, 0.0);
  auto miss = Flight::create(setup);
  ASSERT_TRUE(miss);
  EXPECT_FALSE(miss->collides());
}

}  // namespace
