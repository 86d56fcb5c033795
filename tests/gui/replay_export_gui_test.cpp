// Replay's video export, driven as a user does (issue 14): a simulated shot
// opened in Replay, frames marked with the keys I and O, "Export video..."
// clicked, the file typed and a slow-down chosen in the dialog, Export
// clicked. The written AVI is read back with OpenCV's VideoCapture and
// compared with the shot's own frames (the independent truth): as many frames
// as marked, in order, at the stated fraction of real time, not blank.
#include <gtest/gtest.h>

#include <QComboBox>
#include <QDialogButtonBox>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "app/gui/replay_view.hpp"
#include "app/gui/video_export_dialog.hpp"
#include "app/profile_edit.hpp"
#include "app/rig_setup.hpp"
#include "gui_test_support.hpp"
#include "gui_window_support.hpp"
#include "hw/sequencer.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;
namespace fs = std::filesystem;

namespace {

// A shot of the simulated rig (config/sim.toml) with its camera set to Mono12,
// so the export has 16-bit words to scale.
ShotPtr simulatedShot() {
  auto loaded = hw::loadRigProfile(sourcePath("config/sim.toml"));
  if (!loaded) throw std::runtime_error(loaded.error().message);
  auto text = app::setProfileValue(loaded->text, "camera", "format", "\"Mono12\"");
  if (!text) throw std::runtime_error(text.error().message);
  auto profile = hw::parseRigProfile(*text, loaded->source);
  if (!profile) throw std::runtime_error(profile.error().message);
  auto rig = app::buildRig(*profile);
  if (!rig) throw std::runtime_error(rig.error().message);
  hw::Shot shot = hw::Sequencer(*rig).fire(hw::ShotRequest::atSpeeds(2.1, 1.9));
  (void)hw::shutDown(*rig);
  if (shot.status != hw::ShotStatus::Ok) throw std::runtime_error("shot failed");
  return std::make_shared<const hw::Shot>(std::move(shot));
}

// The shot's frame as the view shows it (Mono12: value * 255 / 4095), made
// here from the raw pixels, not by the code under test.
cv::Mat shownGrey(const hw::Shot& shot, int index) {
  const cv::Mat& raw = shot.burst.frames[index].image;
  if (raw.depth() == CV_8U) return raw;
  cv::Mat grey;
  raw.convertTo(grey, CV_8U, 255.0 / vision::maxValue(shot.burst.format));
  return grey;
}

double meanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  return cv::mean(d)[0];
}

// Opens the export dialog with a click, types `file`, steps the slow-down
// `downs` entries on with the Down key, clicks Export; returns the dialog's
// slow-down N (1/N of real time).
int exportThroughDialog(ReplayView& view, const QString& file, int downs) {
  QTest::mouseClick(view.findChild<QPushButton*>("export_video"), Qt::LeftButton);
  auto* dialog = view.findChild<VideoExportDialog*>("video_export_dialog");
  if (!dialog || !QTest::qWaitForWindowExposed(dialog, 2000)) return -1;
  auto* path = dialog->findChild<QLineEdit*>("video_path");
  QTest::mouseClick(path, Qt::LeftButton);
  QTest::keyClick(path, Qt::Key_A, Qt::ControlModifier);
  QTest::keyClicks(path, file);
  auto* slow = dialog->findChild<QComboBox*>("slow_down");
  slow->setFocus();
  for (int k = 0; k < downs; ++k) QTest::keyClick(slow, Qt::Key_Down);
  const int n = dialog->slowDown();
  (void)screenshot(dialog, "video_export_dialog");
  auto* buttons = dialog->findChild<QDialogButtonBox*>();
  QTest::mouseClick(buttons->button(QDialogButtonBox::Ok), Qt::LeftButton);
  // Written on a worker thread; the status line says when it is done.
  auto* status = view.findChild<QLabel*>("export_status");
  const bool done = QTest::qWaitFor(
      [&] { return status->text().startsWith("wrote") || status->text().startsWith("not"); },
      20000);
  return done ? n : -2;
}

}  // namespace

