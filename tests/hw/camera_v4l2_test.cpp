// CameraV4l2 on the host: pixel conversion, names, profile settings and the
// errors for a missing or wrong device. Streaming from a real driver (vivid)
// is tested in the VM (tests/vm/v4l2_vm_test.cpp).
#include "hw/camera_v4l2.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>

#include "hw/rig.hpp"
#include "hw/rig_profile.hpp"
#include "hw/v4l2_device.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;
using ::testing::HasSubstr;

namespace {

std::string v4l2Profile() {
  std::string t = withKey(simProfileText(), "camera", "backend", "\"v4l2\"");
  for (const char* key : {"sensor_px", "realtime", "noise_grey", "drop_every", "stop_after_frames"})
    t = withoutKey(t, "camera", key);
  t = withKey(t, "camera", "device", "\"/dev/video0\"");
  t = withKey(t, "camera", "fps", "30.0");
  return withKey(t, "camera", "exposure_control", "false");
}

std::string rigError(const std::string& text) {
  auto p = parseRigProfile(text, "lab.toml");
  if (!p) return p.error().message;
  auto rig = makeRig(*p);
  return rig ? std::string("(built)") : rig.error().message;
}

}  // namespace

TEST(V4l2ToMono, GreyIsCroppedAndPaddingSkipped) {
  // 6x3 GREY with 8 bytes per line (2 bytes of padding per row).
  std::vector<std::uint8_t> buf(8 * 3, 0xEE);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 6; ++x)
      buf[static_cast<std::size_t>(y * 8 + x)] = static_cast<std::uint8_t>(10 * y + x);
  auto m = v4l2ToMono(V4L2_PIX_FMT_GREY, buf.data(), buf.size(), 6, 3, 8, cv::Rect(1, 1, 4, 2));
  ASSERT_TRUE(m) << m.error().message;
  ASSERT_EQ(m->type(), CV_8UC1);
  ASSERT_EQ(m->cols, 4);
  ASSERT_EQ(m->rows, 2);
  EXPECT_EQ(m->at<std::uint8_t>(0, 0), 11);
  EXPECT_EQ(m->at<std::uint8_t>(1, 3), 24);
  // The copy owns its pixels.
  buf.assign(buf.size(), 0);
  EXPECT_EQ(m->at<std::uint8_t>(1, 3), 24);
}

TEST(V4l2ToMono, YuyvKeepsTheLuma) {
  // 4x1: Y0 U Y1 V Y2 U Y3 V
  const std::vector<std::uint8_t> buf{10, 200, 20, 201, 30, 202, 40, 203};
  auto m = v4l2ToMono(V4L2_PIX_FMT_YUYV, buf.data(), buf.size(), 4, 1, 8, cv::Rect(0, 0, 4, 1));
  ASSERT_TRUE(m) << m.error().message;
  ASSERT_EQ(m->type(), CV_8UC1);
  EXPECT_EQ(m->at<std::uint8_t>(0, 0), 10);
  EXPECT_EQ(m->at<std::uint8_t>(0, 1), 20);
  EXPECT_EQ(m->at<std::uint8_t>(0, 3), 40);
}

TEST(V4l2ToMono, Y16IsLittleEndianAndY12KeepsTwelveBits) {
  const std::vector<std::uint8_t> buf{0x34, 0x12, 0xff, 0xff};
  auto y16 = v4l2ToMono(V4L2_PIX_FMT_Y16, buf.data(), buf.size(), 2, 1, 4, cv::Rect(0, 0, 2, 1));
  ASSERT_TRUE(y16);
  ASSERT_EQ(y16->type(), CV_16UC1);
  EXPECT_EQ(y16->at<std::uint16_t>(0, 0), 0x1234);
  EXPECT_EQ(y16->at<std::uint16_t>(0, 1), 0xffff);
  auto y12 = v4l2ToMono(V4L2_PIX_FMT_Y12, buf.data(), buf.size(), 2, 1, 4, cv::Rect(0, 0, 2, 1));
  ASSERT_TRUE(y12);
  EXPECT_EQ(y12->at<std::uint16_t>(0, 0), 0x0234);
  EXPECT_EQ(y12->at<std::uint16_t>(0, 1), 0x0fff);
}

