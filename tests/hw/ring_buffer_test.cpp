#include "hw/ring_buffer.hpp"

#include <gtest/gtest.h>

using collide::hw::RingBuffer;

TEST(RingBuffer, KeepsInsertionOrderUntilFull) {
  RingBuffer<int> ring(3);
  EXPECT_TRUE(ring.empty());
  EXPECT_FALSE(ring.push(1).has_value());
  EXPECT_FALSE(ring.push(2).has_value());
  ASSERT_EQ(ring.size(), 2u);
  EXPECT_EQ(ring[0], 1);
  EXPECT_EQ(ring[1], 2);
  EXPECT_EQ(ring.newest(), 2);
  EXPECT_FALSE(ring.full());
}

TEST(RingBuffer, WrapOverwritesTheOldestAndReturnsIt) {
  RingBuffer<int> ring(3);
  for (int i = 1; i <= 3; ++i) ring.push(i);
  EXPECT_TRUE(ring.full());
  auto evicted = ring.push(4);
  ASSERT_TRUE(evicted.has_value());
  EXPECT_EQ(*evicted, 1);
  evicted = ring.push(5);
  ASSERT_TRUE(evicted.has_value());
  EXPECT_EQ(*evicted, 2);
  ASSERT_EQ(ring.size(), 3u);
  EXPECT_EQ(ring[0], 3);
  EXPECT_EQ(ring[1], 4);
  EXPECT_EQ(ring[2], 5);
}

TEST(RingBuffer, WrapsManyTimesAndDrainsOldestFirst) {
  RingBuffer<int> ring(4);
  for (int i = 0; i < 103; ++i) ring.push(i);
  const std::vector<int> drained = ring.drain();
  EXPECT_EQ(drained, (std::vector<int>{99, 100, 101, 102}));
  EXPECT_TRUE(ring.empty());
  ring.push(7);
  EXPECT_EQ(ring[0], 7);
}

TEST(RingBuffer, ZeroCapacityBecomesOne) {
  RingBuffer<int> ring(0);
  EXPECT_EQ(ring.capacity(), 1u);
  ring.push(1);
  EXPECT_EQ(*ring.push(2), 1);
  EXPECT_EQ(ring.newest(), 2);
}
