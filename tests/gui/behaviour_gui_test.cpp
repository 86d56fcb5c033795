// How the window behaves around the happy path: device errors become messages
// that say what to do (and the window keeps working), a campaign can be
// cancelled, a broken profile is refused with its file and field, and the
// window's state persists between runs.
#include <gtest/gtest.h>

#include <QDoubleSpinBox>
#include <QLabel>
#include <QPushButton>
#include <QSettings>
#include <QSignalSpy>
#include <QSpinBox>
#include <QTabWidget>
#include <fstream>

#include "app/gui/campaign_view.hpp"
#include "app/gui/main_window.hpp"
#include "app/gui/rig_panel.hpp"
#include "app/gui/shot_browser.hpp"
#include "app/profile_edit.hpp"
#include "gui_test_support.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;

namespace {

// config/sim.toml with one value changed, written into `dir`.
std::string simProfileWith(const std::string& dir, const std::string& section,
                           const std::string& key, const std::string& value) {
  std::ifstream in(sourcePath("config/sim.toml"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto edited = app::setProfileValue(text, section, key, value);
  if (!edited) throw std::runtime_error(edited.error().message);
  const std::string path = dir + "/rig.toml";
  std::ofstream(path) << *edited;
  return path;
}

MainWindowOptions options(const std::string& profile, const std::string& shots,
                          bool settings = false) {
  MainWindowOptions o;
  o.rig_profile = QString::fromStdString(profile);
  o.shots_dir = QString::fromStdString(shots);
  o.restore_settings = settings;
  return o;
}

}  // namespace

TEST(BehaviourGui, ARegulatorThatFailsIsAMessageNotACrash) {
  application();
  const std::string dir = freshDir("regulator-error");
  // The simulated regulator's link fails after the first setpoint.
  MainWindow w(options(simProfileWith(dir, "regulator", "fault", "\"error\""), dir + "/shots"));
  w.show();
  ASSERT_TRUE(QTest::qWaitFor([&] { return w.profile() != nullptr; }, 20000));
  ASSERT_TRUE(
      QTest::qWaitFor([&] { return w.rigPanel()->lastStatus().state[0] == "running"; }, 20000));
  auto* arm = w.rigPanel()->findChild<QPushButton*>("arm_button");
  QTest::mouseClick(arm, Qt::LeftButton);  // first setpoint: accepted
  QTest::qWait(200);
  QTest::mouseClick(arm, Qt::LeftButton);  // the link is gone now
  ASSERT_TRUE(QTest::qWaitFor([&] { return !w.messages().isEmpty(); }, 10000));
  const QString message = w.messages().last();
  EXPECT_TRUE(message.contains("regulator")) << message.toStdString();
  // Fire stays disabled and the window still answers.
  EXPECT_FALSE(w.rigPanel()->findChild<QPushButton*>("fire_button")->isEnabled());
  w.tabs()->setCurrentIndex(2);
  QApplication::processEvents();
  EXPECT_EQ(w.tabs()->currentIndex(), 2);
}

TEST(BehaviourGui, ABrokenProfileIsRefusedNamingTheFileAndField) {
  application();
  const std::string dir = freshDir("bad-profile");
  MainWindow w(options(simProfileWith(dir, "camera", "fps", "-5"), dir + "/shots"));
  w.show();
  ASSERT_TRUE(QTest::qWaitFor([&] { return !w.messages().isEmpty(); }, 20000));
  const std::string message = w.messages().last().toStdString();
  EXPECT_NE(message.find("rig.toml"), std::string::npos) << message;
  EXPECT_NE(message.find("fps"), std::string::npos) << message;
  EXPECT_EQ(w.profile(), nullptr);
}

TEST(BehaviourGui, ACampaignCanBeCancelled) {
  application();
  const std::string dir = freshDir("cancel");
  MainWindow w(options(sourcePath("config/sim.toml"), dir));
  w.show();
  ASSERT_TRUE(
      QTest::qWaitFor([&] { return w.rigPanel()->lastStatus().state[2] == "running"; }, 20000));
  CampaignView* view = w.campaignView();
  view->findChild<QSpinBox*>("campaign_shots")->setValue(40);
  QSignalSpy progress(w.rigWorker(), &RigWorker::campaignProgress);
  QSignalSpy finished(w.rigWorker(), &RigWorker::campaignFinished);
  QTest::mouseClick(view->findChild<QPushButton*>("run_campaign"), Qt::LeftButton);
  ASSERT_TRUE(QTest::qWaitFor([&] { return progress.count() >= 1; }, 60000));
  QTest::mouseClick(view->findChild<QPushButton*>("cancel_campaign"), Qt::LeftButton);
  ASSERT_TRUE(QTest::qWaitFor([&] { return finished.count() == 1; }, 60000));
  EXPECT_TRUE(finished.at(0).at(1).toBool()) << "reported as cancelled";
  EXPECT_LT(progress.count(), 40);
  // What was fired before the cancel is saved and listed.
  ASSERT_TRUE(QTest::qWaitFor(
      [&] { return w.shotBrowser()->rows().size() == static_cast<std::size_t>(progress.count()); },
      10000));
  // The rig is back and idle.
  ASSERT_TRUE(QTest::qWaitFor(
      [&] {
        return !w.rigPanel()->lastStatus().busy && w.rigPanel()->lastStatus().state[2] == "running";
      },
      20000));
}

TEST(BehaviourGui, WindowStatePersistsBetweenRuns) {
  application();
  QSettings().clear();
  const std::string dir = freshDir("settings");
  QSize size;
  {
    MainWindow w(options(sourcePath("config/sim.toml"), dir, /*settings=*/true));
    w.resize(1111, 777);
    w.show();
    w.tabs()->setCurrentIndex(3);
    ASSERT_TRUE(QTest::qWaitFor([&] { return w.profile() != nullptr; }, 20000));
    size = w.size();  // what the window really is (it may not go below its minimum)
    w.close();
  }
  MainWindow again(options({}, {}, /*settings=*/true));
  EXPECT_EQ(again.tabs()->currentIndex(), 3);
  EXPECT_EQ(again.shotsDir().toStdString(), dir);
  EXPECT_EQ(again.size(), size);
  ASSERT_TRUE(QTest::qWaitFor([&] { return again.profile() != nullptr; }, 20000));
  EXPECT_EQ(again.profile()->source, sourcePath("config/sim.toml"));
  QSettings().clear();
}

TEST(BehaviourGui, SafetyLimitsBoundWhatThePanelCanAskFor) {
  application();
  const std::string dir = freshDir("safety");
  MainWindow w(options(simProfileWith(dir, "calibration", "max_kpa", "60.0"), dir + "/shots"));
  w.show();
  ASSERT_TRUE(QTest::qWaitFor([&] { return w.profile() != nullptr; }, 20000))
      << w.messages().join("\n").toStdString();
  auto* pressure = w.rigPanel()->findChild<QDoubleSpinBox*>("pressure_0");
  auto* speed = w.rigPanel()->findChild<QDoubleSpinBox*>("speed_0");
  EXPECT_DOUBLE_EQ(pressure->maximum(), 60.0);
  auto curve = w.profile()->calibration.curve();
  ASSERT_TRUE(curve);
  EXPECT_NEAR(speed->maximum(), curve->speed_m_s(60.0), 1e-3);
  speed->setValue(9.0);  // above what 60 kPa gives: clamped
  EXPECT_LE(pressure->value(), 60.0);
  EXPECT_TRUE(
      w.rigPanel()->findChild<QLabel*>("safety_limits")->text().contains("safety maximum 200 kPa"));
}

TEST(BehaviourGui, BurstSettingsApplyAndAreRecordedWithTheShot) {
  application();
  const std::string dir = freshDir("burst");
  MainWindow w(options(sourcePath("config/sim.toml"), dir));
  w.show();
  auto running = [&] {
    const RigStatus& s = w.rigPanel()->lastStatus();
    return w.profile() && s.state[0] == "running" && s.state[2] == "running";
  };
  ASSERT_TRUE(QTest::qWaitFor(running, 20000));
  RigPanel* panel = w.rigPanel();
  panel->findChild<QSpinBox*>("pre_trigger_frames")->setValue(12);
  panel->findChild<QSpinBox*>("post_trigger_frames")->setValue(18);
  QTest::mouseClick(panel->findChild<QPushButton*>("apply_burst"), Qt::LeftButton);
  ASSERT_TRUE(QTest::qWaitFor([&] { return w.profile()->burst.post_trigger_frames == 18; }, 20000))
      << w.messages().join("\n").toStdString();
  ASSERT_TRUE(QTest::qWaitFor(running, 20000));
  QTest::mouseClick(panel->findChild<QPushButton*>("arm_button"), Qt::LeftButton);
  auto* fire = panel->findChild<QPushButton*>("fire_button");
  ASSERT_TRUE(QTest::qWaitFor([&] { return fire->isEnabled(); }, 10000));
  QTest::mouseClick(fire, Qt::LeftButton);
  ASSERT_TRUE(QTest::qWaitFor([&] { return w.lastShot() != nullptr; }, 30000));
  const hw::Shot& shot = *w.lastShot();
  ASSERT_EQ(shot.status, hw::ShotStatus::Ok) << shot.failure_reason;
  EXPECT_EQ(shot.burst.frames.size(), 30u);
  EXPECT_EQ(shot.burst.frames.front().id, -12);
  // The profile recorded with the shot says what was really used.
  auto recorded = hw::parseRigProfile(shot.rig_profile_toml, "recorded");
  ASSERT_TRUE(recorded) << recorded.error().message;
  EXPECT_EQ(recorded->burst.pre_trigger_frames, 12);
  EXPECT_EQ(recorded->burst.post_trigger_frames, 18);
}
