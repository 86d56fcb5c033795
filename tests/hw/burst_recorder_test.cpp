#include "hw/burst_recorder.hpp"

#include <gtest/gtest.h>

#include <set>

using collide::hw::BurstLayout;
using collide::hw::BurstRecorder;
using collide::vision::Frame;
using collide::vision::FrameStatus;

namespace {

constexpr std::int64_t kPeriod = 1'000'000;  // 1000 frames/s
constexpr std::int64_t kT0 = 5'000'000'000;

std::int64_t tsOf(std::uint64_t seq) {
  return kT0 + static_cast<std::int64_t>(seq) * kPeriod;
}

// A frame whose single pixel carries its camera sequence number, so tests can
// check which camera frame ended up with which id.
Frame frameFor(std::uint64_t seq, FrameStatus status = FrameStatus::Good) {
  Frame f;
  f.timestamp_ns = tsOf(seq);
  f.status = status;
  f.image = cv::Mat(1, 1, CV_16UC1, cv::Scalar(static_cast<double>(seq)));
  return f;
}

int seqIn(const Frame& f) {
  return f.image.at<std::uint16_t>(0, 0);
}

// Pushes seq first..last (inclusive) except those in `skip`.
void pushRange(BurstRecorder& r, std::uint64_t first, std::uint64_t last,
               const std::set<std::uint64_t>& skip = {}) {
  for (std::uint64_t s = first; s <= last; ++s)
    if (!skip.count(s)) r.push(s, frameFor(s));
}

}  // namespace

TEST(BurstRecorder, NumbersPreTriggerFramesNegativeAndFrameZeroAtTheTrigger) {
  BurstRecorder r(BurstLayout{5, 8, kPeriod});
  pushRange(r, 0, 29);  // the ring wraps many times before the trigger
  r.trigger(tsOf(30));
  EXPECT_FALSE(r.complete());
  pushRange(r, 30, 36);
  EXPECT_FALSE(r.complete());
  EXPECT_FALSE(r.push(37, frameFor(37)));  // frame post-1: burst complete
  EXPECT_TRUE(r.complete());
  EXPECT_FALSE(r.push(38, frameFor(38)));

  const collide::vision::Burst b = r.take();
  ASSERT_EQ(b.frames.size(), 13u);
  for (std::size_t i = 0; i < b.frames.size(); ++i) {
    EXPECT_EQ(b.frames[i].id, static_cast<std::int64_t>(i) - 5);
    EXPECT_EQ(seqIn(b.frames[i]), 25 + static_cast<int>(i));
  }
  EXPECT_TRUE(b.complete);
  EXPECT_EQ(b.stats.completed, 13u);
  EXPECT_EQ(b.stats.dropped, 0u);
  EXPECT_TRUE(b.note.empty()) << b.note;
}

TEST(BurstRecorder, TriggerBetweenFramesMakesTheNextExposureFrameZero) {
  BurstRecorder r(BurstLayout{3, 2, kPeriod});
  r.trigger(tsOf(10) - kPeriod / 3);
  pushRange(r, 0, 11);
  const auto b = r.take();
  ASSERT_EQ(b.frames.size(), 5u);
  EXPECT_EQ(b.frames.front().id, -3);
  EXPECT_EQ(seqIn(b.frames.front()), 7);
  EXPECT_EQ(b.frames[3].id, 0);
  EXPECT_EQ(seqIn(b.frames[3]), 10);
}

TEST(BurstRecorder, LostFramesAreReportedAsMissingIds) {
  BurstRecorder r(BurstLayout{4, 6, kPeriod});
  r.trigger(tsOf(20));
  pushRange(r, 10, 25, {18, 23});
  const auto b = r.take();
  EXPECT_TRUE(b.complete);
  EXPECT_EQ(b.stats.dropped, 2u);
  EXPECT_EQ(b.stats.missing_ids, (std::vector<std::int64_t>{-2, 3}));
  EXPECT_EQ(b.frames.size(), 8u);
}

TEST(BurstRecorder, LosingTheOldestFrameOfTheWindowCountsAsDropped) {
  BurstRecorder r(BurstLayout{3, 2, kPeriod});
  r.trigger(tsOf(20));
  pushRange(r, 15, 21, {17});  // 17 is frame -3, the first the burst wants
  const auto b = r.take();
  EXPECT_EQ(b.stats.missing_ids, (std::vector<std::int64_t>{-3}));
  EXPECT_TRUE(b.note.empty()) << b.note;
}

TEST(BurstRecorder, LostFrameZeroIsNumberedFromTheFramePeriod) {
  BurstRecorder r(BurstLayout{2, 4, kPeriod});
  r.trigger(tsOf(20) - 100);
  pushRange(r, 15, 23, {19, 20});  // the last pre-trigger frame and frame 0 lost
  const auto b = r.take();
  ASSERT_FALSE(b.frames.empty());
  EXPECT_EQ(b.frames.front().id, -2);
  EXPECT_EQ(seqIn(b.frames.front()), 18);
  EXPECT_EQ(b.stats.missing_ids, (std::vector<std::int64_t>{-1, 0}));
  EXPECT_EQ(seqIn(b.frames[1]), 21);
  EXPECT_EQ(b.frames[1].id, 1);
}

