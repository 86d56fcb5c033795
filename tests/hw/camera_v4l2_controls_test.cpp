// Exposure and gain on a V4L2 driver, setting by setting (issue 14): after
// configure() the device holds what the profile asked, read back from it; a
// value the driver rounds to its step or clamps without an error (as the
// kernel's control framework does) is refused, naming what it took, so a shot
// never records settings the camera did not run with. Against the fake
// driver of fake_v4l2.hpp with its controls on (the real V4l2Device code).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cerrno>
#include <cstring>

#include "fake_v4l2.hpp"

using namespace collide;
using namespace collide::hw;
using namespace collide::hw::testing;
using ::testing::HasSubstr;

namespace {

// 10 raw gain units per dB: the fake's gain step (4) is 0.4 dB.
CameraV4l2Settings settingsWithControls() {
  fake().with_controls = true;
  CameraV4l2Settings s = fakeV4l2Settings();
  s.exposure_control = true;
  s.gain_raw_per_db = 10.0;
  return s;
}

CameraConfig config(double exposure_us, double gain_db) {
  return {0, 0, kWidth, kHeight, vision::PixelFormat::Mono8, 100.0, exposure_us, gain_db};
}

std::int64_t held(std::uint32_t id) {
  return fake().controlById(id)->value;
}

}  // namespace

TEST(CameraV4l2Controls, EachSettingIsWhatTheDeviceHolds) {
  const CameraV4l2Settings s = settingsWithControls();
  if (s.path.empty()) GTEST_SKIP() << "no memfd for the fake device: " << std::strerror(errno);
  CameraV4l2 cam(s);
  ASSERT_TRUE(cam.open());
  EXPECT_DOUBLE_EQ(cam.info().max_gain_db, 25.5);  // raw 255 at 10 per dB
  for (const auto& [exposure_us, gain_db] :
       std::vector<std::pair<double, double>>{{300, 2.0}, {1000, 0.0}, {7500, 12.4}}) {
    const Status st = cam.configure(config(exposure_us, gain_db));
    ASSERT_TRUE(st) << st.error().message;
    EXPECT_EQ(held(V4L2_CID_EXPOSURE_ABSOLUTE) * 100, exposure_us);
    EXPECT_EQ(held(V4L2_CID_GAIN), std::llround(10 * gain_db));
    EXPECT_EQ(held(V4L2_CID_EXPOSURE_AUTO), V4L2_EXPOSURE_MANUAL);
    EXPECT_DOUBLE_EQ(cam.config().exposure_us, exposure_us);
  }
}

TEST(CameraV4l2Controls, AValueTheDriverRoundsIsRefusedNamingWhatItTook) {
  const CameraV4l2Settings s = settingsWithControls();
  if (s.path.empty()) GTEST_SKIP() << "no memfd for the fake device: " << std::strerror(errno);
  CameraV4l2 cam(s);
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(config(300, 2.0)));
  // 1.5 dB is raw 15; the driver keeps 16 (its step is 4).
  Status st = cam.configure(config(300, 1.5));
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message,
              HasSubstr("took gain raw 16 (1.6 dB) when asked for raw 15 (1.5 dB"));
  EXPECT_THAT(st.error().message, HasSubstr("step is 4"));
  EXPECT_THAT(st.error().message, HasSubstr("camera.gain_db"));

  // A driver whose exposure moves in 200 us steps from 100 us: 400 us becomes 500 us.
  fake().controlById(V4L2_CID_EXPOSURE_ABSOLUTE)->step = 2;
  st = cam.configure(config(400, 2.0));
  fake().controlById(V4L2_CID_EXPOSURE_ABSOLUTE)->step = 1;
  ASSERT_FALSE(st);
  EXPECT_THAT(
      st.error().message,
      HasSubstr("took exposure 500 us when asked for 400 us (its control's step is 200 us)"));
  EXPECT_THAT(st.error().message, HasSubstr("camera.exposure_us"));

  // Off the 100 us grid, or beyond the control's range: refused before it is set.
  st = cam.configure(config(250, 2.0));
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message, HasSubstr("steps of 100 us from 100 to 1000000 us"));
  st = cam.configure(config(1000, 30.0));
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message, HasSubstr("gain 30 dB is outside 0..25.5: check camera.gain_db"));
}
