// Issue 15 in the lab GUI: a device that stops answering is a state. Driven
// with real input events: shots fired through the window's own Fire button
// until the simulated regulator goes silent; the rig panel then shows it lost
// (its state and the read-back say "lost", the action bar says what happened
// and what to check) with Arm and Fire off; Reconnect, run on the rig's
// control thread, leaves it lost while the hardware is still silent and clears
// it once the hardware answers again (hw/sim_silence.hpp), after which a shot
// fires again.
#include <gtest/gtest.h>

#include <QLabel>
#include <QPushButton>
#include <QSignalSpy>
#include <QTableWidget>
#include <QThread>
#include <fstream>

#include "app/gui/main_window.hpp"
#include "app/gui/rig_panel.hpp"
#include "app/profile_edit.hpp"
#include "gui_test_support.hpp"
#include "gui_window_support.hpp"
#include "hw/sim_silence.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;

namespace {

// This label is used by no other test of this process: the simulated
// hardware behind a label is shared by every device of that label.
const char* const kRegulator = "gui-lost-regulator";

// config/sim.toml whose regulator answers `setpoints` setpoints, then nothing
// (each request then waits `timeout_ms`), written into `dir`.
std::string silentRegulatorProfile(const std::string& dir, int setpoints, int timeout_ms) {
  std::ifstream in(sourcePath("config/sim.toml"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::pair<const char*, std::string> edits[] = {
      {"device", std::string("\"") + kRegulator + "\""},
      {"fault", "\"silent\""},
      {"silent_after_setpoints", std::to_string(setpoints)},
      {"silent_timeout_ms", std::to_string(timeout_ms)}};
  for (const auto& [key, value] : edits) {
    auto edited = app::setProfileValue(text, "regulator", key, value);
    if (!edited) throw std::runtime_error(edited.error().message);
    text = *edited;
  }
  const std::string path = dir + "/rig.toml";
  std::ofstream(path) << text;
  return path;
}

QString regulatorStateCell(RigPanel* panel) {
  QTableWidgetItem* item = child<QTableWidget>(panel, "device_table")->item(0, 2);
  return item ? item->text() : QString();
}

// The lost devices' message is shown whole: as tall as its text needs at its
// width, and not under the armed state below it.
void expectWhole(QLabel* lost, RigPanel* panel) {
  QTest::qWait(100);  // the action bar laid out again for the message
  EXPECT_GE(lost->height(), lost->heightForWidth(lost->width())) << "the lost message is cut off";
  EXPECT_FALSE(lost->geometry().intersects(child<QLabel>(panel, "arm_state")->geometry()))
      << "the lost message overlaps the armed state";
}

}  // namespace

TEST(DeviceLostGui, ALostRegulatorIsShownAndOnlyReconnectClearsItOnceItAnswers) {
  application();
  const std::string dir = freshDir("device-lost");
  // Arming sets 2 setpoints and each shot 2 more: 6 answered setpoints are
  // arming and two good shots; the third shot's first setpoint goes unanswered.
  MainWindow w(windowOptions(silentRegulatorProfile(dir, 6, 300), dir + "/shots"));
  w.resize(1366, 768);
  w.show();
  ASSERT_TRUE(QTest::qWaitForWindowExposed(&w));
  ASSERT_TRUE(waitUntilRigRunning(w)) << w.messages().join("\n").toStdString();
  RigPanel* panel = w.rigPanel();
  auto* arm = child<QPushButton>(panel, "arm_button");
  auto* fire = child<QPushButton>(panel, "fire_button");
  auto* reconnect = child<QPushButton>(panel, "reconnect_button");
  auto* lost_label = child<QLabel>(panel, "lost_devices");
  auto* readback = child<QLabel>(panel, "readback_0");
  EXPECT_FALSE(reconnect->isEnabled()) << "Reconnect with nothing lost";
  EXPECT_FALSE(lost_label->isVisible());

  // Fire through the window until the regulator is lost.
  int ok_shots = 0;
  for (int attempt = 0; attempt < 6 && !panel->lastStatus().anyLost(); ++attempt) {
    if (!fire->isEnabled()) {
      clickThroughWindow(arm);
      ASSERT_TRUE(QTest::qWaitFor(
          [&] { return fire->isEnabled() || panel->lastStatus().anyLost(); }, 10000))
          << w.messages().join("\n").toStdString();
      if (panel->lastStatus().anyLost()) break;
    }
    const ShotPtr previous = w.lastShot();
    clickThroughWindow(fire);
    // The window hears of the shot through a queued signal.
    ASSERT_TRUE(QTest::qWaitFor([&] { return w.lastShot() != previous; }, 30000));
    if (w.lastShot()->status == hw::ShotStatus::Ok) ++ok_shots;
    QTest::qWait(200);  // the status after the shot
  }
  ASSERT_TRUE(panel->lastStatus().anyLost()) << w.messages().join("\n").toStdString();
  EXPECT_EQ(ok_shots, 2) << "the regulator went silent after its 6th setpoint";
  ASSERT_TRUE(panel->lastStatus().lost[0].has_value()) << "the regulator is the lost device";
  EXPECT_FALSE(panel->lastStatus().lost[1] || panel->lastStatus().lost[2]);
  EXPECT_EQ(w.lastShot()->status, hw::ShotStatus::Failed);

  // The panel shows it: the state cell, the read-back (no stale pressure),
  // the action bar's message, and Arm / Fire off with why.
  const QString device = QString("regulator \"%1\"").arg(kRegulator);
  EXPECT_EQ(regulatorStateCell(panel), "lost");
  EXPECT_TRUE(child<QTableWidget>(panel, "device_table")
                  ->item(0, 2)
                  ->toolTip()
                  .contains(device + " is lost"));
  EXPECT_TRUE(readback->text().contains("lost")) << readback->text().toStdString();
  EXPECT_FALSE(readback->text().contains("kPa")) << "a stale pressure is shown";
  EXPECT_TRUE(readback->toolTip().contains("check the regulator's power"))
      << readback->toolTip().toStdString();
  ASSERT_TRUE(lost_label->isVisible());
  const QString shown = lost_label->text();
  EXPECT_TRUE(shown.contains("is lost") && shown.contains("no answer within 300 ms"))
      << shown.toStdString();
  EXPECT_TRUE(shown.contains("check the regulator's power") && shown.contains("press Reconnect"))
      << shown.toStdString();
  // The whole message (the hw layer's, with the GUI's way to clear it) is its tooltip.
  EXPECT_TRUE(lost_label->toolTip().contains("retrying will not help"));
  EXPECT_TRUE(lost_label->toolTip().contains("press Reconnect in the GUI's rig panel"))
      << lost_label->toolTip().toStdString();
  expectWhole(lost_label, panel);
  EXPECT_FALSE(arm->isEnabled());
  EXPECT_FALSE(fire->isEnabled());
  EXPECT_TRUE(arm->toolTip().contains("lost")) << arm->toolTip().toStdString();
  EXPECT_TRUE(child<QLabel>(panel, "next_step_hint")->text().contains("Reconnect"));
  EXPECT_TRUE(reconnect->isEnabled());
  // Nothing that rebuilds the rig (and so would forget the loss without
  // asking the device) is offered either.
  auto* apply_burst = child<QPushButton>(panel, "apply_burst");
  auto* exposure = child<QAbstractSpinBox>(&w, "live_exposure_us");
  EXPECT_FALSE(apply_burst->isEnabled());
  EXPECT_TRUE(apply_burst->toolTip().contains("Reconnect")) << apply_burst->toolTip().toStdString();
  EXPECT_FALSE(exposure->isEnabled());
  EXPECT_TRUE(exposure->toolTip().contains("lost")) << exposure->toolTip().toStdString();
  clickThroughWindow(arm);  // disabled: nothing is armed
  QTest::qWait(300);
  EXPECT_FALSE(panel->lastStatus().armed);

  // Reconnect while the hardware is still silent: it stays lost. The re-check
  // runs on the control thread: the click returns before it reports back.
  const std::shared_ptr<hw::SimSilence> hardware = hw::SimSilence::find(device.toStdString());
  ASSERT_NE(hardware, nullptr);
  const std::int64_t unanswered = hardware->unanswered();
  QSignalSpy reconnected(w.rigWorker(), &RigWorker::reconnectFinished);
  QThread* reported_on = nullptr;
  QObject::connect(
      w.rigWorker(), &RigWorker::reconnectFinished, &w,
      [&](bool, QString) { reported_on = QThread::currentThread(); }, Qt::DirectConnection);
  clickThroughWindow(reconnect);
  EXPECT_EQ(reconnected.count(), 0) << "the re-check ran inside the click (on the GUI thread)";
  EXPECT_FALSE(reconnect->isEnabled()) << "enabled while reconnecting";
  ASSERT_TRUE(QTest::qWaitFor([&] { return reconnected.count() == 1; }, 20000));
  // Reported on the window's thread (RigWorker's signals come through its
  // Mailbox), from work done on the control thread.
  EXPECT_EQ(reported_on, QThread::currentThread());
  EXPECT_EQ(w.rigWorker()->thread(), w.rigWorker()->controlThread());
  EXPECT_FALSE(reconnected.at(0).at(0).toBool());
  EXPECT_GT(hardware->unanswered(), unanswered) << "Reconnect did not ask the regulator";
  QTest::qWait(300);
  EXPECT_TRUE(panel->lastStatus().lost[0].has_value());
  EXPECT_TRUE(w.messages().last().startsWith("Still lost")) << w.messages().last().toStdString();
  EXPECT_EQ(w.lastMessageKind(), MainWindow::MessageKind::Error);
  EXPECT_TRUE(lost_label->text().contains("did not find it")) << lost_label->text().toStdString();
  EXPECT_EQ(regulatorStateCell(panel), "lost");
  EXPECT_FALSE(arm->isEnabled());
  EXPECT_TRUE(reconnect->isEnabled()) << "Reconnect can be tried again";
  expectWhole(lost_label, panel);
  EXPECT_TRUE(screenshot(&w, "device_lost"));

  // The regulator's cable is plugged back in: Reconnect clears it.
  hardware->answerAgain();
  clickThroughWindow(reconnect);
  ASSERT_TRUE(QTest::qWaitFor([&] { return reconnected.count() == 2; }, 20000));
  EXPECT_TRUE(reconnected.at(1).at(0).toBool()) << reconnected.at(1).at(1).toString().toStdString();
  ASSERT_TRUE(QTest::qWaitFor([&] { return !panel->lastStatus().anyLost(); }, 5000));
  EXPECT_TRUE(w.messages().last().startsWith("Reconnected")) << w.messages().last().toStdString();
  EXPECT_EQ(w.lastMessageKind(), MainWindow::MessageKind::Info);
  EXPECT_FALSE(lost_label->isVisible());
  EXPECT_EQ(regulatorStateCell(panel), "running");
  EXPECT_TRUE(readback->text().contains("kPa")) << readback->text().toStdString();
  EXPECT_TRUE(arm->isEnabled());
  EXPECT_FALSE(reconnect->isEnabled());
  EXPECT_TRUE(apply_burst->isEnabled());
  EXPECT_TRUE(exposure->isEnabled());

  // And the rig fires again.
  clickThroughWindow(arm);
  ASSERT_TRUE(QTest::qWaitFor([&] { return fire->isEnabled(); }, 10000))
      << w.messages().join("\n").toStdString();
  const ShotPtr previous = w.lastShot();
  clickThroughWindow(fire);
  ASSERT_TRUE(QTest::qWaitFor([&] { return w.lastShot() != previous; }, 30000));
  EXPECT_EQ(w.lastShot()->status, hw::ShotStatus::Ok) << w.lastShot()->failure_reason;
}
