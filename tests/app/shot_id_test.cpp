#include "app/store/shot_id.hpp"

#include <gtest/gtest.h>

TEST(ShotId, FormatsUtcTimeAndSequence) {
  // 2026-11-22 02:30:05 UTC
  const std::int64_t t = 1795314605LL * 1000000000LL;
  EXPECT_EQ(collide::app::makeShotId(t, 7), "20261122-023005-0007");
  EXPECT_LT(collide::app::makeShotId(t, 7), collide::app::makeShotId(t + 1000000000LL, 0));
}

TEST(ShotId, NextIdIncrementsTheTrailingSequenceKeepingItsWidth) {
  using collide::app::nextShotId;
  EXPECT_EQ(nextShotId("20261122-023005-0007"), "20261122-023005-0008");
  EXPECT_EQ(nextShotId("20261122-023005-0099"), "20261122-023005-0100");
  EXPECT_EQ(nextShotId("20261122-023005-9999"), "20261122-023005-10000");
  EXPECT_EQ(nextShotId("shot"), "shot-0001");
  EXPECT_EQ(nextShotId("shot-a"), "shot-a-0001");
  // Sorting stays chronological within a second.
  EXPECT_LT(std::string("20261122-023005-0007"), nextShotId("20261122-023005-0007"));
}
