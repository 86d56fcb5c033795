#include "app/shot_id.hpp"

#include <gtest/gtest.h>

TEST(ShotId, FormatsUtcTimeAndSequence) {
  // 2026-11-22 02:30:05 UTC
  const std::int64_t t = 1795314605LL * 1000000000LL;
  EXPECT_EQ(collide::app::makeShotId(t, 7), "20261122-023005-0007");
  EXPECT_LT(collide::app::makeShotId(t, 7), collide::app::makeShotId(t + 1000000000LL, 0));
}
