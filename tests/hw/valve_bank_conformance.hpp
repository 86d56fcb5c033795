#pragma once
// Conformance suite for the ValveBank role: every backend must pass it. A test
// program includes this header, defines a bench maker per backend and
// instantiates the suite with them (valve_bank_conformance_test.cpp: sim on a
// manual clock; valve_bank_gpiod_test.cpp: gpiod over recording lines on
// CLOCK_MONOTONIC). A maker whose device is missing returns no bank and a
// skip reason.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hw/clock.hpp"
#include "hw/device_health.hpp"
#include "hw/valve_bank.hpp"

namespace collide::hw::testing {

constexpr std::int64_t kValveMs = 1'000'000;

struct Tolerance {
  std::int64_t early_ns = 0;
  std::int64_t late_ns = 0;
};

struct ValveBench {
  std::shared_ptr<Clock> clock;  // the clock the bank fires on
  std::shared_ptr<void> keep_alive;
  std::unique_ptr<ValveBank> valves;
  // How far an opening may land from the instant asked, and a pulse from the
  // width asked, early (before, shorter) or late (after, longer). A
  // simulated bank on a manual clock misses only by its simulated jitter
  // either way; a bank on CLOCK_MONOTONIC that sleeps up to each edge is
  // never early, but on a shared, loaded machine it may be scheduled late by
  // many ms (docs/benchmarks.md, "Firing path", measures how late).
  Tolerance opening{1 * kValveMs, 1 * kValveMs};
  Tolerance pulse{kValveMs / 2, kValveMs / 2};
  std::string skip_reason;  // no bank: why the backend's device is missing
  // Takes the device away (unplugged) while the bank is open; empty when the
  // backend has no device that can go away, and then `no_unplug_reason`
  // says why (the lost-device case skips with it).
  std::function<void()> unplug;
  std::string no_unplug_reason;
  // Requests the device has been asked so far (empty: not countable).
  std::function<int()> requests;
};

struct ValveBackend {
  std::string name;
  std::function<ValveBench()> make;
};

class ValveBankConformance : public ::testing::TestWithParam<ValveBackend> {
 protected:
  void SetUp() override {
    bench_ = GetParam().make();
    if (!bench_.valves) GTEST_SKIP() << bench_.skip_reason;
  }
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

}  // namespace collide::hw::testing

namespace collide::hw::testing {

using ::testing::HasSubstr;

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
  const std::int64_t t0 = clock().nowNs() + 2 * kValveMs;
  const std::vector<ValvePulse> pattern{{1, t0 + 3 * kValveMs, 5000}, {0, t0, 2000}};
  const auto events = valves().fire(pattern);
  ASSERT_TRUE(events) << events.error().message;
  ASSERT_EQ(events->size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const ValveEvent& e = (*events)[i];
    EXPECT_EQ(e.valve, pattern[i].valve);
    EXPECT_GE(e.opened_ns, pattern[i].open_at_ns - bench_.opening.early_ns) << "valve " << i;
    EXPECT_LE(e.opened_ns, pattern[i].open_at_ns + bench_.opening.late_ns) << "valve " << i;
    const std::int64_t width_ns = e.closed_ns - e.opened_ns;
    const std::int64_t asked_ns = pattern[i].pulse_us * 1000;
    EXPECT_GE(width_ns, asked_ns - bench_.pulse.early_ns) << "valve " << i;
    EXPECT_LE(width_ns, asked_ns + bench_.pulse.late_ns) << "valve " << i;
  }
  // fire() returns once every valve has closed again.
  EXPECT_GE(clock().nowNs(), (*events)[0].closed_ns);
  EXPECT_GE(clock().nowNs(), (*events)[1].closed_ns);
}

TEST_P(ValveBankConformance, AnOpeningAlreadyPastHappensAtOnce) {
  bringUp();
  const std::int64_t called = clock().nowNs();
  const auto events = valves().fire({{0, called - 5 * kValveMs, 1000}});
  ASSERT_TRUE(events) << events.error().message;
  EXPECT_GE((*events)[0].opened_ns, called);
  EXPECT_LT((*events)[0].opened_ns, called + 50 * kValveMs);
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
  EXPECT_THAT(fireError({{0, t + 20'000 * kValveMs, 1000}}), HasSubstr("too far ahead"));
}

TEST_P(ValveBankConformance, FiresAgainAfterStopAndAfterReopening) {
  bringUp();
  const auto fireOnce = [&](const char* when) {
    const std::int64_t at = clock().nowNs() + 2 * kValveMs;
    const auto events = valves().fire({{1, at, 1000}});
    ASSERT_TRUE(events) << when << ": " << events.error().message;
    ASSERT_EQ(events->size(), 1u) << when;
    EXPECT_EQ((*events)[0].valve, 1) << when;
    EXPECT_GE((*events)[0].opened_ns, at - bench_.opening.early_ns) << when;
    EXPECT_LE((*events)[0].opened_ns, at + bench_.opening.late_ns) << when;
  };
  fireOnce("first");
  ASSERT_TRUE(valves().stop());
  ASSERT_TRUE(valves().start());
  fireOnce("after stop() and start()");
  ASSERT_TRUE(valves().close());
  bringUp();
  fireOnce("after close() and open()");
}

TEST_P(ValveBankConformance, ADeviceThatGoesAwayIsLostAndTheNextFireIsRefused) {
  if (!bench_.unplug) {
    ASSERT_FALSE(bench_.no_unplug_reason.empty()) << "a bench without unplug must say why";
    GTEST_SKIP() << bench_.no_unplug_reason;
  }
  bringUp();
  ASSERT_TRUE(valves().fire({{0, clock().nowNs() + 2 * kValveMs, 1000}}));
  EXPECT_FALSE(valves().loss());
  bench_.unplug();
  const auto failed = valves().fire({{0, clock().nowNs() + 2 * kValveMs, 1000}});
  ASSERT_FALSE(failed);
  ASSERT_TRUE(valves().loss()) << "the bank did not mark itself lost: " << failed.error().message;
  const std::string lost = lostMessage(*valves().loss());
  EXPECT_THAT(lost, HasSubstr(" is lost ("));
  EXPECT_THAT(lost, HasSubstr("retrying will not help"));
  EXPECT_THAT(failed.error().message, HasSubstr(lost));
  // The next fire() is refused at once with the same sentence, driving nothing.
  const int asked = bench_.requests ? bench_.requests() : 0;
  const auto refused = valves().fire({{0, clock().nowNs() + 2 * kValveMs, 1000}});
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().message, lost);
  if (bench_.requests) {
    EXPECT_EQ(bench_.requests(), asked) << "fire() drove the lost device";
  }
  (void)valves().close();  // never refused (closing the valves may fail: the device is gone)
  EXPECT_EQ(valves().state(), DeviceState::Closed);
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

}  // namespace collide::hw::testing
