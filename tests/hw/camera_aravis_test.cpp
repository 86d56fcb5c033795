// CameraAravis without a camera: its profile settings (parsed, defaulted,
// refused with file, line and field) and the unwrapping of 16-bit GigE
// Vision frame ids. Streaming is tested against Aravis' own fake cameras in
// camera_aravis_peer_test.cpp.
#include "hw/camera_aravis.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "aravis_profile.hpp"
#include "hw/rig.hpp"
#include "hw/rig_profile.hpp"

using namespace collide;
using namespace collide::hw;
using namespace collide::hw::testing;
using ::testing::HasSubstr;

namespace {

// 1-based line of the first line of `text` that starts with `start`.
int lineStarting(const std::string& text, const std::string& start) {
  const auto lines = splitLines(text);
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (lines[i].rfind(start, 0) == 0) return static_cast<int>(i) + 1;
  throw std::runtime_error("no line starts with " + start);
}

Result<CameraAravisSettings> settingsOf(const std::string& text) {
  auto profile = parseRigProfile(text, "lab.toml");
  if (!profile) return profile.error();
  SettingsReader r = profile->camera.backendSettings();
  return CameraAravisSettings::read(r);
}

std::string errorOf(const std::string& text) {
  auto profile = parseRigProfile(text, "lab.toml");
  if (!profile) return profile.error().message;
  auto rig = makeRig(*profile);
  return rig ? std::string("(accepted)") : rig.error().message;
}

}  // namespace

TEST(CameraAravisSettings, DefaultsWhenOnlyTheRoleKeysAreGiven) {
  const auto s = settingsOf(aravisProfileText(aravisCameraLines("192.168.10.20")));
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(s->trigger, AravisTrigger::FreeRun);
  EXPECT_EQ(s->trigger_line, "Line0");
  EXPECT_EQ(s->trigger_activation, "RisingEdge");
  EXPECT_EQ(s->packet_size_bytes, 0);
  EXPECT_EQ(s->packet_delay_ns, 0);
  EXPECT_EQ(s->buffers, 64);
  EXPECT_EQ(s->socket_buffer_bytes, 0);
  EXPECT_TRUE(s->packet_resend);
  EXPECT_LT(s->timestamp_latency_us, 0.0);  // the exposure time
  EXPECT_TRUE(s->features.empty());
}

TEST(CameraAravisSettings, ReadsEverySettingAndTheFeaturesInFileOrder) {
  const std::string text = aravisProfileText(
      aravisCameraLines(
          "192.168.10.20",
          {"trigger = \"line\"", "trigger_line = \"Line2\"", "trigger_activation = \"FallingEdge\"",
           "packet_size_bytes = 8192", "packet_delay_ns = 2500", "buffers = 200",
           "socket_buffer_bytes = 16777216", "packet_resend = false", "packet_timeout_ms = 5",
           "frame_retention_ms = 200", "timestamp_latency_us = 350", "stall_timeout_ms = 1500"}),
      {"Zeta = 1", "BalanceWhiteAuto = \"Off\"", "ReverseX = true", "Gamma = 0.5"});
  const auto s = settingsOf(text);
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(s->trigger, AravisTrigger::Line);
  EXPECT_EQ(s->trigger_line, "Line2");
  EXPECT_EQ(s->trigger_activation, "FallingEdge");
  EXPECT_EQ(s->packet_size_bytes, 8192);
  EXPECT_EQ(s->packet_delay_ns, 2500);
  EXPECT_EQ(s->buffers, 200);
  EXPECT_EQ(s->socket_buffer_bytes, 16777216);
  EXPECT_FALSE(s->packet_resend);
  EXPECT_DOUBLE_EQ(s->packet_timeout_ms, 5.0);
  EXPECT_DOUBLE_EQ(s->frame_retention_ms, 200.0);
  EXPECT_DOUBLE_EQ(s->timestamp_latency_us, 350.0);
  EXPECT_DOUBLE_EQ(s->stall_timeout_ms, 1500.0);

  // File order, not alphabetical: a selector must be set before what it selects.
  ASSERT_EQ(s->features.size(), 4u);
  EXPECT_EQ(s->features[0].name, "Zeta");
  EXPECT_EQ(std::get<std::int64_t>(s->features[0].value.value), 1);
  EXPECT_EQ(s->features[1].name, "BalanceWhiteAuto");
  EXPECT_EQ(std::get<std::string>(s->features[1].value.value), "Off");
  EXPECT_EQ(s->features[2].name, "ReverseX");
  EXPECT_TRUE(std::get<bool>(s->features[2].value.value));
  EXPECT_EQ(s->features[3].name, "Gamma");
  EXPECT_DOUBLE_EQ(std::get<double>(s->features[3].value.value), 0.5);
  EXPECT_EQ(s->features[0].where,
            "lab.toml:" + std::to_string(lineStarting(text, "Zeta")) + ": camera.features.Zeta");
}

