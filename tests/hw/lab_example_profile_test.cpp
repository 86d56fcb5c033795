// config/lab-example.toml, the complete real rig (GigE camera through
// Aravis, gpiod valves, Modbus RTU regulator): it parses, every backend
// accepts its settings (the devices are built, not opened: there is no such
// hardware here), and every field is explained.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "hw/camera_aravis.hpp"
#include "hw/rig.hpp"
#include "hw/rig_profile.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;

namespace {

const std::string kPath = std::string(COLLIDE_SOURCE_DIR) + "/config/lab-example.toml";

}  // namespace

TEST(LabExampleProfile, ParsesAndBuildsTheAravisCameraGpiodValvesAndModbusRegulator) {
  const auto p = loadRigProfile(kPath);
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_EQ(p->name, "lab-example");
  EXPECT_EQ(p->camera.backend, "aravis");
  EXPECT_EQ(p->camera.device, "192.168.10.20");
  EXPECT_EQ(p->valves.backend, "gpiod");
  EXPECT_EQ(p->regulator.backend, "modbus");
  EXPECT_EQ(p->camera_config.roi_y, 256);
  EXPECT_EQ(p->camera_config.width, 1024);
  EXPECT_EQ(p->camera_config.height, 512);
  EXPECT_DOUBLE_EQ(p->camera_config.fps, 2000.0);
  EXPECT_DOUBLE_EQ(p->camera_config.gain_db, 6.0);

  const auto rig = makeRig(*p);
  ASSERT_TRUE(rig) << rig.error().message;
  EXPECT_NE(dynamic_cast<CameraAravis*>(rig->camera.get()), nullptr);
  EXPECT_EQ(rig->valves->info().backend, "gpiod");
  EXPECT_EQ(rig->valves->info().valves, 2);
  EXPECT_EQ(rig->regulator->info().backend, "modbus");

  SettingsReader r = p->camera.backendSettings();
  const auto cam = CameraAravisSettings::read(r);
  ASSERT_TRUE(cam) << cam.error().message;
  EXPECT_EQ(cam->trigger, AravisTrigger::FreeRun);
  EXPECT_EQ(cam->trigger_line, "Line1");
  EXPECT_EQ(cam->packet_size_bytes, 9000);
  EXPECT_EQ(cam->buffers, 256);
  EXPECT_DOUBLE_EQ(cam->timestamp_latency_us, 250.0);
  ASSERT_EQ(cam->features.size(), 4u);
  EXPECT_EQ(cam->features[0].name, "ExposureAuto");  // file order
  EXPECT_EQ(cam->features[3].name, "ReverseX");
}

TEST(LabExampleProfile, EveryFieldIsExplained) {
  const auto lines = splitLines(readFile(kPath));
  int fields = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    if (l.empty() || l[0] == '#' || l[0] == '[' || l[0] == ' ' ||
        l.find('=') == std::string::npos)
      continue;
    ++fields;
    EXPECT_NE(l.find('#'), std::string::npos) << "line " << i + 1 << " has no comment: " << l;
  }
  EXPECT_GT(fields, 70);
}
