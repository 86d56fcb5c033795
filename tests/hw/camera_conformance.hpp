#pragma once
// Conformance suite for the Camera role: every backend must pass it. A test
// program includes this header, defines a bench maker per backend and
// instantiates the suite with them (camera_conformance_test.cpp: sim and
// replay; camera_aravis_peer_test.cpp: Aravis' fake cameras, in-process and
// over loopback GigE Vision). A maker whose peer is missing returns no camera
// and a skip reason. Cameras stream on CLOCK_MONOTONIC in real time: waits
// have generous deadlines and nothing asserts how long a step took.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <memory>
#include <string>

#include "hw/camera.hpp"
#include "hw/clock.hpp"
#include "hw/device_health.hpp"

namespace collide::hw::testing {

using collide::vision::Burst;
using collide::vision::PixelFormat;
using ::testing::HasSubstr;

struct CameraBench {
  std::shared_ptr<void> keep_alive;
  std::unique_ptr<Camera> camera;
  CameraConfig config;  // a configuration the backend accepts
  // A camera with a hardware frame clock exposes one frame per period (the
  // suite checks the spacing to 2 %). A software-timed fake on a shared
  // machine may stall for many periods (its frame ids stay consecutive): then
  // only the order of the timestamps is checked.
  bool hardware_timed = true;
  // Extra time after arming, before the trigger or a stop: a software-timed
  // fake on a loaded machine may expose fewer frames than its rate says.
  std::int64_t extra_lead_ns = 0;
  std::string skip_reason;  // no camera: why the backend's peer is missing
  // Takes the device away (unplugged, killed) while the camera streams; empty
  // when the backend has no device that can go away, and then
  // `no_unplug_reason` says why (the lost-device case skips with it).
  std::function<void()> unplug;
  std::string no_unplug_reason;
  // Requests the device has been asked so far (empty: not countable).
  std::function<int()> requests;
};

struct CameraBackend {
  std::string name;
  std::function<CameraBench()> make;
};

constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kGenerousNs = 10'000'000'000;

class CameraConformance : public ::testing::TestWithParam<CameraBackend> {
 protected:
  void SetUp() override {
    bench_ = GetParam().make();
    if (!bench_.camera) GTEST_SKIP() << bench_.skip_reason;
  }
  Camera& cam() { return *bench_.camera; }
  const CameraConfig& config() const { return bench_.config; }

  void bringUp() {
    ASSERT_TRUE(cam().open());
    const auto c = cam().configure(config());
    ASSERT_TRUE(c) << c.error().message;
    const auto s = cam().start();
    ASSERT_TRUE(s) << s.error().message;
  }

  std::string configureError(CameraConfig c) {
    auto s = cam().configure(c);
    return s ? std::string("(accepted)") : s.error().message;
  }