TEST(CameraAravisSettings, AProfileWithAnAravisCameraBuildsARig) {
  auto profile = parseRigProfile(aravisProfileText(aravisCameraLines("192.168.10.20")), "lab.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  EXPECT_EQ(profile->camera.backend, "aravis");
  auto rig = makeRig(*profile);
  ASSERT_TRUE(rig) << rig.error().message;
  ASSERT_NE(dynamic_cast<CameraAravis*>(rig->camera.get()), nullptr);
  EXPECT_EQ(rig->camera->info().backend, "aravis");
  EXPECT_EQ(rig->camera->info().device, "192.168.10.20");
  EXPECT_EQ(rig->camera->state(), DeviceState::Closed);  // nothing opened yet
}

TEST(CameraAravisSettings, RefusesBadValuesWithFileLineAndField) {
  auto with = [](const std::vector<std::string>& extra) {
    return aravisProfileText(aravisCameraLines("192.168.10.20", extra));
  };
  std::string text = with({"trigger = \"sometimes\""});
  EXPECT_THAT(errorOf(text), HasSubstr("lab.toml:" + std::to_string(lineStarting(text, "trigger")) +
                                       ": camera.trigger = \"sometimes\""));
  EXPECT_THAT(errorOf(with({"packet_size_bytes = 100"})),
              HasSubstr("camera.packet_size_bytes = 100: must be 0 (negotiate) or at least 576"));
  EXPECT_THAT(errorOf(with({"buffers = 1"})), HasSubstr("camera.buffers = 1"));
  EXPECT_THAT(errorOf(with({"packet_sise_bytes = 1500"})),
              HasSubstr("camera.packet_sise_bytes: unknown setting for the aravis camera backend"));
  // The sim backend's keys are not the aravis backend's.
  EXPECT_THAT(errorOf(with({"noise_grey = 1.0"})),
              HasSubstr("camera.noise_grey: unknown setting for the aravis camera backend"));
  text = aravisProfileText(aravisCameraLines("192.168.10.20"), {"Roi = [1, 2]"});
  EXPECT_THAT(errorOf(text), HasSubstr("lab.toml:" + std::to_string(lineStarting(text, "Roi")) +
                                       ": camera.features.Roi = [1, 2]: a GenICam feature takes "
                                       "one value"));
  // A camera must be named: the default device (the backend's name) opens nothing.
  auto lines = aravisCameraLines("x");
  lines.erase(lines.begin() + 1);
  EXPECT_THAT(errorOf(aravisProfileText(lines)), HasSubstr("camera.device: name the camera"));
}

TEST(CameraAravisFrameIds, SixteenBitIdsWrapFrom65535ToOne) {
  EXPECT_EQ(CameraAravis::unwrapFrameId(10, 100, 11), 101u);
  EXPECT_EQ(CameraAravis::unwrapFrameId(10, 100, 14), 104u);  // 3 lost
  EXPECT_EQ(CameraAravis::unwrapFrameId(65535, 100, 1), 101u);
  EXPECT_EQ(CameraAravis::unwrapFrameId(65534, 100, 2), 103u);  // 65535 and 1 lost
  EXPECT_EQ(CameraAravis::unwrapFrameId(65535, 100, 0), 101u);  // a camera that does send 0
  EXPECT_EQ(CameraAravis::unwrapFrameId(60000, 100, 500), 100u + 5535 + 500);
}

TEST(CameraAravisFrameIds, DuplicatesAndLateFramesAreNotNewer) {
  EXPECT_FALSE(CameraAravis::unwrapFrameId(10, 100, 10));
  EXPECT_FALSE(CameraAravis::unwrapFrameId(10, 100, 9));
  EXPECT_FALSE(CameraAravis::unwrapFrameId(40000, 100, 39000));
}

TEST(CameraAravisFrameIds, SixtyFourBitIdsNeverWrap) {
  EXPECT_EQ(CameraAravis::unwrapFrameId(70000, 5, 70001), 6u);
  EXPECT_FALSE(CameraAravis::unwrapFrameId(1ULL << 40, 5, 3));
}
