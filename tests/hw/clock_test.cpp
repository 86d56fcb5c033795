#include "hw/clock.hpp"

#include <gtest/gtest.h>

#include <chrono>

using namespace collide::hw;

TEST(Clock, ManualClockMovesOnlyWhenToldAndSleepJumpsForward) {
  ManualClock clock(100);
  EXPECT_EQ(clock.nowNs(), 100);
  clock.advanceNs(50);
  EXPECT_EQ(clock.nowNs(), 150);
  clock.sleepUntilNs(1000);
  EXPECT_EQ(clock.nowNs(), 1000);
  clock.sleepUntilNs(500);  // the past: no change
  EXPECT_EQ(clock.nowNs(), 1000);
}

// Waits on condition variables use std::chrono::steady_clock with deadlines
// computed from CLOCK_MONOTONIC: the two must be the same clock.
TEST(Clock, SteadyClockIsClockMonotonic) {
  const std::int64_t before = monotonicNowNs();
  const std::int64_t steady = std::chrono::duration_cast<std::chrono::nanoseconds>(
                                  std::chrono::steady_clock::now().time_since_epoch())
                                  .count();
  const std::int64_t after = monotonicNowNs();
  EXPECT_GE(steady, before);
  EXPECT_LE(steady, after);
}

TEST(Clock, MonotonicSleepReturnsNoEarlierThanAsked) {
  auto clock = monotonicClock();
  const std::int64_t target = clock->nowNs() + 2'000'000;
  clock->sleepUntilNs(target);
  EXPECT_GE(clock->nowNs(), target);
}
