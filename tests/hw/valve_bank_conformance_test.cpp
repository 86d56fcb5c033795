// Conformance suite for the ValveBank role: every backend must pass it. A
// backend joins by adding a bench maker to the INSTANTIATE line (a real one,
// e.g. gpiod on a VM's gpio chip, runs on CLOCK_MONOTONIC and skips when its
// chip is missing). Timing bounds are generous: real valves jitter.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <memory>

#include "hw/clock.hpp"
#include "hw/sim_world.hpp"
#include "hw/valve_bank.hpp"
#include "hw/valve_bank_sim.hpp"

using namespace collide::hw;
using ::testing::HasSubstr;

namespace {

struct ValveBench {
  std::shared_ptr<Clock> clock;
  std::shared_ptr<void> keep_alive;
  std::unique_ptr<ValveBank> valves;
};

struct ValveBackend {
  std::string name;
  std::function<ValveBench()> make;
};

ValveBench simBench() {
  auto clock = std::make_shared<ManualClock>();
  auto world = *SimWorld::create(*defaultRigProfile(), clock);
  ValveSimSettings s;
  s.count = 2;
  s.jitter_us = 20.0;
  return {clock, world, std::make_unique<ValveBankSim>(world, clock, s)};
}

constexpr std::int64_t kMs = 1'000'000;

class ValveBankConformance : public ::testing::TestWithParam<ValveBackend> {
 protected:
  void SetUp() override { bench_ = GetParam().make(); }
  ValveBank& valves() { return *bench_.valves; }
  Clock& clock() { return *bench_.clock; }

  void bringUp(std::int64_t max_pulse_us = 50000) {
    ASSERT_TRUE(valves().open());
    ASSERT_TRUE(valves().configure({max_pulse_us}));
    ASSERT_TRUE(valves().start());
  }

  std::string fireError(const std::vector<ValvePulse>& pattern) {
    auto r = valves().fire(pattern);
    return r ? std::string("(fired)") : r.error().message;
  }

  ValveBench bench_;
};

}  // namespace

TEST_P(ValveBankConformance, RefusesToFireUntilRunning) {
  const auto r = valves().fire({{0, clock().nowNs(), 1000}});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message,
              HasSubstr("fire() refused: the device is closed; call open() first"));
  EXPECT_FALSE(valves().closeAll());
  ASSERT_TRUE(valves().open());
  EXPECT_TRUE(valves().closeAll());  // the safe state is always reachable once open
  EXPECT_FALSE(valves().configure({0}));
  ASSERT_TRUE(valves().configure({20000}));
  EXPECT_THAT(fireError({{0, clock().nowNs(), 1000}}), HasSubstr("call start() first"));
}

TEST_P(ValveBankConformance, FiresAPatternAndReportsWhatWasAchieved) {
  bringUp();
  ASSERT_GE(valves().info().valves, 2);
  const std::int64_t t0 = clock().nowNs() + 2 * kMs;
  const std::vector<ValvePulse> pattern{{1, t0 + 3 * kMs, 5000}, {0, t0, 2000}};
  const auto events = valves().fire(pattern);
  ASSERT_TRUE(events) << events.error().message;
  ASSERT_EQ(events->size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const ValveEvent& e = (*events)[i];
    EXPECT_EQ(e.valve, pattern[i].valve);
    EXPECT_NEAR(static_cast<double>(e.opened_ns), static_cast<double>(pattern[i].open_at_ns),
                1.0 * kMs);
    EXPECT_NEAR(static_cast<double>(e.pulseUs()), static_cast<double>(pattern[i].pulse_us), 500.0);
  }
  // fire() returns once every valve has closed again.
  EXPECT_GE(clock().nowNs(), (*events)[0].closed_ns);
  EXPECT_GE(clock().nowNs(), (*events)[1].closed_ns);
}

TEST_P(ValveBankConformance, AnOpeningAlreadyPastHappensAtOnce) {
  bringUp();
  const std::int64_t called = clock().nowNs();
  const auto events = valves().fire({{0, called - 5 * kMs, 1000}});
  ASSERT_TRUE(events) << events.error().message;
  EXPECT_GE((*events)[0].opened_ns, called);
  EXPECT_LT((*events)[0].opened_ns, called + 50 * kMs);
}

TEST_P(ValveBankConformance, RefusesBadPatterns) {
  bringUp(20000);
  const std::int64_t t = clock().nowNs();
  const int n = valves().info().valves;
  EXPECT_THAT(fireError({}), HasSubstr("the pattern names no valve"));
  EXPECT_THAT(fireError({{n, t, 1000}}),
              HasSubstr("valve " + std::to_string(n) + " does not exist"));
  EXPECT_THAT(fireError({{0, t, 1000}, {0, t, 1000}}), HasSubstr("appears twice"));
  EXPECT_THAT(fireError({{0, t, 0}}), HasSubstr("pulse of 0 us is outside 1..20000 us"));
  EXPECT_THAT(fireError({{0, t, 20001}}), HasSubstr("pulse of 20001 us is outside 1..20000 us"));
  EXPECT_THAT(fireError({{0, t + 20'000 * kMs, 1000}}), HasSubstr("too far ahead"));
}

TEST_P(ValveBankConformance, StopAndCloseLeaveNoValveOpen) {
  bringUp();
  ASSERT_TRUE(valves().stop());
  EXPECT_EQ(valves().state(), DeviceState::Configured);
  EXPECT_THAT(fireError({{0, clock().nowNs(), 1000}}), HasSubstr("call start() first"));
  ASSERT_TRUE(valves().start());
  ASSERT_TRUE(valves().close());
  EXPECT_EQ(valves().state(), DeviceState::Closed);
}

INSTANTIATE_TEST_SUITE_P(Backends, ValveBankConformance,
                         ::testing::Values(ValveBackend{"sim", &simBench}),
                         [](const auto& info) { return info.param.name; });
