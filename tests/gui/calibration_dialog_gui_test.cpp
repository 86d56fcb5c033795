// The calibration dialog: launches measured on a known cubic are refitted to
// that cubic, and saving writes it into the profile file (which then loads
// with the new coefficients) while keeping the old file as a backup.
#include <gtest/gtest.h>

#include <QLabel>
#include <QPushButton>
#include <QSignalSpy>
#include <fstream>
#include <sstream>

#include "app/gui/calibration_dialog.hpp"
#include "gui_test_support.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;

namespace {

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Launches whose speeds lie exactly on `c` at pressures across the range.
std::vector<MeasuredLaunch> launchesOn(const LaunchCalibration::Coefficients& c) {
  std::vector<MeasuredLaunch> out;
  for (int k = 0; k < 12; ++k) {
    MeasuredLaunch m;
    m.shot_id = QString("shot-%1").arg(k);
    m.launcher = k % 2;
    m.pressure_kPa = 15.0 + 10.0 * k;
    const double x = m.pressure_kPa / 100.0;
    m.speed_m_s = c[0] + c[1] * x + c[2] * x * x + c[3] * x * x * x;
    out.push_back(m);
  }
  return out;
}

}  // namespace

TEST(CalibrationDialogGui, RefitsMeasuredLaunchesAndSavesThemIntoTheProfile) {
  application();
  const std::string dir = freshDir("calibration");
  const std::string path = dir + "/rig.toml";
  const std::string original = readText(sourcePath("config/sim.toml"));
  std::ofstream(path) << original;
  auto profile = hw::loadRigProfile(path);
  ASSERT_TRUE(profile) << profile.error().message;

  const LaunchCalibration::Coefficients truth{0.2, 6.1, -4.4, 3.1};  // not the profile's cubic
  CalibrationDialog dialog(std::make_shared<const hw::RigProfile>(*profile),
                           QString::fromStdString(path));
  dialog.show();
  dialog.setLaunches(launchesOn(truth));
  EXPECT_FALSE(dialog.findChild<QPushButton*>("save_calibration")->isEnabled());
  QTest::mouseClick(dialog.findChild<QPushButton*>("refit_button"), Qt::LeftButton);
  ASSERT_TRUE(dialog.result().has_value()) << dialog.statusText().toStdString();
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(dialog.result()->calibration.coefficients()[k], truth[k], 1e-6) << "c" << k;
  EXPECT_TRUE(dialog.findChild<QPushButton*>("save_calibration")->isEnabled());
  EXPECT_TRUE(screenshot(&dialog, "calibration"));

  QSignalSpy saved(&dialog, &CalibrationDialog::profileSaved);
  Status s = dialog.saveToProfile(/*ask=*/false);
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(saved.count(), 1);
  auto reloaded = hw::loadRigProfile(path);
  ASSERT_TRUE(reloaded) << reloaded.error().message;
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(reloaded->calibration.coefficients[k], truth[k], 1e-6) << "c" << k;
  // Everything else in the profile is as it was; the old file is the backup.
  EXPECT_EQ(reloaded->burst.post_trigger_frames, profile->burst.post_trigger_frames);
  EXPECT_EQ(readText(dialog.backupPath().toStdString()), original);
}

TEST(CalibrationDialogGui, TooFewLaunchesSayWhyAndSaveNothing) {
  application();
  auto profile = hw::defaultRigProfile();
  ASSERT_TRUE(profile);
  CalibrationDialog dialog(std::make_shared<const hw::RigProfile>(*profile), QString());
  auto launches = launchesOn({0.143, 6.6, -5.0, 3.38});
  launches.resize(3);
  dialog.setLaunches(launches);
  EXPECT_FALSE(dialog.refit());
  EXPECT_TRUE(dialog.statusText().contains("Cannot refit")) << dialog.statusText().toStdString();
  EXPECT_FALSE(dialog.saveToProfile(false));
}
