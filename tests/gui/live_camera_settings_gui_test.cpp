// Live's camera settings (issue 14): exposure, gain and frame rate are edited
// beside the image with real input (typing + Enter, the wheel after a click)
// and reach the camera while the rig is not armed; armed, neither typing nor
// the wheel changes anything, and a request that slips past the GUI is
// refused by the rig's control thread. The check is physical: the simulated
// camera's analogue gain multiplies the background's grey level by
// 10^(gain_dB / 20) (0.02 of full scale at 0 dB, config/sim.toml).
#include <gtest/gtest.h>

#include <QPushButton>
#include <QWheelEvent>
#include <algorithm>
#include <cmath>
#include <fstream>

#include "../hw/aravis_profile.hpp"
#include "app/gui/live_view.hpp"
#include "gui_test_support.hpp"
#include "gui_window_support.hpp"
#include "hw/camera_aravis.hpp"
#include "hw/camera_replay.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;

namespace {

constexpr double kBackgroundLevel = 0.02;  // vision::RenderSettings' default backdrop

// The median grey level of the camera's newest frame: the backdrop (the
// spheres cover a small part of the image).
double medianGrey(const CameraPtr& camera) {
  auto frame = camera->latestFrame();
  if (!frame || frame->image.empty()) return -1;
  std::vector<std::uint8_t> v(frame->image.begin<std::uint8_t>(), frame->image.end<std::uint8_t>());
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Waits for the live view's camera to run with `gain_db` and publish a frame.
bool waitForGain(MainWindow& w, double gain_db) {
  return QTest::qWaitFor(
      [&] {
        CameraPtr c = w.liveView()->camera();
        return c && std::abs(c->config().gain_db - gain_db) < 1e-9 && c->latestFrame();
      },
      15000);
}

}  // namespace

TEST(LiveCameraSettingsGui, AppliedWhenDisarmedLockedWhenArmed) {
  application();
  const std::string dir = freshDir("live-camera");
  MainWindow w(windowOptions(sourcePath("config/sim.toml"), dir + "/shots"));
  w.resize(1366, 768);
  activate(&w);
  ASSERT_TRUE(waitUntilRigRunning(w));
  LiveView* live = w.liveView();
  auto* gain = child<QDoubleSpinBox>(live, "live_gain_db");
  auto* exposure = child<QDoubleSpinBox>(live, "live_exposure_us");
  ASSERT_TRUE(waitForGain(w, 0.0));
  const double grey0 = medianGrey(live->camera());
  EXPECT_NEAR(grey0, kBackgroundLevel * 255, 1.0);

  // Not armed: a typed gain reaches the camera; the next frame is brighter by the gain.
  ASSERT_TRUE(gain->isEnabled());
  typeInto(gain, "12");
  ASSERT_TRUE(waitForGain(w, 12.0)) << w.messages().join("\n").toStdString();
  EXPECT_NEAR(medianGrey(live->camera()), kBackgroundLevel * 255 * std::pow(10.0, 12.0 / 20), 1.0);
  EXPECT_TRUE(live->cameraSettingsText().contains("gain 12.0 dB"))
      << live->cameraSettingsText().toStdString();
  // The wheel, once clicked into the field: exposure one step (1 us) up.
  const double exposure0 = live->camera()->config().exposure_us;
  QTest::mouseClick(exposure->findChild<QLineEdit*>(), Qt::LeftButton);
  ASSERT_TRUE(exposure->hasFocus());
  wheel(exposure, 1);
  ASSERT_TRUE(QTest::qWaitFor(
      [&] { return std::abs(live->camera()->config().exposure_us - (exposure0 + 1)) < 1e-9; },
      15000))
      << w.messages().join("\n").toStdString();

  // A frame rate whose period is shorter than the exposure is refused by the
  // profile, said in the message bar, and the field goes back to the camera's.
  auto* fps = child<QDoubleSpinBox>(live, "live_fps");
  const CameraPtr before = live->camera();
  typeInto(fps, "10000");  // 100 us period < 201 us exposure
  ASSERT_TRUE(QTest::qWaitFor(
      [&] { return w.messages().join("\n").contains("Camera settings not applied"); }, 5000));
  EXPECT_TRUE(w.messages().last().contains("exposure_us")) << w.messages().last().toStdString();
  EXPECT_DOUBLE_EQ(fps->value(), 1000.0);
  EXPECT_EQ(live->camera(), before);

  // Armed: locked. Typing and the wheel change neither the field nor the camera.
  QTest::mouseClick(child<QPushButton>(w.rigPanel(), "arm_button"), Qt::LeftButton);
  ASSERT_TRUE(QTest::qWaitFor([&] { return live->cameraControlsLocked(); }, 10000));
  const CameraPtr armed_camera = live->camera();
  EXPECT_FALSE(gain->isEnabled());
  EXPECT_TRUE(gain->toolTip().contains("armed")) << gain->toolTip().toStdString();
  typeInto(gain, "20");
  QTest::mouseClick(exposure->findChild<QLineEdit*>(), Qt::LeftButton);
  wheel(exposure, 5);
  wheel(gain, 5);
  QTest::qWait(800);  // past the 300 ms that gathers wheel notches
  EXPECT_DOUBLE_EQ(gain->value(), 12.0);
  EXPECT_DOUBLE_EQ(exposure->value(), exposure0 + 1);
  // Nor through the rig panel's burst settings (frame rate, exposure there too).
  auto* apply_burst = child<QPushButton>(w.rigPanel(), "apply_burst");
  EXPECT_FALSE(apply_burst->isEnabled());
  QTest::mouseClick(apply_burst, Qt::LeftButton);
  QTest::qWait(300);
  EXPECT_EQ(live->camera(), armed_camera) << "the rig was rebuilt while armed";
  EXPECT_DOUBLE_EQ(live->camera()->config().gain_db, 12.0);
  // A request that bypasses the locked controls is refused by the control thread.
  emit live->cameraSettingsRequested(1000, 100, 3);
  ASSERT_TRUE(QTest::qWaitFor(
      [&] { return w.messages().last().contains("Camera settings not applied: the rig is armed"); },
      5000));
  EXPECT_EQ(live->camera(), armed_camera);
  EXPECT_TRUE(w.rigPanel()->lastStatus().armed);
  EXPECT_TRUE(screenshot(&w, "live_camera_locked"));

  // Disarmed again: unlocked.
  QTest::mouseClick(child<QPushButton>(w.rigPanel(), "disarm_button"), Qt::LeftButton);
  ASSERT_TRUE(QTest::qWaitFor([&] { return !live->cameraControlsLocked(); }, 10000));
  EXPECT_TRUE(gain->isEnabled());
}

// Per setting, on a real camera driver (Aravis' in-process fake camera,
// "Fake_1", the rest of the rig simulated): what is typed in Live is what the
// device then holds, read back from the device's own features; a value the
// profile allows but this camera refuses (the fake exposes at least 10 us) is
// named in the message bar, and the rig runs again with the settings it had
// instead of being left down.
TEST(LiveCameraSettingsGui, AnAravisCameraTakesEachSettingOrKeepsTheOldOnes) {
  application();
  const std::string dir = freshDir("live-aravis");
  const std::string profile = dir + "/aravis.toml";
  {
    std::ofstream out(profile);
    out << hw::testing::aravisProfileText(hw::testing::aravisCameraLines("Fake_1"));
  }
  MainWindow w(windowOptions(profile, dir + "/shots"));
  w.resize(1366, 768);
  activate(&w);
  ASSERT_TRUE(waitUntilRigRunning(w)) << w.messages().join("\n").toStdString();
  LiveView* live = w.liveView();
  auto* exposure = child<QDoubleSpinBox>(live, "live_exposure_us");
  auto* fps = child<QDoubleSpinBox>(live, "live_fps");
  // The device's own value of a feature, "" when the camera is not an open Aravis camera.
  const auto feature = [&](const char* name) {
    auto aravis = std::dynamic_pointer_cast<hw::CameraAravis>(live->camera());
    if (!aravis) return std::string();
    auto value = aravis->feature(name);
    return value ? *value : std::string();
  };
  const auto holds = [&](const char* name, const std::string& value) {
    return QTest::qWaitFor(
        [&] { return feature(name) == value && live->camera()->latestFrame() != nullptr; }, 15000);
  };
  ASSERT_TRUE(holds("ExposureTimeAbs", "1000")) << feature("ExposureTimeAbs");
  ASSERT_TRUE(exposure->isEnabled());

  // Exposure, frame rate, gain: each typed value is the device's afterwards.
  typeInto(exposure, "2500");
  EXPECT_TRUE(holds("ExposureTimeAbs", "2500")) << feature("ExposureTimeAbs") << "\n"
                                                << w.messages().join("\n").toStdString();
  typeInto(fps, "50");
  EXPECT_TRUE(holds("AcquisitionFrameRate", "50")) << feature("AcquisitionFrameRate") << "\n"
                                                   << w.messages().join("\n").toStdString();
  auto* gain = child<QDoubleSpinBox>(live, "live_gain_db");
  ASSERT_TRUE(gain->isEnabled()) << gain->toolTip().toStdString();
  typeInto(gain, "3");
  // The fake's gain is an integer register (GainRaw), which Aravis sets in dB.
  EXPECT_TRUE(holds("GainRaw", "3")) << feature("GainRaw") << "\n"
                                     << w.messages().join("\n").toStdString();
  EXPECT_TRUE(live->cameraSettingsText().contains("exposure 2500 us"))
      << live->cameraSettingsText().toStdString();

  // 5 us: the profile allows it, the fake does not. Named, and undone.
  typeInto(exposure, "5");
  ASSERT_TRUE(QTest::qWaitFor(
      [&] { return w.messages().join("\n").contains("Camera settings not applied"); }, 15000))
      << w.messages().join("\n").toStdString();
  const QString said = w.messages().join("\n");
  EXPECT_TRUE(said.contains("exposure 5 us is outside the camera's 10..")) << said.toStdString();
  EXPECT_TRUE(said.contains("Back to the settings the rig had")) << said.toStdString();
  EXPECT_TRUE(holds("ExposureTimeAbs", "2500")) << feature("ExposureTimeAbs");
  EXPECT_EQ(feature("AcquisitionFrameRate"), "50");
  EXPECT_EQ(feature("GainRaw"), "3");
  EXPECT_TRUE(QTest::qWaitFor([&] { return exposure->value() == 2500.0; }, 5000))
      << exposure->value();
  EXPECT_DOUBLE_EQ(live->camera()->config().exposure_us, 2500.0);
  EXPECT_EQ(live->camera()->state(), hw::DeviceState::Running);
  EXPECT_TRUE(screenshot(&w, "live_setting_refused"));
}

// A replayed recording cannot change its exposure, gain or frame rate: the
// controls are off and say why.
TEST(LiveCameraSettingsGui, AReplayedRecordingsSettingsAreFixed) {
  application();
  vision::Burst burst;
  burst.fps = 500;
  for (int k = 0; k < 3; ++k) {
    vision::Frame f;
    f.id = k;
    f.image = cv::Mat(48, 64, CV_8U, cv::Scalar(10));
    burst.frames.push_back(f);
  }
  LiveView view;
  view.setCamera(std::make_shared<hw::CameraReplay>(burst, "recording.cine", false));
  for (const char* name : {"live_exposure_us", "live_gain_db", "live_fps"}) {
    auto* box = child<QDoubleSpinBox>(&view, name);
    EXPECT_FALSE(box->isEnabled()) << name;
    EXPECT_TRUE(box->toolTip().contains("replayed recording")) << box->toolTip().toStdString();
  }
}
