// Conformance suite for the Camera role: every backend must pass it. A backend
// joins by adding a bench maker to the INSTANTIATE line (a real one, e.g.
// Aravis against arv-fake-gv-camera on loopback, skips when its peer is
// missing). Cameras stream on CLOCK_MONOTONIC in real time: waits have
// generous deadlines and nothing asserts how long a step took.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <memory>

#include "hw/camera.hpp"
#include "hw/camera_replay.hpp"
#include "hw/camera_sim.hpp"
#include "hw/clock.hpp"
#include "hw/sim_world.hpp"

using namespace collide::hw;
using collide::vision::Burst;
using collide::vision::PixelFormat;
using ::testing::HasSubstr;

namespace {

struct CameraBench {
  std::shared_ptr<void> keep_alive;
  std::unique_ptr<Camera> camera;
  CameraConfig config;  // a configuration the backend accepts
};

struct CameraBackend {
  std::string name;
  std::function<CameraBench()> make;
};

CameraBench simBench() {
  auto world = *SimWorld::create(*defaultRigProfile(), monotonicClock());
  CameraSimSettings s;
  s.noise_grey = 1.0;
  CameraConfig c{0, 0, 160, 120, PixelFormat::Mono8, 1000.0, 200.0, 0.0};
  return {world, std::make_unique<CameraSim>(world, s), c};
}

// A stored burst of 12 pre- and 20 post-trigger frames at 500 frames/s.
Burst storedBurst() {
  Burst b;
  b.format = PixelFormat::Mono12;
  b.fps = 500.0;
  b.exposure_us = 100.0;
  for (int id = -12; id < 20; ++id) {
    collide::vision::Frame f;
    f.id = id;
    f.timestamp_ns = 7'000'000'000 + id * 2'000'000;
    f.image = cv::Mat(48, 64, CV_16UC1, cv::Scalar(1000 + id));
    b.frames.push_back(f);
  }
  return b;
}

CameraBench replayBench() {
  CameraConfig c{0, 0, 64, 48, PixelFormat::Mono12, 500.0, 100.0, 0.0};
  return {nullptr, std::make_unique<CameraReplay>(storedBurst(), "stored", true), c};
}

constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kGenerousNs = 10'000'000'000;

class CameraConformance : public ::testing::TestWithParam<CameraBackend> {
 protected:
  void SetUp() override { bench_ = GetParam().make(); }
  Camera& cam() { return *bench_.camera; }
  const CameraConfig& config() const { return bench_.config; }

  void bringUp() {
    ASSERT_TRUE(cam().open());
    const auto c = cam().configure(config());
    ASSERT_TRUE(c) << c.error().message;
    ASSERT_TRUE(cam().start());
  }

  std::string configureError(CameraConfig c) {
    auto s = cam().configure(c);
    return s ? std::string("(accepted)") : s.error().message;
  }

  // Arms, triggers `lead_ns` from now, waits (generously) and takes the burst.
  Burst shoot(int pre, int post, std::int64_t& trigger_ns, std::int64_t lead_ns = 30 * kMs) {
    EXPECT_TRUE(cam().arm(pre, post));
    trigger_ns = monotonicNowNs() + lead_ns;
    EXPECT_TRUE(cam().trigger(trigger_ns));
    const auto done = cam().waitBurst(monotonicNowNs() + kGenerousNs);
    EXPECT_TRUE(done && *done);
    auto burst = cam().takeBurst();
    EXPECT_TRUE(burst) << burst.error().message;
    return burst ? std::move(burst).value() : Burst{};
  }

  CameraBench bench_;
};

}  // namespace

TEST_P(CameraConformance, RefusesCallsOutOfOrder) {
  EXPECT_THAT(cam().arm(1, 1).error().message,
              HasSubstr("arm() refused: the device is closed; call open() first"));
  ASSERT_TRUE(cam().open());
  ASSERT_TRUE(cam().configure(config()));
  EXPECT_THAT(cam().arm(1, 1).error().message, HasSubstr("call start() first"));
  ASSERT_TRUE(cam().start());
  EXPECT_THAT(cam().trigger(monotonicNowNs()).error().message, HasSubstr("no burst is armed"));
  EXPECT_THAT(cam().takeBurst().error().message, HasSubstr("no burst is armed"));
  EXPECT_THAT(configureError(config()), HasSubstr("call stop() first"));
  EXPECT_FALSE(cam().arm(-1, 5));
  EXPECT_FALSE(cam().arm(5, 0));
}

