// What only the simulated regulator does: its first-order response and its
// fault knobs. The role's contract is in regulator_conformance_test.cpp.
#include "hw/pressure_regulator_sim.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

using namespace collide::hw;
using ::testing::HasSubstr;

namespace {

struct Bench {
  std::shared_ptr<ManualClock> clock = std::make_shared<ManualClock>();
  std::shared_ptr<SimWorld> world;
  std::unique_ptr<PressureRegulatorSim> reg;

  explicit Bench(RegulatorSimSettings s) {
    world = *SimWorld::create(*defaultRigProfile(), clock);
    reg = std::make_unique<PressureRegulatorSim>(world, s);
    EXPECT_TRUE(reg->open());
    EXPECT_TRUE(reg->configure({0.0, 300.0}));
    EXPECT_TRUE(reg->start());
  }
};

RegulatorSimSettings noiseless(
    RegulatorSimSettings::Fault fault = RegulatorSimSettings::Fault::None) {
  RegulatorSimSettings s;
  s.time_constant_s = 0.02;
  s.noise_kPa = 0.0;
  s.hold_band_kPa = 0.0;  // the pure first-order curve (the band: PressureLine's tests)
  s.fault = fault;
  return s;
}

}  // namespace

TEST(PressureRegulatorSim, AnswersASetpointWithAFirstOrderResponse) {
  Bench b(noiseless());
  ASSERT_TRUE(b.reg->setPressureKPa(0, 100.0));
  EXPECT_NEAR(*b.reg->readPressureKPa(0), 0.0, 1e-9);
  b.clock->advanceNs(20'000'000);  // one time constant
  EXPECT_NEAR(*b.reg->readPressureKPa(0), 100.0 * (1.0 - std::exp(-1.0)), 1e-6);
  b.clock->advanceNs(80'000'000);  // five in all
  EXPECT_NEAR(*b.reg->readPressureKPa(0), 100.0 * (1.0 - std::exp(-5.0)), 1e-6);
  // A new setpoint starts from where the line is, without a jump.
  const double now = *b.reg->readPressureKPa(0);
  ASSERT_TRUE(b.reg->setPressureKPa(0, 20.0));
  EXPECT_NEAR(*b.reg->readPressureKPa(0), now, 1e-9);
  EXPECT_NEAR(*b.reg->readPressureKPa(1), 0.0, 1e-9);  // the other line did not move
}

TEST(PressureRegulatorSim, ReadBackNoiseHasTheConfiguredSpread) {
  RegulatorSimSettings s = noiseless();
  s.noise_kPa = 0.5;
  Bench b(s);
  double sum = 0, sum2 = 0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const double p = *b.reg->readPressureKPa(0);
    sum += p;
    sum2 += p * p;
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.05);
  EXPECT_NEAR(sd, 0.5, 0.05);
}

TEST(PressureRegulatorSim, LeakFaultStallsShortOfTheSetpoint) {
  Bench b(noiseless(RegulatorSimSettings::Fault::NeverSettles));
  ASSERT_TRUE(b.reg->setPressureKPa(0, 100.0));
  b.clock->advanceNs(2'000'000'000);  // 100 time constants
  EXPECT_NEAR(*b.reg->readPressureKPa(0), 80.0, 1e-6);
  EXPECT_FALSE(*b.reg->settled(0, 0.5));
  // Venting still works: a leak does not stop the pressure falling.
  ASSERT_TRUE(b.reg->vent());
  b.clock->advanceNs(2'000'000'000);
  EXPECT_NEAR(*b.reg->readPressureKPa(0), 0.0, 1e-6);
}

TEST(PressureRegulatorSim, LinkFaultFailsEveryCallAfterTheFirstSetpoint) {
  Bench b(noiseless(RegulatorSimSettings::Fault::Error));
  ASSERT_TRUE(b.reg->setPressureKPa(0, 50.0));
  const auto read = b.reg->readPressureKPa(0);
  ASSERT_FALSE(read);
  EXPECT_THAT(read.error().message, HasSubstr("regulator \"sim\": no reply on the link"));
  EXPECT_FALSE(b.reg->setPressureKPa(0, 10.0));
  EXPECT_FALSE(b.reg->vent());
  // Reopening restores the link (a power cycle) until the next setpoint.
  ASSERT_TRUE(b.reg->close());
  ASSERT_TRUE(b.reg->open());
  ASSERT_TRUE(b.reg->configure({0.0, 300.0}));
  ASSERT_TRUE(b.reg->start());
  EXPECT_TRUE(b.reg->setPressureKPa(1, 10.0));
  EXPECT_FALSE(b.reg->readPressureKPa(1));
}
