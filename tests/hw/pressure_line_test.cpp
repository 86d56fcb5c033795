// PressureLine, the regulator dynamics shared by the simulated regulator and
// the simulated Modbus regulator, against the analytic first-order response.
#include "hw/pressure_line.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace collide::hw;

namespace {
constexpr std::int64_t kMs = 1'000'000;
}

TEST(PressureLine, FollowsTheFirstOrderStepResponse) {
  PressureLine line;
  line.setModel({0.02, 1.0}, 0);
  line.command(100.0, 0);
  EXPECT_DOUBLE_EQ(line.pressureKPa(0), 0.0);
  for (int ms : {5, 20, 40, 100})
    EXPECT_NEAR(line.pressureKPa(ms * kMs), 100.0 * (1.0 - std::exp(-ms / 20.0)), 1e-9) << ms;
  EXPECT_DOUBLE_EQ(line.targetKPa(), 100.0);
  // Before the command (a clock read earlier) the line has not moved.
  EXPECT_DOUBLE_EQ(line.pressureKPa(-5 * kMs), 0.0);
}

TEST(PressureLine, ANewSetpointStartsFromWhereTheLineIs) {
  PressureLine line;
  line.setModel({0.01, 1.0}, 0);
  line.command(100.0, 0);
  const double at_10ms = line.pressureKPa(10 * kMs);  // 63.2 kPa
  line.command(20.0, 10 * kMs);
  EXPECT_DOUBLE_EQ(line.pressureKPa(10 * kMs), at_10ms);  // no jump
  EXPECT_NEAR(line.pressureKPa(20 * kMs), 20.0 + (at_10ms - 20.0) * std::exp(-1.0), 1e-9);
}

TEST(PressureLine, ALeakStallsARiseButNotAFall) {
  PressureLine line;
  line.setModel({0.01, kLeakReach}, 0);
  line.command(100.0, 0);
  EXPECT_NEAR(line.pressureKPa(1000 * kMs), 80.0, 1e-9);
  line.command(0.0, 1000 * kMs);
  EXPECT_NEAR(line.pressureKPa(2000 * kMs), 0.0, 1e-9);
}

TEST(PressureLine, ArrivesAtTheGoalOnceWithinTheHoldBand) {
  PressureLine line;
  line.setModel({0.01, 1.0, 1.0}, 0);
  line.command(100.0, 0);
  // The first-order curve until 1 kPa short: 100 (1 - e^-t/tau) at t = tau ln 100 = 46.05 ms.
  EXPECT_NEAR(line.pressureKPa(40 * kMs), 100.0 * (1.0 - std::exp(-4.0)), 1e-9);
  EXPECT_NEAR(line.pressureKPa(46 * kMs), 100.0 * (1.0 - std::exp(-4.6)), 1e-9);
  EXPECT_EQ(line.pressureKPa(47 * kMs), 100.0);
  EXPECT_EQ(line.pressureKPa(500 * kMs), 100.0);
  // A leak's goal is where the line stalls (80 % of the rise), and it holds there.
  line.setModel({0.01, kLeakReach, 1.0}, 500 * kMs);
  line.command(200.0, 500 * kMs);
  EXPECT_EQ(line.pressureKPa(1500 * kMs), 180.0);
}
