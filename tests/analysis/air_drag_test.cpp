// Air drag (analysis/air_drag.hpp) against the measured drag curve and
// Newton's law, and the flights (analysis/flight.hpp) and trajectory fits
// (analysis/trajectory.hpp) that take it into account, against closed forms.
#include "analysis/air_drag.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "analysis/flight.hpp"
#include "analysis/trajectory.hpp"

using namespace collide;

namespace {

constexpr double kD = 0.0254;   // nylon sphere: diameter, m
constexpr double kM = 0.00978;  // mass, kg

AirDrag nylon() {
  return AirDrag{kD, kM, kAirDensity_kg_m3};
}

}  // namespace

// Values read off the standard drag curve of a smooth sphere (Schlichting's
// data as tabulated in fluid-mechanics texts) and the creeping-flow limit.
TEST(SphereDragCoefficient, FollowsTheMeasuredCurve) {
  EXPECT_NEAR(sphereDragCoefficient(0.01), 2400.0, 0.01 * 2400);  // Stokes: 24 / Re
  EXPECT_NEAR(sphereDragCoefficient(1.0), 26.5, 0.1 * 26.5);      // measured ~26-27
  EXPECT_NEAR(sphereDragCoefficient(200.0), 0.77, 0.03);          // Barati et al.: 0.768
  EXPECT_NEAR(sphereDragCoefficient(1e4), 0.40, 0.03);            // the plateau, ~0.39-0.42
  EXPECT_NEAR(sphereDragCoefficient(1e5), 0.47, 0.05);            // just before the crisis
  EXPECT_LT(sphereDragCoefficient(5e5), 0.25);                    // past the drag crisis
  EXPECT_TRUE(std::isnan(sphereDragCoefficient(0.0)));
  EXPECT_TRUE(std::isnan(sphereDragCoefficient(-3.0)));
  EXPECT_TRUE(std::isnan(sphereDragCoefficient(std::nan(""))));
}

// F = rho C_D A v^2 / 2 against the velocity, worked out by hand for a
// 25.4 mm, 9.78 g sphere at 1.5 m/s (Re = 2530).
TEST(AirDrag, SlowsASphereAsNewtonsDragLawSays) {
  const AirDrag d = nylon();
  const Vec3 v(1.2, -0.9, 0.0);  // 1.5 m/s
  const double re = kAirDensity_kg_m3 * 1.5 * kD / kAirViscosity_Pa_s;
  const double force = 0.5 * kAirDensity_kg_m3 * sphereDragCoefficient(re) *
                       (std::numbers::pi * kD * kD / 4) * 1.5 * 1.5;
  const Vec3 a = d.acceleration(v);
  EXPECT_NEAR(a.norm(), force / kM, 1e-12);
  EXPECT_NEAR(a.normalized().dot(-v.normalized()), 1.0, 1e-12);  // against the motion
  EXPECT_GT(a.norm(), 0.02);  // ~0.03 m/s^2: what the fits must know
  EXPECT_LT(a.norm(), 0.04);
  EXPECT_EQ(d.acceleration(Vec3::Zero()), Vec3::Zero());
  AirDrag vacuum = d;
  vacuum.air_density_kg_m3 = 0;
  EXPECT_FALSE(vacuum.acts());
  EXPECT_EQ(vacuum.acceleration(v), Vec3::Zero());
  AirDrag fixed = d;
  fixed.drag_coefficient = 0.5;
  EXPECT_NEAR(fixed.acceleration(v).norm(),
              0.5 * kAirDensity_kg_m3 * 0.5 * (std::numbers::pi * kD * kD / 4) * 2.25 / kM, 1e-12);
}

// Without gravity and with a constant C_D the speed falls as
// v = v0 / (1 + k v0 t) and the distance is ln(1 + k v0 t) / k: the
// integrated flight against that closed form.
TEST(FlightThroughAir, MatchesTheClosedFormOfConstantDrag) {
  FlightSetup s;
  s.gravity_m_s2 = Vec3::Zero();
  s.air_density_kg_m3 = kAirDensity_kg_m3;
  s.drag_coefficient = 0.45;
  for (int i = 0; i < 2; ++i) {
    s.spheres[i].mass_kg = kM;
    s.spheres[i].diameter_m = kD;
  }
  const double v0 = 3.0;
  s.spheres[0].position_m = Vec3(0, 0, 0);
  s.spheres[0].velocity_m_s = Vec3(v0, 0, 0);
  s.spheres[1].position_m = Vec3(0, 1.0, 0);  // flies parallel, never meets
  s.spheres[1].velocity_m_s = Vec3(v0, 0, 0);
  auto f = Flight::create(s);
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_FALSE(f->collides());
  const double k = 0.5 * kAirDensity_kg_m3 * 0.45 * std::numbers::pi * kD * kD / 4 / kM;
  for (const double t : {0.0105, 0.2, 1.5}) {
    const SphereState st = f->at(t)[0];
    EXPECT_NEAR(st.position_m.x(), std::log1p(k * v0 * t) / k, 1e-11) << t;
    EXPECT_NEAR(st.velocity_m_s.x(), v0 / (1 + k * v0 * t), 1e-11) << t;
  }
}

