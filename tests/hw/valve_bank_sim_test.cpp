// What only the simulated valve bank does: its log, launching the simulated
// spheres, and its fault knob. The role's contract is in
// valve_bank_conformance_test.cpp.
#include "hw/valve_bank_sim.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>

#include "hw/pressure_regulator_sim.hpp"

using namespace collide::hw;
using ::testing::HasSubstr;

namespace {

constexpr std::int64_t kMs = 1'000'000;

struct Bench {
  std::shared_ptr<ManualClock> clock = std::make_shared<ManualClock>();
  std::shared_ptr<SimWorld> world;
  std::unique_ptr<ValveBankSim> valves;

  explicit Bench(ValveSimSettings s) {
    world = *SimWorld::create(*defaultRigProfile(), clock);
    valves = std::make_unique<ValveBankSim>(world, clock, s);
    EXPECT_TRUE(valves->open());
    EXPECT_TRUE(valves->configure({50000}));
    EXPECT_TRUE(valves->start());
  }
};

}  // namespace

TEST(ValveBankSim, LogsEveryOpeningAndLaunchesTheSpheresFromTheLinePressure) {
  Bench b(ValveSimSettings{});
  b.world->commandPressureKPa(0, 60.0);
  b.world->commandPressureKPa(1, 30.0);
  b.clock->advanceNs(1000 * kMs);  // lines settled
  const std::int64_t t0 = b.clock->nowNs() + kMs;
  const auto events = b.valves->fire({{0, t0, 15000}, {1, t0 + 2 * kMs, 15000}});
  ASSERT_TRUE(events) << events.error().message;
  ASSERT_EQ(b.valves->log().size(), 2u);
  // No jitter configured: exactly as commanded.
  EXPECT_EQ(b.valves->log()[0].opened_ns, t0);
  EXPECT_EQ(b.valves->log()[1].opened_ns, t0 + 2 * kMs);
  EXPECT_EQ(b.valves->log()[1].pulseUs(), 15000);

  const auto launch = b.world->currentLaunch();
  ASSERT_TRUE(launch);
  EXPECT_TRUE(launch->launched[0] && launch->launched[1]);
  EXPECT_NEAR(launch->pressure_kPa[0], 60.0, 1e-6);
  EXPECT_NEAR(launch->pressure_kPa[1], 30.0, 1e-6);
  // Each sphere leaves its tube one exit delay (8 ms) after its valve opened.
  EXPECT_EQ(launch->launch_ns[1] - launch->launch_ns[0], 2 * kMs);
  EXPECT_EQ(launch->launch_ns[0], t0 + 8 * kMs);
  // Faster at the higher pressure, by the calibration (1 % scatter).
  const auto curve = collide::LaunchCalibration::thesis();
  EXPECT_NEAR(launch->exit_speed_m_s[0], curve.speed_m_s(60.0), 0.05 * curve.speed_m_s(60.0));
  EXPECT_NEAR(launch->exit_speed_m_s[1], curve.speed_m_s(30.0), 0.05 * curve.speed_m_s(30.0));
}

TEST(ValveBankSim, AValveWithoutPressureLeavesItsSphereInTheTube) {
  Bench b(ValveSimSettings{});
  const auto events = b.valves->fire({{0, b.clock->nowNs(), 1000}});
  ASSERT_TRUE(events);
  const auto launch = b.world->currentLaunch();
  ASSERT_TRUE(launch);
  EXPECT_FALSE(launch->launched[0]);
  EXPECT_FALSE(launch->launched[1]);
}

TEST(ValveBankSim, DriverFaultRefusesToFireAndClosesEverything) {
  ValveSimSettings s;
  s.fault = ValveSimSettings::Fault::Error;
  Bench b(s);
  const int closes_before = b.valves->closeAllCount();
  const auto events = b.valves->fire({{0, b.clock->nowNs(), 1000}});
  ASSERT_FALSE(events);
  EXPECT_THAT(events.error().message, HasSubstr("valves \"sim\": the driver refused"));
  EXPECT_THAT(events.error().message, HasSubstr("all valves closed"));
  EXPECT_EQ(b.valves->closeAllCount(), closes_before + 1);
  EXPECT_TRUE(b.valves->log().empty());
  EXPECT_FALSE(b.world->currentLaunch());
}