TEST(ReplayExportGui, MarkedFramesBecomeAVideoAtAFractionOfRealTime) {
  application();
  const ShotPtr shot = simulatedShot();
  ASSERT_EQ(shot->burst.format, vision::PixelFormat::Mono12);
  ReplayView view;
  view.resize(1366, 700);
  view.setShot(shot);
  activate(&view);
  // Mark frames 4..15 (positions) with the keys.
  QTest::keyClick(&view, Qt::Key_Home);
  for (int k = 0; k < 4; ++k) QTest::keyClick(&view, Qt::Key_Right);
  QTest::keyClick(&view, Qt::Key_I);
  QTest::keyClick(&view, Qt::Key_Right, Qt::ShiftModifier);
  QTest::keyClick(&view, Qt::Key_Right);
  QTest::keyClick(&view, Qt::Key_O);
  ASSERT_EQ(view.markIn(), 4);
  ASSERT_EQ(view.markOut(), 15);

  const std::string dir = freshDir("export-video");
  const std::string file = dir + "/marked";  // the dialog adds .avi
  const int n = exportThroughDialog(view, QString::fromStdString(file), 1);
  ASSERT_GT(n, 0) << "the export dialog did not open (-1) or the export did not end (-2)";
  const QString status = view.findChild<QLabel*>("export_status")->text();
  EXPECT_TRUE(status.contains(QString("1/%1x real time").arg(n))) << status.toStdString();
  ASSERT_TRUE(fs::exists(file + ".avi")) << status.toStdString();

  cv::VideoCapture cap(file + ".avi", cv::CAP_OPENCV_MJPEG);
  ASSERT_TRUE(cap.isOpened());
  EXPECT_NEAR(cap.get(cv::CAP_PROP_FPS), shot->burst.fps / n, 1e-6);
  cv::Mat frame, grey;
  for (int k = 4; k <= 15; ++k) {
    ASSERT_TRUE(cap.read(frame)) << "frame " << k << " missing";
    cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
    cv::Scalar mean, sd;
    cv::meanStdDev(grey, mean, sd);
    EXPECT_GT(sd[0], 5.0) << "frame " << k << " is blank";
    // Closest to its own frame of the shot, and close in absolute terms.
    const double own = meanAbsDiff(grey, shownGrey(*shot, k));
    EXPECT_LT(own, 2.0) << "frame " << k;
    for (int other : {k - 3, k + 3})
      EXPECT_LT(own, meanAbsDiff(grey, shownGrey(*shot, other)))
          << "frame " << k << " vs " << other;
  }
  EXPECT_FALSE(cap.read(frame)) << "more frames than marked";
  EXPECT_TRUE(screenshot(&view, "replay_export"));
}

TEST(ReplayExportGui, AnUnwritableFileIsNamedAndLeavesNothing) {
  application();
  ReplayView view;
  view.resize(1366, 700);
  view.setShot(simulatedShot());
  activate(&view);
  const std::string file = freshDir("export-video-bad") + "/no/such/folder/shot.avi";
  ASSERT_GT(exportThroughDialog(view, QString::fromStdString(file), 0), 0);
  auto* status = view.findChild<QLabel*>("export_status");
  EXPECT_TRUE(status->text().contains(QString::fromStdString(file)))
      << status->text().toStdString();
  EXPECT_TRUE(status->text().contains("not exported")) << status->text().toStdString();
  EXPECT_FALSE(fs::exists(file));
}

// Issue 14: the playback speed also says what it is as a fraction of real
// time, from the shot's recording rate (1000 frames/s in config/sim.toml):
// 25 screen frames/s is 1/40x real time; one step down the list with the
// keyboard, 50 frames/s, is 1/20x.
TEST(ReplayExportGui, PlaybackSpeedIsAFractionOfRealTime) {
  application();
  const ShotPtr shot = simulatedShot();
  ASSERT_DOUBLE_EQ(shot->burst.fps, 1000.0);
  ReplayView view;
  view.resize(1366, 700);
  view.setShot(shot);
  activate(&view);
  auto* speed = view.findChild<QComboBox*>("playback_speed");
  EXPECT_DOUBLE_EQ(view.playbackRate(), 25.0);
  EXPECT_DOUBLE_EQ(view.playbackRealTimeFraction(), 25.0 / 1000.0);
  EXPECT_TRUE(speed->currentText().contains("1/40x real time"))
      << speed->currentText().toStdString();
  QTest::mouseClick(speed, Qt::LeftButton);  // opens the list
  QTest::keyClick(QApplication::focusWidget(), Qt::Key_Down);
  QTest::keyClick(QApplication::focusWidget(), Qt::Key_Return);
  EXPECT_DOUBLE_EQ(view.playbackRate(), 50.0);
  EXPECT_DOUBLE_EQ(view.playbackRealTimeFraction(), 50.0 / 1000.0);
  EXPECT_TRUE(speed->currentText().contains("1/20x real time"))
      << speed->currentText().toStdString();
}
