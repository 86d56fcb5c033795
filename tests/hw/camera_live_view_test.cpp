// The live-view tap on a camera: off by default (nothing published), on it
// publishes idle frames from the simulator and every frame of a burst, and a
// shot taken while a viewer holds a frame is unaffected.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "hw/camera.hpp"
#include "hw/sequencer.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using collide::hw::testing::simProfileText;

namespace {

Rig simRig() {
  auto profile = parseRigProfile(simProfileText(), "sim.toml");
  if (!profile) throw std::runtime_error(profile.error().message);
  auto rig = makeRig(*profile);
  if (!rig) throw std::runtime_error(rig.error().message);
  return std::move(*rig);
}

// Polls `done` every 5 ms for up to `seconds`.
template <class F>
bool waitFor(F done, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < until) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return done();
}

}  // namespace

TEST(CameraLiveView, OffByDefaultNothingIsPublished) {
  Rig rig = simRig();
  ASSERT_TRUE(bringUp(rig));
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  EXPECT_EQ(rig.camera->publishedFrames(), 0u);
  EXPECT_EQ(rig.camera->latestFrame(), nullptr);
  ASSERT_TRUE(shutDown(rig));
}

TEST(CameraLiveView, SimulatorPublishesIdleFramesAtViewerRate) {
  Rig rig = simRig();
  ASSERT_TRUE(bringUp(rig));
  rig.camera->setLiveView(true);
  ASSERT_TRUE(waitFor([&] { return rig.camera->publishedFrames() >= 3; }, 5.0));
  auto frame = rig.camera->latestFrame();
  ASSERT_NE(frame, nullptr);
  EXPECT_EQ(frame->image.cols, rig.profile.camera_config.width);
  EXPECT_EQ(frame->image.rows, rig.profile.camera_config.height);
  // About 25 per second while idle: far fewer than the 1000 frames/s stream.
  const auto before = rig.camera->publishedFrames();
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  const auto idle = rig.camera->publishedFrames() - before;
  EXPECT_GE(idle, 3u);
  EXPECT_LE(idle, 40u);
  rig.camera->setLiveView(false);
  ASSERT_TRUE(shutDown(rig));
}

TEST(CameraLiveView, BurstFramesArePublishedAndTheShotIsWhole) {
  Rig rig = simRig();
  ASSERT_TRUE(bringUp(rig));
  rig.camera->setLiveView(true);
  ASSERT_TRUE(waitFor([&] { return rig.camera->latestFrame() != nullptr; }, 5.0));
  // A viewer holds on to a frame during the shot.
  std::shared_ptr<const collide::vision::Frame> held = rig.camera->latestFrame();
  const auto before = rig.camera->publishedFrames();
  const Shot shot = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(shot.status, ShotStatus::Ok) << shot.failure_reason;
  const auto burst_frames = static_cast<std::uint64_t>(rig.profile.burst.pre_trigger_frames +
                                                       rig.profile.burst.post_trigger_frames);
  EXPECT_EQ(shot.burst.frames.size(), burst_frames);
  // Every burst frame went past the viewer as well.
  EXPECT_GE(rig.camera->publishedFrames() - before, burst_frames);
  EXPECT_FALSE(held->image.empty());
  (void)shutDown(rig);
}