  // Arms, triggers `lead_ns` from now (at least long enough for the
  // pre-trigger frames to be exposed after arming), waits (generously) and
  // takes the burst.
  Burst shoot(int pre, int post, std::int64_t& trigger_ns, std::int64_t lead_ns = 30 * kMs) {
    EXPECT_TRUE(cam().arm(pre, post));
    lead_ns = std::max(lead_ns, (pre + 3) * config().framePeriodNs()) + bench_.extra_lead_ns;
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

}  // namespace collide::hw::testing

namespace collide::hw::testing {

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
    if (i > 0 && bench_.hardware_timed) {
      EXPECT_NEAR(static_cast<double>(f.timestamp_ns - b.frames[i - 1].timestamp_ns),
                  static_cast<double>(period), 0.02 * period);
    }
    if (i > 0) {
      EXPECT_GT(f.timestamp_ns, b.frames[i - 1].timestamp_ns);
    }
  }
  // Frame 0 is the first frame exposed at or after the trigger.
  EXPECT_GE(b.frames[5].timestamp_ns, trigger);
  if (bench_.hardware_timed) {
    EXPECT_LT(b.frames[5].timestamp_ns, trigger + period);
  }
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

TEST_P(CameraConformance, StreamsAgainAfterStopAndAfterReopening) {
  bringUp();
  std::int64_t trigger = 0;
  const Burst first = shoot(2, 3, trigger);
  ASSERT_TRUE(first.complete) << first.note;
  // stop() then start(): the next burst is whole, its frames after the new trigger.
  ASSERT_TRUE(cam().stop());
  const auto restarted = cam().start();
  ASSERT_TRUE(restarted) << restarted.error().message;
  const Burst again = shoot(2, 3, trigger);
  ASSERT_TRUE(again.complete) << again.note;
  ASSERT_EQ(again.frames.size(), 5u);
  EXPECT_GE(again.frames[2].timestamp_ns, trigger);
  EXPECT_LT(again.frames[1].timestamp_ns, trigger);
  // close() then the whole bring-up again: the same.
  ASSERT_TRUE(cam().close());
  bringUp();
  const Burst reopened = shoot(2, 3, trigger);
  ASSERT_TRUE(reopened.complete) << reopened.note;
  ASSERT_EQ(reopened.frames.size(), 5u);
  EXPECT_GE(reopened.frames[2].timestamp_ns, trigger);
  EXPECT_LT(reopened.frames[1].timestamp_ns, trigger);
}

TEST_P(CameraConformance, StoppingWhileArmedKeepsWhatArrived) {
  bringUp();
  ASSERT_TRUE(cam().arm(3, 100000));
  ASSERT_TRUE(cam().trigger(monotonicNowNs() + 10 * kMs));
  (void)cam().waitBurst(monotonicNowNs() + 60 * kMs + bench_.extra_lead_ns);  // let frames arrive
  ASSERT_TRUE(cam().stop());
  const auto b = cam().takeBurst();  // allowed once stopped
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_FALSE(b->complete);
  EXPECT_FALSE(b->frames.empty());
  EXPECT_FALSE(b->note.empty());
}

TEST_P(CameraConformance, ADeviceThatGoesAwayMidBurstIsLostAndTheNextBurstIsRefused) {
  if (!bench_.unplug) {
    ASSERT_FALSE(bench_.no_unplug_reason.empty()) << "a bench without unplug must say why";
    GTEST_SKIP() << bench_.no_unplug_reason;
  }
  bringUp();
  ASSERT_TRUE(cam().arm(2, 100000));
  ASSERT_TRUE(cam().trigger(monotonicNowNs() + 20 * kMs));
  (void)cam().waitBurst(monotonicNowNs() + 200 * kMs + bench_.extra_lead_ns);  // frames arrive
  bench_.unplug();
  const auto ended = cam().waitBurst(monotonicNowNs() + 3 * kGenerousNs);
  ASSERT_TRUE(ended) << ended.error().message;
  ASSERT_TRUE(*ended) << "the burst never learned that the device was gone";
  const auto b = cam().takeBurst();  // what arrived is handed back
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_FALSE(b->complete);
  EXPECT_FALSE(b->frames.empty());
  ASSERT_TRUE(cam().loss()) << "the camera did not mark itself lost";
  const std::string lost = lostMessage(*cam().loss());
  EXPECT_THAT(lost, HasSubstr(" is lost ("));
  EXPECT_THAT(lost, HasSubstr("retrying will not help"));
  EXPECT_THAT(b->note, HasSubstr(lost));
  // The next burst is refused at once with the same sentence, asking the device nothing.
  const int asked = bench_.requests ? bench_.requests() : 0;
  const auto armed = cam().arm(2, 10);
  ASSERT_FALSE(armed);
  EXPECT_EQ(armed.error().message, lost);
  if (bench_.requests) {
    EXPECT_EQ(bench_.requests(), asked) << "arm() asked the lost device";
  }
  (void)cam().close();  // never refused (it may fail: the device is gone)
  EXPECT_EQ(cam().state(), DeviceState::Closed);
}

TEST_P(CameraConformance, ClosesFromRunning) {
  bringUp();
  ASSERT_TRUE(cam().arm(2, 2));
  ASSERT_TRUE(cam().close());
  EXPECT_EQ(cam().state(), DeviceState::Closed);
  EXPECT_FALSE(cam().takeBurst());
}

}  // namespace collide::hw::testing