TEST_P(CameraConformance, ConfigureRefusesWhatTheCameraCannotDo) {
  ASSERT_TRUE(cam().open());
  const CameraInfo info = cam().info();
  CameraConfig c = config();
  c.roi_x = info.sensor_width - c.width + 1;
  EXPECT_THAT(configureError(c), HasSubstr("does not fit the"));
  c = config();
  c.fps = info.max_fps * 2;
  c.exposure_us = 1.0;
  EXPECT_THAT(configureError(c), HasSubstr("frames/s is outside"));
  c = config();
  c.exposure_us = 1e6 / c.fps + 1;
  EXPECT_THAT(configureError(c), HasSubstr("at most one frame"));
  c = config();
  c.gain_db = info.max_gain_db + 1;
  EXPECT_THAT(configureError(c), HasSubstr("gain"));
  EXPECT_EQ(cam().state(), DeviceState::Open);
}

TEST_P(CameraConformance, DeliversPreAndPostTriggerFramesAroundTheTrigger) {
  bringUp();
  std::int64_t trigger = 0;
  const Burst b = shoot(5, 8, trigger);
  ASSERT_TRUE(b.complete) << b.note;
  ASSERT_EQ(b.frames.size(), 13u);
  const std::int64_t period = config().framePeriodNs();
  for (std::size_t i = 0; i < b.frames.size(); ++i) {
    const auto& f = b.frames[i];
    EXPECT_EQ(f.id, static_cast<std::int64_t>(i) - 5);
    EXPECT_TRUE(f.good());
    EXPECT_EQ(f.image.cols, config().width);
    EXPECT_EQ(f.image.rows, config().height);
    EXPECT_EQ(f.image.type(), collide::vision::cvType(config().format));
    if (i > 0) {
      EXPECT_NEAR(static_cast<double>(f.timestamp_ns - b.frames[i - 1].timestamp_ns),
                  static_cast<double>(period), 0.02 * period);
    }
  }
  // Frame 0 is the first frame exposed at or after the trigger.
  EXPECT_GE(b.frames[5].timestamp_ns, trigger);
  EXPECT_LT(b.frames[5].timestamp_ns, trigger + period);
  EXPECT_LT(b.frames[4].timestamp_ns, trigger);
  EXPECT_EQ(b.stats.completed, 13u);
  EXPECT_EQ(b.stats.dropped, 0u);
  EXPECT_EQ(b.format, config().format);
  EXPECT_DOUBLE_EQ(b.fps, config().fps);
  EXPECT_DOUBLE_EQ(b.exposure_us, config().exposure_us);
}

TEST_P(CameraConformance, ArmsAgainForTheNextBurst) {
  bringUp();
  std::int64_t t1 = 0, t2 = 0;
  const Burst first = shoot(2, 3, t1);
  const Burst second = shoot(2, 3, t2);
  ASSERT_TRUE(first.complete) << first.note;
  ASSERT_TRUE(second.complete) << second.note;
  EXPECT_EQ(second.frames.size(), 5u);
  EXPECT_GT(second.frames.front().timestamp_ns, first.frames.back().timestamp_ns);
}

TEST_P(CameraConformance, StoppingWhileArmedKeepsWhatArrived) {
  bringUp();
  ASSERT_TRUE(cam().arm(3, 100000));
  ASSERT_TRUE(cam().trigger(monotonicNowNs() + 10 * kMs));
  (void)cam().waitBurst(monotonicNowNs() + 60 * kMs);  // let some frames arrive
  ASSERT_TRUE(cam().stop());
  const auto b = cam().takeBurst();  // allowed once stopped
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_FALSE(b->complete);
  EXPECT_FALSE(b->frames.empty());
  EXPECT_FALSE(b->note.empty());
}

TEST_P(CameraConformance, ClosesFromRunning) {
  bringUp();
  ASSERT_TRUE(cam().arm(2, 2));
  ASSERT_TRUE(cam().close());
  EXPECT_EQ(cam().state(), DeviceState::Closed);
  EXPECT_FALSE(cam().takeBurst());
}

INSTANTIATE_TEST_SUITE_P(Backends, CameraConformance,
                         ::testing::Values(CameraBackend{"sim", &simBench},
                                           CameraBackend{"replay", &replayBench}),
                         [](const auto& info) { return info.param.name; });