// The sequencer reads the regulator until its line settles, as often as the
// host's timing makes it: those reads (and their noise) must not change what
// the launch draws, or the same seed fires different shots from run to run.
TEST(ValveBankSim, ALaunchFollowsTheSeedNotHowOftenTheRegulatorWasRead) {
  ValveSimSettings s;
  s.jitter_us = 20.0;
  std::array<std::shared_ptr<const SimLaunch>, 2> launches;
  std::array<std::vector<ValveEvent>, 2> events;
  for (int run = 0; run < 2; ++run) {
    Bench b(s);
    b.world->commandPressureKPa(0, 60.0);
    b.world->commandPressureKPa(1, 30.0);
    b.clock->advanceNs(1000 * kMs);
    // Run 1 reads the regulator 17 times more, as a slower host would.
    for (int k = 0; k < (run == 0 ? 3 : 20); ++k)
      b.world->gaussian(SimWorld::Noise::Regulator, 0.05);
    const std::int64_t t0 = b.clock->nowNs() + kMs;
    const auto fired = b.valves->fire({{0, t0, 15000}, {1, t0 + 2 * kMs, 15000}});
    ASSERT_TRUE(fired) << fired.error().message;
    for (const ValveEvent& e : *fired)
      events[run].push_back({e.valve, e.opened_ns - t0, e.closed_ns - t0});
    launches[run] = b.world->currentLaunch();
    ASSERT_TRUE(launches[run]);
  }
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(events[0][i].opened_ns, events[1][i].opened_ns) << "valve " << i << "'s jitter";
    EXPECT_EQ(launches[0]->exit_speed_m_s[i], launches[1]->exit_speed_m_s[i]) << "sphere " << i;
    EXPECT_EQ(launches[0]->dots[i].centres, launches[1]->dots[i].centres) << "sphere " << i;
    const auto a = launches[0]->at(launches[0]->launch_ns[1] + 5 * kMs);
    const auto b = launches[1]->at(launches[1]->launch_ns[1] + 5 * kMs);
    EXPECT_EQ(a[i].spin_rad_s, b[i].spin_rad_s) << "sphere " << i;
    EXPECT_EQ(a[i].velocity_m_s, b[i].velocity_m_s) << "sphere " << i;
  }
}

// The sequencer fires once the line has settled within its tolerance and held
// there; how long that took depends on the host. The simulated regulator holds
// the line at its setpoint once within its hold band, so the pressure behind
// the sphere, and the shot, do not depend on it.
TEST(ValveBankSim, ALaunchFollowsTheSeedNotHowLongTheLineTookToSettle) {
  const LineModel line = RegulatorSimSettings{}.lineModel();  // the sim regulator's default
  ASSERT_GT(line.hold_band_kPa, 0.0);
  std::array<std::shared_ptr<const SimLaunch>, 2> launches;
  // 60 kPa from 0 with a 10 ms time constant: 0.15 kPa short after 60 ms (inside
  // the sequencer's 0.5 kPa tolerance), 0.007 kPa after 90 ms.
  const std::array<std::int64_t, 2> waited_ns = {60 * kMs, 90 * kMs};
  for (int run = 0; run < 2; ++run) {
    Bench b(ValveSimSettings{});
    b.world->setLineModel(0, line);
    b.world->setLineModel(1, line);
    b.world->commandPressureKPa(0, 60.0);
    b.world->commandPressureKPa(1, 60.0);
    b.clock->advanceNs(waited_ns[run]);
    const auto fired = b.valves->fire({{0, b.clock->nowNs(), 15000}});
    ASSERT_TRUE(fired) << fired.error().message;
    launches[run] = b.world->currentLaunch();
    ASSERT_TRUE(launches[run]);
    EXPECT_EQ(launches[run]->pressure_kPa[0], 60.0) << "after " << waited_ns[run] / kMs << " ms";
  }
  EXPECT_EQ(launches[0]->exit_speed_m_s[0], launches[1]->exit_speed_m_s[0]);
}