TEST(V4l2ToMono, RefusesShortBuffersOtherFormatsAndBadRegions) {
  const std::vector<std::uint8_t> buf(10);
  EXPECT_THAT(v4l2ToMono(V4L2_PIX_FMT_GREY, buf.data(), buf.size(), 4, 4, 4, cv::Rect(0, 0, 4, 4))
                  .error()
                  .message,
              HasSubstr("short frame"));
  EXPECT_THAT(v4l2ToMono(V4L2_PIX_FMT_MJPEG, buf.data(), buf.size(), 2, 2, 2, cv::Rect(0, 0, 2, 2))
                  .error()
                  .message,
              HasSubstr("MJPG cannot be read as grey"));
  EXPECT_THAT(v4l2ToMono(V4L2_PIX_FMT_GREY, buf.data(), buf.size(), 2, 2, 2, cv::Rect(1, 0, 2, 2))
                  .error()
                  .message,
              HasSubstr("outside the 2x2 frame"));
}

TEST(V4l2Names, FourccsAndControlKeys) {
  EXPECT_EQ(fourccText(V4L2_PIX_FMT_GREY), "GREY");
  EXPECT_EQ(fourccText(V4L2_PIX_FMT_Y16), "Y16");
  EXPECT_EQ(fourccFromText("Y16"), static_cast<std::uint32_t>(V4L2_PIX_FMT_Y16));
  EXPECT_EQ(fourccFromText("YUYV"), static_cast<std::uint32_t>(V4L2_PIX_FMT_YUYV));
  EXPECT_EQ(fourccFromText("TOOLONG"), 0u);
  EXPECT_EQ(v4l2ControlKey("Exposure Time, Absolute"), "exposure_time_absolute");
  EXPECT_EQ(v4l2ControlKey("Percentage of Dropped Buffers"), "percentage_of_dropped_buffers");
  EXPECT_EQ(v4l2ControlKey("Gain"), "gain");
}

TEST(CameraV4l2, MissingDeviceSaysWhereToLook) {
  CameraV4l2Settings s;
  s.path = "/dev/video-collide-missing";
  s.frame_width = 64;
  s.frame_height = 48;
  CameraV4l2 cam(s);
  const auto r = cam.open();
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message, HasSubstr("no camera at /dev/video-collide-missing"));
  EXPECT_THAT(r.error().message, HasSubstr("v4l2-ctl --list-devices"));
  EXPECT_EQ(cam.state(), DeviceState::Closed);
}

TEST(CameraV4l2, ANonV4l2NodeIsRefused) {
  CameraV4l2Settings s;
  s.path = "/dev/null";
  CameraV4l2 cam(s);
  const auto r = cam.open();
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message, HasSubstr("/dev/null is not a V4L2 video device"));
}

TEST(CameraV4l2, ProfileSettingsAreReadAndChecked) {
  const std::string base = v4l2Profile();
  auto p = parseRigProfile(withKey(base, "camera", "frame_px", "[800, 600]"), "lab.toml");
  ASSERT_TRUE(p) << p.error().message;
  auto rig = makeRig(*p);
  ASSERT_TRUE(rig) << rig.error().message;
  EXPECT_EQ(rig->camera->info().backend, "v4l2");
  EXPECT_EQ(rig->camera->info().device, "/dev/video0");

  EXPECT_THAT(rigError(withKey(base, "camera", "pixel_format", "\"MJPG\"")),
              HasSubstr("camera.pixel_format = \"MJPG\": must be one of"));
  EXPECT_THAT(rigError(withKey(base, "camera", "pixel_format", "\"Y16\"")),
              HasSubstr("Y16 gives Mono16 frames but camera.format is Mono8"));
  EXPECT_THAT(rigError(withKey(base, "camera", "buffers", "1")), HasSubstr("camera.buffers"));
  EXPECT_THAT(rigError(withKey(base, "camera", "frame_px", "[640.5, 480]")),
              HasSubstr("whole numbers"));
  EXPECT_THAT(rigError(withKey(base, "camera", "colour", "1")), HasSubstr("camera.colour"));
  EXPECT_THAT(rigError(withoutKey(base, "camera", "device")), HasSubstr("camera.device"));
  const std::string ctl = base + "\n[camera.controls]\nbrightness = \"high\"\n";
  EXPECT_THAT(rigError(ctl), HasSubstr("camera.controls.brightness"));
  const std::string ok = base + "\n[camera.controls]\nbrightness = 128\npower_line_frequency = 1\n";
  EXPECT_EQ(rigError(ok), "(built)");
}