// Dropped for long enough, a sphere falls at the speed where the drag
// balances gravity (Newton's second law with no acceleration): ~28 m/s.
TEST(FlightThroughAir, FallsAtTheTerminalSpeed) {
  FlightSetup s;
  s.air_density_kg_m3 = kAirDensity_kg_m3;
  for (int i = 0; i < 2; ++i) {
    s.spheres[i].mass_kg = kM;
    s.spheres[i].diameter_m = kD;
    s.spheres[i].position_m = Vec3(i, 0, 0);
  }
  auto f = Flight::create(s);
  ASSERT_TRUE(f.ok()) << f.error().message;
  const Vec3 v = f->at(30.0)[0].velocity_m_s;
  const Vec3 a = nylon().acceleration(v) + kGravity_m_s2;
  EXPECT_LT(a.norm(), 1e-4 * kGravity_m_s2.norm());
  EXPECT_GT(-v.y(), 20.0);
  EXPECT_LT(-v.y(), 40.0);
}

// Two spheres through air meet where their centres are one diameter apart,
// and the impulse conserves their momentum.
TEST(FlightThroughAir, CollisionAtTheContactDistanceWithMomentumConserved) {
  FlightSetup s;
  s.air_density_kg_m3 = kAirDensity_kg_m3;
  s.spheres[0] = Sphere{kM, kD, Vec3(-0.1, 0.3, 0), Vec3(2.0, 0.1, 0.02), Vec3(0, 0, 30)};
  s.spheres[1] = Sphere{2 * kM, kD, Vec3(0.1, 0.31, 0), Vec3(-1.2, 0, 0), Vec3::Zero()};
  auto f = Flight::create(s);
  ASSERT_TRUE(f.ok()) << f.error().message;
  ASSERT_TRUE(f->collides());
  const auto& b = f->justBefore();
  const auto& a = f->justAfter();
  EXPECT_NEAR((b[0].position_m - b[1].position_m).norm(), kD, 1e-12);
  const Vec3 p_before = kM * b[0].velocity_m_s + 2 * kM * b[1].velocity_m_s;
  const Vec3 p_after = kM * a[0].velocity_m_s + 2 * kM * a[1].velocity_m_s;
  EXPECT_LT((p_after - p_before).norm(), 1e-15);
  // The states at the instant are the flight's own.
  const auto at = f->at(f->collisionTime_s() - 1e-9);
  EXPECT_NEAR((at[0].position_m - b[0].position_m).norm(), 0, 1e-8);
  // Drag slowed them: the contact comes later than in a vacuum.
  FlightSetup vacuum = s;
  vacuum.air_density_kg_m3 = 0;
  auto fv = Flight::create(vacuum);
  ASSERT_TRUE(fv.ok());
  EXPECT_GT(f->collisionTime_s(), fv->collisionTime_s());
  EXPECT_LT(f->collisionTime_s() - fv->collisionTime_s(), 1e-4);
}

TEST(FlightThroughAir, RefusesANegativeDensityOrDragCoefficient) {
  FlightSetup s;
  for (int i = 0; i < 2; ++i)
    s.spheres[i] = Sphere{kM, kD, Vec3(i, 0, 0), Vec3::Zero(), Vec3::Zero()};
  s.air_density_kg_m3 = -1;
  auto f = Flight::create(s);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("air_density_kg_m3"), std::string::npos);
  s.air_density_kg_m3 = 1.2;
  s.drag_coefficient = -0.4;
  f = Flight::create(s);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("drag_coefficient"), std::string::npos);
}

// A 30 ms track at 2000 frames/s of a sphere slowed by air: the fit that
// knows the drag gives the velocity at the track's end (where the contact
// would be) to 1e-6 m/s; with gravity alone it is off by about half the
// speed the drag took over the track (the test fails without the drag).
TEST(TrajectoryFitThroughAir, TheVelocityAtTheEndOfATrackIsTheTrueOne) {
  FlightSetup s;
  s.air_density_kg_m3 = kAirDensity_kg_m3;
  s.spheres[0] = Sphere{kM, kD, Vec3(-0.1, 0.0, 0), Vec3(1.5, 0.4, 0), Vec3::Zero()};
  s.spheres[1] = Sphere{kM, kD, Vec3(0.3, 0.5, 0), Vec3::Zero(), Vec3::Zero()};
  s.launch_time_s = {0.0, 1e6};
  auto f = Flight::create(s);
  ASSERT_TRUE(f.ok()) << f.error().message;
  const int n = 61;
  const double t_end = 0.05, dt = 1 / 2000.0;
  Eigen::VectorXd t(n);
  Eigen::MatrixXd p(n, 2);
  for (int i = 0; i < n; ++i) {
    t[i] = t_end - (n - 1 - i) * dt;
    p.row(i) = f->at(t[i])[0].position_m.head<2>().transpose();
  }
  const Vec3 truth = f->at(t_end)[0].velocity_m_s;
  TrajectoryOptions with;
  with.fixed_acceleration_m_s2 = kGravity_m_s2;
  with.drag = nylon();
  TrajectoryOptions without = with;
  without.drag.reset();
  auto fw = fitTrajectory(t, p, Weights::equal(), t_end, with);
  auto fo = fitTrajectory(t, p, Weights::equal(), t_end, without);
  ASSERT_TRUE(fw.ok() && fo.ok());
  const Vec3 vw = fw->velocityAt_m_s(t_end).value, vo = fo->velocityAt_m_s(t_end).value;
  const double lost = nylon().acceleration(truth).norm() * (t_end - t[0]);  // ~1 mm/s
  EXPECT_LT((vw - truth).head<2>().norm(), 1e-6);
  EXPECT_GT((vo - truth).head<2>().norm(), 0.3 * lost);
  EXPECT_LT((vo - truth).head<2>().norm(), 0.7 * lost);
  // Its acceleration is gravity and the drag there.
  EXPECT_LT((fw->acceleration_m_s2().value - kGravity_m_s2 - nylon().acceleration(truth))
                .head<2>()
                .norm(),
            1e-5);
}
