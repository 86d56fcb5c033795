#include "vision/frame_parallel.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <stdexcept>
#include <thread>
#include <vector>

#include "shot_fixture.hpp"
#include "vision/shot_analysis.hpp"

namespace collide::vision {
namespace {

// Sets COLLIDE_THREADS for one scope.
struct ThreadsEnv {
  explicit ThreadsEnv(const char* value) { setenv("COLLIDE_THREADS", value, 1); }
  ~ThreadsEnv() { unsetenv("COLLIDE_THREADS"); }
};

TEST(FrameParallel, EveryFrameOnceProgressOnTheCallingThreadInOrder) {
  const std::size_t n = 257;
  std::vector<std::atomic<int>> seen(n);
  std::vector<int> reported;
  const std::thread::id caller = std::this_thread::get_id();
  bool progress_elsewhere = false;
  forEachFrame(
      n, [&](std::size_t k) { seen[k].fetch_add(1); },
      [&](int done, int total) {
        EXPECT_EQ(total, static_cast<int>(n));
        progress_elsewhere |= std::this_thread::get_id() != caller;
        reported.push_back(done);
      });
  for (std::size_t k = 0; k < n; ++k) EXPECT_EQ(seen[k].load(), 1) << "frame " << k;
  EXPECT_FALSE(progress_elsewhere);
  ASSERT_FALSE(reported.empty());
  EXPECT_EQ(reported.back(), static_cast<int>(n));
  for (std::size_t i = 1; i < reported.size(); ++i) EXPECT_GT(reported[i], reported[i - 1]);
}

TEST(FrameParallel, TheFirstErrorStopsTheRestAndIsRethrown) {
  // Frames after the bad one wait (up to 2 s) until it has thrown, then take
  // 1 ms each: otherwise another thread may finish every frame while the
  // throw is still being unwound and caught (slow under ASan, or when the
  // throwing thread is preempted on a loaded machine; seen in a full ctest
  // run), and nothing is left to stop. Without the stop, the 10,000 frames
  // take 10 s and the check below fails.
  std::atomic<int> ran{0};
  std::atomic<bool> thrown{false};
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW(forEachFrame(10000,
                            [&](std::size_t k) {
                              ran.fetch_add(1);
                              if (k == 3) {
                                thrown = true;
                                throw std::runtime_error("frame 3 is corrupt");
                              }
                              if (k < 3) return;
                              while (!thrown && std::chrono::steady_clock::now() - start <
                                                    std::chrono::seconds(2))
                                std::this_thread::yield();
                              std::this_thread::sleep_for(std::chrono::milliseconds(1));
                            }),
               std::runtime_error);
  EXPECT_LT(ran.load(), 10000) << "frames went on after the error";
  forEachFrame(0, [](std::size_t) { FAIL() << "no frame to run"; });
}

TEST(FrameParallel, ThreadsFollowTheEnvironmentCap) {
  {
    ThreadsEnv one("1");
    EXPECT_EQ(frameThreads(), 1);
  }
  {
    ThreadsEnv junk("two");  // not a number: ignored
    EXPECT_GE(frameThreads(), 1);
  }
  EXPECT_LE(frameThreads(), static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
}

// The analysis on one thread and on all: the same numbers, to the last bit
// (each frame's work is the same whichever thread does it).
TEST(FrameParallel, AShotAnalysesTheSameOnOneThreadAndOnAll) {
  testing::ShotSpec spec;
  spec.seed = 51;
  spec.frames_before = 20;
  spec.frames_after = 20;
  const testing::SimulatedShot shot = testing::simulateShot(spec);
  Result<ShotAnalysis> one = fail("not run");
  {
    ThreadsEnv single("1");
    one = analyzeBurst(shot.burst, shot.settings);
  }
  const auto all = analyzeBurst(shot.burst, shot.settings);
  ASSERT_TRUE(one.ok()) << one.error().message;
  ASSERT_TRUE(all.ok()) << all.error().message;
  EXPECT_EQ(one->collision.e.value, all->collision.e.value);
  EXPECT_EQ(one->collision.e.sigma, all->collision.e.sigma);
  EXPECT_EQ(one->collision.beta.value, all->collision.beta.value);
  for (int s = 0; s < 2; ++s) {
    EXPECT_EQ(one->sphere[s].spin_before_rad_s.value, all->sphere[s].spin_before_rad_s.value);
    EXPECT_EQ(one->sphere[s].spin_after_rad_s.value, all->sphere[s].spin_after_rad_s.value);
  }
  EXPECT_EQ(one->quality_flags, all->quality_flags);
}

}  // namespace
}  // namespace collide::vision