TEST(BurstRecorder, LastFrameLostStillCompletesWhenALaterOneArrives) {
  BurstRecorder r(BurstLayout{1, 3, kPeriod});
  r.trigger(tsOf(10));
  pushRange(r, 9, 11);
  EXPECT_FALSE(r.complete());
  r.push(13, frameFor(13));  // 12 (frame post-1) lost
  EXPECT_TRUE(r.complete());
  const auto b = r.take();
  EXPECT_EQ(b.stats.missing_ids, (std::vector<std::int64_t>{2}));
  EXPECT_EQ(b.frames.size(), 3u);
}

TEST(BurstRecorder, TriggerInThePastRenumbersFramesAlreadyInTheRing) {
  BurstRecorder r(BurstLayout{3, 5, kPeriod});
  pushRange(r, 0, 12);
  r.trigger(tsOf(9));
  EXPECT_FALSE(r.complete());
  pushRange(r, 13, 13);
  EXPECT_TRUE(r.complete());
  const auto b = r.take();
  ASSERT_EQ(b.frames.size(), 8u);
  EXPECT_EQ(b.frames[3].id, 0);
  EXPECT_EQ(seqIn(b.frames[3]), 9);
}

TEST(BurstRecorder, StreamEndingEarlyGivesAnIncompleteBurstWithItsFramesAndReason) {
  BurstRecorder r(BurstLayout{2, 10, kPeriod});
  r.trigger(tsOf(5));
  pushRange(r, 0, 8);
  r.endOfStream("link lost");
  EXPECT_TRUE(r.waitUntil(0));  // ended: no need to wait
  EXPECT_FALSE(r.push(9, frameFor(9)));
  const auto b = r.take();
  EXPECT_FALSE(b.complete);
  EXPECT_EQ(b.frames.size(), 6u);  // -2 .. 3
  EXPECT_NE(b.note.find("link lost"), std::string::npos) << b.note;
  EXPECT_NE(b.note.find("4 of 10"), std::string::npos) << b.note;
  EXPECT_EQ(b.stats.dropped, 0u);  // frames never sent are not transport losses
}

TEST(BurstRecorder, WaitReturnsFalseAtTheDeadlineWhileIncomplete) {
  BurstRecorder r(BurstLayout{0, 3, kPeriod});
  r.trigger(tsOf(0));
  pushRange(r, 0, 1);
  EXPECT_FALSE(r.waitUntil(0));  // deadline long past
  const auto b = r.take();
  EXPECT_FALSE(b.complete);
  EXPECT_NE(b.note.find("timed out"), std::string::npos) << b.note;
}

TEST(BurstRecorder, FailedFramesAreKeptAndCounted) {
  BurstRecorder r(BurstLayout{0, 3, kPeriod});
  r.trigger(tsOf(0));
  r.push(0, frameFor(0));
  r.push(1, frameFor(1, FrameStatus::Incomplete));
  r.push(2, frameFor(2));
  const auto b = r.take();
  EXPECT_EQ(b.stats.completed, 2u);
  EXPECT_EQ(b.stats.failed, 1u);
  ASSERT_EQ(b.frames.size(), 3u);
  EXPECT_EQ(b.frames[1].status, FrameStatus::Incomplete);
}

TEST(BurstRecorder, ShortPreTriggerHistoryIsNoted) {
  BurstRecorder r(BurstLayout{10, 2, kPeriod});
  r.trigger(tsOf(50));
  pushRange(r, 46, 51);
  const auto b = r.take();
  EXPECT_TRUE(b.complete);
  EXPECT_EQ(b.frames.front().id, -4);
  EXPECT_EQ(b.stats.dropped, 0u);
  EXPECT_NE(b.note.find("only 4 of 10 pre-trigger"), std::string::npos) << b.note;
}

TEST(BurstRecorder, WantsOnlyFramesThatCanEndInTheBurst) {
  BurstRecorder r(BurstLayout{3, 2, kPeriod});
  EXPECT_TRUE(r.wants(tsOf(0)));  // trigger unknown: any frame may be needed
  r.trigger(tsOf(100));
  EXPECT_FALSE(r.wants(tsOf(90)));
  EXPECT_TRUE(r.wants(tsOf(97)));
  pushRange(r, 97, 101);
  EXPECT_TRUE(r.complete());
  EXPECT_FALSE(r.wants(tsOf(102)));
}

TEST(BurstRecorder, NeverTriggeredSaysSo) {
  BurstRecorder r(BurstLayout{3, 2, kPeriod});
  pushRange(r, 0, 10);
  const auto b = r.take();
  EXPECT_FALSE(b.complete);
  EXPECT_TRUE(b.frames.empty());
  EXPECT_NE(b.note.find("never triggered"), std::string::npos);
}

// What the sequencer waits on while a slow camera delivers: frames taken in,
// out-of-order ones not counted, and never more than the burst can hold (a
// camera streaming frames that never reach the window stops counting).
TEST(BurstRecorder, ArrivalsCountFramesTakenInUpToWhatTheBurstHolds) {
  BurstRecorder r(BurstLayout{5, 8, kPeriod});
  EXPECT_EQ(r.arrivals(), 0u);
  pushRange(r, 0, 3);
  EXPECT_EQ(r.arrivals(), 4u);
  r.push(2, frameFor(2));  // out of order: ignored
  EXPECT_EQ(r.arrivals(), 4u);
  pushRange(r, 4, 40);  // never triggered: the ring wraps
  EXPECT_EQ(r.arrivals(), 13u);
}
