// The calibration dialog: launches measured on a known cubic are refitted to
// that cubic, and saving writes it into the profile file (which then loads
// with the new coefficients) while keeping the old file as a backup.
#include <gtest/gtest.h>

#include <QCheckBox>
#include <QLabel>
#include <QMessageBox>
#include <QPushButton>
#include <QSignalSpy>
#include <QTimer>
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

// Issue 14, defect 6: launches between 27 and 60 kPa do not calibrate the
// profile's 10..150 kPa. The measured range is shaded, the dialog warns, and
// saving narrows the working range to it (offered, ticked) or is refused.
TEST(CalibrationDialogGui, ARefitIsNotSavedBeyondTheMeasuredPressures) {
  application();
  const std::string dir = freshDir("calibration-narrow");
  const std::string path = dir + "/rig.toml";
  std::ofstream(path) << readText(sourcePath("config/sim.toml"));
  auto profile = hw::loadRigProfile(path);
  ASSERT_TRUE(profile) << profile.error().message;
  const LaunchCalibration::Coefficients truth{0.2, 6.1, -4.4, 3.1};
  std::vector<MeasuredLaunch> launches;
  for (int k = 0; k < 12; ++k) {
    MeasuredLaunch m;
    m.shot_id = QString("shot-%1").arg(k);
    m.launcher = k % 2;
    m.pressure_kPa = 27.0 + 3.0 * k;  // 27 .. 60 kPa
    const double x = m.pressure_kPa / 100.0;
    m.speed_m_s = truth[0] + truth[1] * x + truth[2] * x * x + truth[3] * x * x * x;
    launches.push_back(m);
  }
  CalibrationDialog dialog(std::make_shared<const hw::RigProfile>(*profile),
                           QString::fromStdString(path));
  dialog.resize(1100, 620);
  dialog.show();
  dialog.setLaunches(launches);
  QTest::mouseClick(dialog.findChild<QPushButton*>("refit_button"), Qt::LeftButton);
  ASSERT_TRUE(dialog.result().has_value()) << dialog.statusText().toStdString();
  EXPECT_TRUE(dialog.extrapolates());
  EXPECT_TRUE(dialog.statusText().contains("extrapolated")) << dialog.statusText().toStdString();
  auto* narrow = dialog.findChild<QCheckBox*>("narrow_range");
  ASSERT_NE(narrow, nullptr);
  EXPECT_TRUE(narrow->isVisible());
  EXPECT_TRUE(narrow->isChecked());
  auto* save = dialog.findChild<QPushButton*>("save_calibration");
  EXPECT_TRUE(save->isEnabled());
  EXPECT_TRUE(screenshot(&dialog, "calibration_extrapolation"));
  // Untick the narrowing: saving is refused.
  QTest::mouseClick(narrow, Qt::LeftButton, {}, QPoint(8, narrow->height() / 2));
  EXPECT_FALSE(narrow->isChecked());
  EXPECT_FALSE(save->isEnabled());
  QTest::mouseClick(narrow, Qt::LeftButton, {}, QPoint(8, narrow->height() / 2));
  ASSERT_TRUE(save->isEnabled());
  // Save, and confirm in the question that follows.
  QTimer::singleShot(300, [] {
    auto* box = qobject_cast<QMessageBox*>(QApplication::activeModalWidget());
    if (box) QTest::mouseClick(box->button(QMessageBox::Yes), Qt::LeftButton);
  });
  QSignalSpy saved(&dialog, &CalibrationDialog::profileSaved);
  QTest::mouseClick(save, Qt::LeftButton);
  ASSERT_EQ(saved.count(), 1) << dialog.statusText().toStdString();
  auto reloaded = hw::loadRigProfile(path);
  ASSERT_TRUE(reloaded) << reloaded.error().message;
  EXPECT_DOUBLE_EQ(reloaded->calibration.min_kPa, 27.0);
  EXPECT_DOUBLE_EQ(reloaded->calibration.max_kPa, 60.0);
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(reloaded->calibration.coefficients[k], truth[k], 1e-6) << "c" << k;
}
