// config/lab-v4l2-gpiod.toml, the example lab profile with a V4L2 camera, GPIO
// valves and a Modbus regulator: it parses, builds its devices (without opening them: there is
// no such hardware here), and documents every field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "hw/camera_v4l2.hpp"
#include "hw/rig.hpp"
#include "hw/rig_profile.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;

namespace {

const std::string kPath = std::string(COLLIDE_SOURCE_DIR) + "/config/lab-v4l2-gpiod.toml";

}  // namespace

TEST(LabProfile, ParsesWithTheV4l2CameraAndGpiodValves) {
  const auto p = loadRigProfile(kPath);
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_EQ(p->name, "lab-v4l2-gpiod");
  EXPECT_EQ(p->camera.backend, "v4l2");
  EXPECT_EQ(p->camera.device, "/dev/video0");
  EXPECT_EQ(p->valves.backend, "gpiod");
  EXPECT_EQ(p->valves.device, "gpiochip0");
  EXPECT_EQ(p->regulator.backend, "modbus");
  EXPECT_EQ(p->camera_config.width, 640);
  EXPECT_EQ(p->camera_config.format, collide::vision::PixelFormat::Mono8);
  EXPECT_DOUBLE_EQ(p->camera_config.fps, 60.0);
  EXPECT_EQ(p->valve_config.max_pulse_us, 50000);

  // The backends accept their settings (the devices are only built, not opened).
  const auto rig = makeRig(*p);
  ASSERT_TRUE(rig) << rig.error().message;
  EXPECT_EQ(rig->camera->info().backend, "v4l2");
  EXPECT_EQ(rig->valves->info().backend, "gpiod");
  EXPECT_EQ(rig->valves->info().valves, 2);
  EXPECT_EQ(rig->valves->info().device, "gpiochip0");
  EXPECT_EQ(rig->regulator->info().backend, "modbus");

  SettingsReader r = p->camera.backendSettings();
  const auto cam = CameraV4l2Settings::read(r, p->camera_config);
  ASSERT_TRUE(cam) << cam.error().message;
  EXPECT_EQ(fourccText(cam->pixel_format), "GREY");
  EXPECT_EQ(cam->frame_width, 640);
  EXPECT_EQ(cam->frame_height, 480);
  EXPECT_TRUE(cam->exposure_control);
  ASSERT_EQ(cam->controls.size(), 1u);
  EXPECT_EQ(cam->controls[0].first, "power_line_frequency");
}

TEST(LabProfile, EveryFieldIsCommented) {
  const auto lines = splitLines(readFile(kPath));
  int fields = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    if (l.empty() || l[0] == '#' || l[0] == '[' || l.find('=') == std::string::npos) continue;
    ++fields;
    EXPECT_NE(l.find('#'), std::string::npos) << "line " << i + 1 << " has no comment: " << l;
  }
  EXPECT_GT(fields, 40);
}
