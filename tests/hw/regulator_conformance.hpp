#pragma once
// Conformance suite for the PressureRegulator role: every backend must pass
// it. A test program instantiates it for its backends:
//
//   INSTANTIATE_TEST_SUITE_P(Backends, RegulatorConformance,
//                            ::testing::Values(RegulatorBackend{"sim", &simBench}),
//                            [](const auto& info) { return info.param.name; });
//
// regulator_conformance_test.cpp runs it over the simulated backend; the
// Modbus backend runs it against a real Modbus server over loopback TCP and a
// pty pair (pressure_regulator_modbus_peer_test.cpp). A bench whose peer is
// missing sets `skip` and the suite skips with that reason.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <string>

#include "hw/clock.hpp"
#include "hw/device_health.hpp"
#include "hw/pressure_regulator.hpp"

namespace collide::hw::testing {

struct RegulatorBench {
  std::shared_ptr<Clock> clock;  // the clock the device runs on
  std::shared_ptr<void> keep_alive;
  std::unique_ptr<PressureRegulator> regulator;
  std::string skip;  // non-empty: the peer is missing, skip with this reason
  // Takes the device away (switched off, cable pulled); empty when the bench
  // cannot, and then `no_unplug_reason` says why (the lost-device case skips).
  std::function<void()> unplug;
  std::string no_unplug_reason;
  // Requests the device has been sent so far, where the bench can count them.
  std::function<std::int64_t()> requests;
};

struct RegulatorBackend {
  std::string name;
  std::function<RegulatorBench()> make;
};

class RegulatorConformance : public ::testing::TestWithParam<RegulatorBackend> {
 protected:
  void SetUp() override {
    bench_ = GetParam().make();
    if (!bench_.skip.empty()) GTEST_SKIP() << bench_.skip;
    ASSERT_TRUE(bench_.regulator);
  }

  PressureRegulator& reg() { return *bench_.regulator; }
  Clock& clock() { return *bench_.clock; }

  void bringUp(double min_kPa = 0.0, double max_kPa = 200.0) {
    ASSERT_TRUE(reg().open());
    ASSERT_TRUE(reg().configure({min_kPa, max_kPa}));
    ASSERT_TRUE(reg().start());
  }

  // Polls settled() every millisecond of the device's clock for up to 10 s
  // until it has held for 30 ms (three time constants of the benches), as the
  // sequencer waits for settle_hold: a single reading at the edge of the band
  // says little about the next one while the pressure is still moving.
  bool waitSettled(int channel, double tolerance_kPa) {
    const std::int64_t start = clock().nowNs();
    std::int64_t since = -1;
    while (clock().nowNs() - start < 10'000'000'000) {
      auto s = reg().settled(channel, tolerance_kPa);
      if (!s) ADD_FAILURE() << s.error().message;
      if (!s) return false;
      if (!*s)
        since = -1;
      else if (since < 0)
        since = clock().nowNs();
      else if (clock().nowNs() - since >= 30'000'000)
        return true;
      clock().sleepUntilNs(clock().nowNs() + 1'000'000);
    }
    return false;
  }

  RegulatorBench bench_;
};

TEST_P(RegulatorConformance, StartsClosedAndRefusesPressureCallsUntilRunning) {
  EXPECT_EQ(reg().state(), DeviceState::Closed);
  const auto set = reg().setPressureKPa(0, 10.0);
  ASSERT_FALSE(set);
  EXPECT_THAT(set.error().message,
              ::testing::HasSubstr("setPressureKPa() refused: the device is closed; "
                                   "call open() first"));
  EXPECT_FALSE(reg().readPressureKPa(0));
  EXPECT_FALSE(reg().vent());
  ASSERT_TRUE(reg().open());
  ASSERT_TRUE(reg().configure({0.0, 100.0}));
  EXPECT_THAT(reg().readPressureKPa(0).error().message, ::testing::HasSubstr("call start() first"));
}

TEST_P(RegulatorConformance, WalksTheLifecycle) {
  ASSERT_TRUE(reg().open());
  EXPECT_EQ(reg().state(), DeviceState::Open);
  EXPECT_THAT(reg().start().error().message, ::testing::HasSubstr("call configure() first"));
  ASSERT_TRUE(reg().configure({0.0, 150.0}));
  EXPECT_EQ(reg().state(), DeviceState::Configured);
  ASSERT_TRUE(reg().start());
  EXPECT_EQ(reg().state(), DeviceState::Running);
  EXPECT_THAT(reg().configure({0.0, 100.0}).error().message,
              ::testing::HasSubstr("call stop() first"));
  ASSERT_TRUE(reg().stop());
  EXPECT_EQ(reg().state(), DeviceState::Configured);
  ASSERT_TRUE(reg().start());
  ASSERT_TRUE(reg().close());
  EXPECT_EQ(reg().state(), DeviceState::Closed);
  EXPECT_FALSE(reg().readPressureKPa(0));
}

TEST_P(RegulatorConformance, ConfigureRefusesLimitsOutsideTheDeviceRange) {
  ASSERT_TRUE(reg().open());
  const RegulatorInfo info = reg().info();
  ASSERT_GE(info.channels, 2) << "a launcher rig needs two channels";
  const auto above = reg().configure({info.device_min_kPa, info.device_max_kPa + 1.0});
  ASSERT_FALSE(above);
  EXPECT_THAT(above.error().message, ::testing::HasSubstr("exceed the device's range"));
  EXPECT_FALSE(reg().configure({50.0, 40.0}));
  EXPECT_EQ(reg().state(), DeviceState::Open);
}

TEST_P(RegulatorConformance, RefusesSetpointsOutsideTheLimitsAndUnknownChannels) {
  bringUp(0.0, 120.0);
  const auto high = reg().setPressureKPa(0, 150.0);
  ASSERT_FALSE(high);
  EXPECT_THAT(high.error().message,
              ::testing::HasSubstr("150 kPa on channel 0 is outside the limits 0..120"));
  EXPECT_FALSE(reg().setPressureKPa(1, -5.0));
  const int channels = reg().info().channels;
  const auto none = reg().setPressureKPa(channels, 10.0);
  ASSERT_FALSE(none);
  EXPECT_THAT(none.error().message, ::testing::HasSubstr("no channel " + std::to_string(channels)));
  EXPECT_FALSE(reg().readPressureKPa(-1));
  EXPECT_EQ(*reg().setpointKPa(0), 0.0);  // refused setpoints are not remembered
}

TEST_P(RegulatorConformance, EachChannelSettlesAtItsOwnSetpoint) {
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(0, 40.0));
  ASSERT_TRUE(reg().setPressureKPa(1, 90.0));
  EXPECT_EQ(*reg().setpointKPa(0), 40.0);
  EXPECT_EQ(*reg().setpointKPa(1), 90.0);
  ASSERT_TRUE(waitSettled(0, 0.5));
  ASSERT_TRUE(waitSettled(1, 0.5));
  EXPECT_NEAR(*reg().readPressureKPa(0), 40.0, 0.5);
  EXPECT_NEAR(*reg().readPressureKPa(1), 90.0, 0.5);
}

