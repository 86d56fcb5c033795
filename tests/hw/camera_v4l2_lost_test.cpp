// CameraV4l2 when its device goes away (unplugged, driver unbound), on the
// host without a VM, against the fake capture driver of fake_v4l2.hpp (every
// ioctl ENODEV once "unplugged"). The real driver path (vivid's "disconnect"
// control) is in tests/vm/v4l2_vm_test.cpp.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include "fake_v4l2.hpp"
#include "hw/camera_v4l2.hpp"
#include "hw/clock.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;
using collide::vision::PixelFormat;
using ::testing::AnyOf;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

class V4l2Lost : public ::testing::Test {
 protected:
  void SetUp() override {
    settings_ = fakeV4l2Settings();
    ASSERT_FALSE(settings_.path.empty()) << "memfd_create: " << std::strerror(errno);
  }

  static CameraConfig config() {
    return {0, 0, kWidth, kHeight, PixelFormat::Mono8, 100.0, 1000.0, 0.0};
  }

  CameraV4l2Settings settings_;
};

}  // namespace

TEST_F(V4l2Lost, TheFakeDriverStreamsFrames) {
  // The bench itself: without a loss, bursts arrive whole.
  CameraV4l2 cam(settings_);
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(config()));
  ASSERT_TRUE(cam.start());
  ASSERT_TRUE(cam.arm(2, 5));
  ASSERT_TRUE(cam.trigger(monotonicNowNs() + 50'000'000));
  const auto done = cam.waitBurst(monotonicNowNs() + 10'000'000'000);
  ASSERT_TRUE(done && *done);
  const auto b = cam.takeBurst();
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_TRUE(b->complete) << b->note;
  EXPECT_EQ(b->frames.size(), 7u);
  EXPECT_FALSE(cam.loss());
  ASSERT_TRUE(cam.close());
}

TEST_F(V4l2Lost, ADeviceUnpluggedMidBurstIsLostAndTheNextShotIsRefusedWithoutAskingIt) {
  CameraV4l2 cam(settings_);
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(config()));
  ASSERT_TRUE(cam.start());
  ASSERT_TRUE(cam.arm(2, 100000));
  ASSERT_TRUE(cam.trigger(monotonicNowNs() + 50'000'000));
  (void)cam.waitBurst(monotonicNowNs() + 200'000'000);  // some frames arrive
  fake().unplugged = true;
  const auto ended = cam.waitBurst(monotonicNowNs() + 30'000'000'000);
  ASSERT_TRUE(ended);
  ASSERT_TRUE(*ended) << "the burst never learned that the device was gone";
  const auto b = cam.takeBurst();
  ASSERT_TRUE(b) << b.error().message;  // what arrived is handed back
  EXPECT_FALSE(b->complete);
  EXPECT_FALSE(b->frames.empty());

  ASSERT_TRUE(cam.loss()) << "the camera did not mark itself lost";
  const std::string lost = lostMessage(*cam.loss());
  std::printf("the user reads: %s\n", lost.c_str());
  // The streaming thread finds it out taking a frame or giving one back.
  EXPECT_THAT(lost,
              StartsWith("camera \"" + settings_.path + "\" is lost (the device went away ("));
  EXPECT_THAT(lost, AnyOf(HasSubstr("(taking a frame: "), HasSubstr("(queueing a buffer: ")));
  EXPECT_THAT(lost, HasSubstr("retrying will not help"));
  EXPECT_THAT(lost, HasSubstr("v4l2-ctl --list-devices"));
  EXPECT_THAT(b->note, HasSubstr(lost));

  // The next shot: refused at once, and the device is not asked anything.
  const int asked = fake().calls.load();
  const auto armed = cam.arm(2, 10);
  ASSERT_FALSE(armed);
  EXPECT_EQ(armed.error().message, lost);
  EXPECT_EQ(fake().calls.load(), asked) << "arm() asked the lost device";
  (void)cam.stop();  // stopping is never refused (it may fail: the device is gone)
  const int asked_before_start = fake().calls.load();
  const auto restart = cam.start();
  ASSERT_FALSE(restart);
  EXPECT_EQ(restart.error().message, lost);
  EXPECT_EQ(fake().calls.load(), asked_before_start) << "start() asked the lost device";
  (void)cam.close();
}

TEST_F(V4l2Lost, ADeviceUnpluggedBetweenShotsIsLostAtTheNextStart) {
  CameraV4l2 cam(settings_);
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(config()));
  fake().unplugged = true;
  const auto s = cam.start();  // the first call to ask it finds it gone
  ASSERT_FALSE(s);
  ASSERT_TRUE(cam.loss());
  EXPECT_EQ(s.error().message, lostMessage(*cam.loss()));
  EXPECT_THAT(s.error().message, HasSubstr("allocating buffers"));
  const int asked = fake().calls.load();
  EXPECT_EQ(cam.start().error().message, s.error().message);
  EXPECT_EQ(cam.configure(config()).error().message, s.error().message);
  EXPECT_EQ(fake().calls.load(), asked) << "the lost device was asked again";
  // Reopening looks for it again: while it is gone that fails too.
  ASSERT_TRUE(cam.close());
  EXPECT_FALSE(cam.open());
  fake().unplugged = false;  // plugged back in: reopening finds it
  ASSERT_TRUE(cam.open());
  EXPECT_FALSE(cam.loss());
  ASSERT_TRUE(cam.configure(config()));
  ASSERT_TRUE(cam.start());
  ASSERT_TRUE(cam.close());
}

TEST_F(V4l2Lost, AnErrorThatIsNotAGoneDeviceDoesNotLoseIt) {
  CameraV4l2Settings s = settings_;
  s.frame_width = 640;  // more than the fake's buffers hold: it refuses the format (EINVAL)
  s.frame_height = 480;
  CameraV4l2 cam(s);
  ASSERT_TRUE(cam.open());
  const auto c = cam.configure({0, 0, 640, 480, PixelFormat::Mono8, 100.0, 1000.0, 0.0});
  ASSERT_FALSE(c);
  EXPECT_FALSE(cam.loss()) << c.error().message;
  EXPECT_THAT(c.error().message, HasSubstr("setting the format"));
}