TEST_P(RegulatorConformance, SettlesAgainAfterStopAndAfterReopening) {
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(0, 50.0));
  ASSERT_TRUE(waitSettled(0, 0.5));
  ASSERT_TRUE(reg().stop());
  ASSERT_TRUE(reg().start());
  ASSERT_TRUE(reg().setPressureKPa(0, 70.0));
  ASSERT_TRUE(waitSettled(0, 0.5));
  EXPECT_NEAR(*reg().readPressureKPa(0), 70.0, 0.5);
  ASSERT_TRUE(reg().close());
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(1, 30.0));
  EXPECT_EQ(*reg().setpointKPa(1), 30.0);
  ASSERT_TRUE(waitSettled(1, 0.5));
  EXPECT_NEAR(*reg().readPressureKPa(1), 30.0, 0.5);
}

TEST_P(RegulatorConformance, VentTakesEveryChannelToZero) {
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(0, 80.0));
  ASSERT_TRUE(reg().setPressureKPa(1, 60.0));
  ASSERT_TRUE(waitSettled(0, 0.5));
  ASSERT_TRUE(reg().vent());
  EXPECT_EQ(*reg().setpointKPa(0), 0.0);
  EXPECT_EQ(*reg().setpointKPa(1), 0.0);
  ASSERT_TRUE(waitSettled(0, 0.5));
  ASSERT_TRUE(waitSettled(1, 0.5));
  EXPECT_NEAR(*reg().readPressureKPa(1), 0.0, 0.5);
}

// A device that stops answering is lost: the call that found it out fails
// with what to check, and every later one is refused at once with the same
// sentence, without waiting out the link's timeout again or asking the device.
TEST_P(RegulatorConformance, ADeviceThatGoesAwayIsLostAndLaterCallsAreRefusedAtOnce) {
  if (!bench_.unplug) {
    ASSERT_FALSE(bench_.no_unplug_reason.empty()) << "a bench without unplug must say why";
    GTEST_SKIP() << bench_.no_unplug_reason;
  }
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(0, 40.0));
  ASSERT_TRUE(reg().readPressureKPa(0));
  bench_.unplug();
  const auto read = reg().readPressureKPa(0);
  ASSERT_FALSE(read) << "a device that is gone gave a reading";
  ASSERT_TRUE(reg().loss()) << "the regulator did not mark itself lost: " << read.error().message;
  const std::string lost = lostMessage(*reg().loss());
  EXPECT_THAT(lost, ::testing::HasSubstr(" is lost ("));
  EXPECT_THAT(lost, ::testing::HasSubstr("retrying will not help"));
  EXPECT_THAT(read.error().message, ::testing::HasSubstr(" is lost ("));
  const std::int64_t asked = bench_.requests ? bench_.requests() : 0;
  const std::int64_t t0 = clock().nowNs();
  const auto set = reg().setPressureKPa(0, 30.0);
  const auto again = reg().readPressureKPa(1);
  const std::int64_t took_ns = clock().nowNs() - t0;
  ASSERT_FALSE(set);
  ASSERT_FALSE(again);
  EXPECT_EQ(set.error().message, lost);
  EXPECT_EQ(again.error().message, lost);
  EXPECT_LT(took_ns, 20'000'000) << "a lost regulator waited for an answer";
  if (bench_.requests) {
    EXPECT_EQ(bench_.requests(), asked) << "a lost regulator was asked";
  }
  (void)reg().close();  // never refused (it may fail: the device is gone)
  EXPECT_EQ(reg().state(), DeviceState::Closed);
}

TEST_P(RegulatorConformance, VentIsAllowedBeforeStart) {
  ASSERT_TRUE(reg().open());
  EXPECT_TRUE(reg().vent());
}

}  // namespace collide::hw::testing
