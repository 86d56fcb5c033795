// What a vendor viewer has (issue 14), driven with real input events: zoom
// about the cursor with the wheel, pan by dragging, the pixel value under the
// cursor, the measuring tool, the live histogram with its saturation warning,
// Replay's keys (frame stepping, Home/End, Space, marks), playback loop and
// reverse, exporting marked frames, the arm/fire keyboard chords (fire only
// when armed and settled), and vendor footage opened in Replay.
#include <gtest/gtest.h>

#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QMouseEvent>
#include <QPushButton>
#include <QTableWidget>
#include <QWheelEvent>
#include <filesystem>
#include <fstream>

#include "app/gui/histogram_view.hpp"
#include "app/gui/live_view.hpp"
#include "app/gui/main_window.hpp"
#include "app/gui/replay_view.hpp"
#include "app/gui/rig_panel.hpp"
#include "app/gui/shot_browser.hpp"
#include "app/rig_setup.hpp"
#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"
#include "app/store/shot_id.hpp"
#include "gui_test_support.hpp"
#include "gui_window_support.hpp"
#include "hw/sequencer.hpp"
#include "vision/footage.hpp"

using namespace collide;
using namespace collide::gui;
using namespace collide::gui::testing;
namespace fs = std::filesystem;

namespace {

// A 64 x 48 Mono12 frame: value 100 + u + 10 v at pixel (u, v), so every
// pixel's value says where it is.
cv::Mat rampMono12() {
  cv::Mat m(48, 64, CV_16U);
  for (int v = 0; v < m.rows; ++v)
    for (int u = 0; u < m.cols; ++u)
      m.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(100 + u + 10 * v);
  return m;
}

// An ImageView 640 x 480 showing the ramp: 10 screen pixels per image pixel,
// pixel (u, v) covering [10u, 10u + 10) x [10v, 10v + 10) on screen.
std::unique_ptr<ImageView> rampView() {
  auto view = std::make_unique<ImageView>();
  view->resize(640, 480);
  const cv::Mat raw = rampMono12();
  view->setImage(toDisplayImage(raw, vision::PixelFormat::Mono12));
  view->setRawFrame(raw, vision::PixelFormat::Mono12);
  view->show();
  QApplication::processEvents();
  return view;
}

void wheelAt(QWidget* w, QPointF at, int notches) {
  QWheelEvent e(at, w->mapToGlobal(at), QPoint(), QPoint(0, 120 * notches), Qt::NoButton,
                Qt::NoModifier, Qt::NoScrollPhase, false);
  QApplication::sendEvent(w, &e);
}

void mouse(QWidget* w, QEvent::Type type, QPointF at, Qt::MouseButton button, Qt::MouseButtons held,
           Qt::KeyboardModifiers modifiers = Qt::NoModifier) {
  QMouseEvent e(type, at, w->mapToGlobal(at), button, held, modifiers);
  QApplication::sendEvent(w, &e);
}

void drag(QWidget* w, QPointF from, QPointF to, Qt::MouseButton button,
          Qt::KeyboardModifiers modifiers = Qt::NoModifier) {
  mouse(w, QEvent::MouseButtonPress, from, button, button, modifiers);
  mouse(w, QEvent::MouseMove, (from + to) / 2, Qt::NoButton, button, modifiers);
  mouse(w, QEvent::MouseMove, to, Qt::NoButton, button, modifiers);
  mouse(w, QEvent::MouseButtonRelease, to, button, Qt::NoButton, modifiers);
}

// A burst of `n` Mono8 frames, ids -10 .. n - 11, each filled with its index.
ShotPtr syntheticShot(int n) {
  hw::Shot shot;
  shot.id = "synthetic";
  shot.burst.format = vision::PixelFormat::Mono8;
  shot.burst.fps = 1000;
  for (int k = 0; k < n; ++k) {
    vision::Frame f;
    f.id = k - 10;
    f.timestamp_ns = k * 1000000LL;
    f.image = cv::Mat(24, 32, CV_8U, cv::Scalar(k));
    shot.burst.frames.push_back(f);
  }
  return std::make_shared<const hw::Shot>(std::move(shot));
}

}  // namespace

TEST(ViewerToolsGui, CursorShowsThePixelsRawValueAndPosition) {
  application();
  auto view = rampView();
  // Screen point (105, 205) lies in pixel (10, 20): raw value 100 + 10 + 200.
  QTest::mouseMove(view.get(), QPoint(105, 205));
  QApplication::processEvents();
  EXPECT_EQ(view->cursorText().toStdString(), "u 10, v 20: 310 of 4095");
  QTest::mouseMove(view.get(), QPoint(639, 479));  // the last pixel (63, 47)
  QApplication::processEvents();
  EXPECT_EQ(view->cursorText().toStdString(), "u 63, v 47: 633 of 4095");
}

TEST(ViewerToolsGui, WheelZoomsAboutTheCursorAndDoubleClickRestores) {
  application();
  auto view = rampView();
  const QPointF at(105, 205);
  wheelAt(view.get(), at, 2);
  EXPECT_NEAR(view->zoom(), 1.25 * 1.25, 1e-12);
  // The point under the cursor stays under it: pixel (10, 20)'s centre is
  // 0.5 px right and below the cursor's image point (10.0, 20.0) at zoom 1.
  const QPointF under = view->toImage(at);
  EXPECT_NEAR(under.x(), 10.0, 1e-9);
  EXPECT_NEAR(under.y(), 20.0, 1e-9);
  QTest::mouseMove(view.get(), at.toPoint());
  EXPECT_TRUE(view->cursorText().startsWith("u 10, v 20: 310"));
  // Thirty more notches: capped at the most the view zooms, never past it.
  for (int k = 0; k < 30; ++k) wheelAt(view.get(), at, 1);
  EXPECT_DOUBLE_EQ(view->zoom(), ImageView::kMaxZoom);
  wheelAt(view.get(), at, -60);
  EXPECT_DOUBLE_EQ(view->zoom(), 1.0);
  wheelAt(view.get(), at, 3);
  QTest::mouseDClick(view.get(), Qt::LeftButton, {}, QPoint(320, 240));
  EXPECT_DOUBLE_EQ(view->zoom(), 1.0);
}

TEST(ViewerToolsGui, LeftDragPansAZoomedImage) {
  application();
  auto view = rampView();
  wheelAt(view.get(), QPointF(320, 240), 4);  // zoom 2.44 about the middle
  const double scale = 10.0 * view->zoom();
  const QPointF probe(320, 240);
  const QPointF before = view->toImage(probe);
  drag(view.get(), QPointF(400, 240), QPointF(300, 240), Qt::LeftButton);
  const QPointF after = view->toImage(probe);
  // Dragging the image 100 screen px to the left brings 100 / scale image
  // pixels from the right under the probe.
  EXPECT_NEAR(after.x() - before.x(), 100.0 / scale, 1e-9);
  EXPECT_NEAR(after.y() - before.y(), 0.0, 1e-9);
  // Panning stops at the image's edge: a huge drag leaves its right edge at
  // the widget's right edge.
  drag(view.get(), QPointF(600, 240), QPointF(-5000, 240), Qt::LeftButton);
  EXPECT_NEAR(view->toImage(QPointF(640, 240)).x(), 63.5, 1e-9);
}

TEST(ViewerToolsGui, RightDragMeasuresInPixelsAndMillimetres) {
  application();
  auto view = rampView();
  view->setPixelSize(0.5e-3);
  // From pixel (10, 20)'s centre to pixel (40, 40)'s: 30 across, 20 down.
  drag(view.get(), QPointF(105, 205), QPointF(405, 605 - 200), Qt::RightButton);
  ASSERT_TRUE(view->measurement());
  EXPECT_NEAR(view->measurement()->length(), std::hypot(30.0, 20.0), 1e-9);
  const double expected_px = std::hypot(30.0, 20.0);
  const double angle = -std::atan2(20.0, 30.0) * 180 / M_PI;  // down the image: negative
  EXPECT_EQ(view->measurementText(), QString("%1 px = %2 mm, %3°")
                                         .arg(expected_px, 0, 'f', 1)
                                         .arg(expected_px * 0.5, 0, 'f', 2)
                                         .arg(angle, 0, 'f', 1));
  // Shift + left drag measures too; a plain click does not leave a zero-length one.
  drag(view.get(), QPointF(105, 105), QPointF(105, 305), Qt::LeftButton, Qt::ShiftModifier);
  ASSERT_TRUE(view->measurement());
  EXPECT_NEAR(view->measurement()->length(), 20.0, 1e-9);
  view->setFocus();
  QTest::keyClick(view.get(), Qt::Key_Escape);
  EXPECT_FALSE(view->measurement());
  drag(view.get(), QPointF(105, 105), QPointF(105, 105), Qt::RightButton);
  EXPECT_FALSE(view->measurement());
}

TEST(ViewerToolsGui, HistogramCountsEveryPixelAndWarnsOfSaturation) {
  application();
  cv::Mat m(10, 10, CV_16U, cv::Scalar(1000));
  for (int k = 0; k < 7; ++k) m.at<std::uint16_t>(k, 3) = 4095;
  const Histogram h = histogramOf(m, 4095, 64);
  std::uint64_t total = 0;
  for (auto c : h.counts) total += c;
  EXPECT_EQ(total, 100u);
  EXPECT_EQ(h.saturated, 7u);
  EXPECT_EQ(h.counts.back(), 7u);
  EXPECT_EQ(h.counts[1000 * 64 / 4096], 93u);
  HistogramView view;
  view.setHistogram(h);
  EXPECT_TRUE(view.warning().startsWith("7.0 % of the pixels saturated (7 at 4095)"))
      << view.warning().toStdString();
  view.setHistogram(histogramOf(cv::Mat(10, 10, CV_16U, cv::Scalar(4094)), 4095));
  EXPECT_TRUE(view.warning().isEmpty());
}

TEST(ViewerToolsGui, LiveViewShowsCameraSettingsHistogramAndSaturation) {
  application();
  auto profile = hw::loadRigProfile(sourcePath("config/sim.toml"));
  ASSERT_TRUE(profile);
  auto rig = app::buildRig(*profile);
  ASSERT_TRUE(rig);
  ASSERT_TRUE(hw::bringUp(*rig));
  rig->camera->setLiveView(true);
  LiveView view;
  view.resize(1000, 560);
  view.show();
  view.setCamera(CameraPtr(rig->camera.get(), [](hw::Camera*) {}));
  ASSERT_TRUE(QTest::qWaitFor([&] { return view.framesShown() >= 2; }, 10000));
  const hw::CameraConfig c = rig->camera->config();
  const QString text = view.cameraSettingsText();
  EXPECT_TRUE(text.contains(QString("exposure %1 us").arg(c.exposure_us, 0, 'f', 0)))
      << text.toStdString();
  EXPECT_TRUE(text.contains(QString("frame rate %1 frames/s").arg(c.fps, 0, 'f', 0)));
  EXPECT_TRUE(text.contains(QString("region %1 x %2").arg(c.width).arg(c.height)));
  const Histogram& h = view.histogramView()->histogram();
  EXPECT_EQ(h.pixels, static_cast<std::uint64_t>(c.width) * c.height);
  // The saturation line says what the histogram counted at full scale.
  EXPECT_EQ(view.saturationWarning().isEmpty(), h.saturated == 0);
  EXPECT_TRUE(screenshot(&view, "live_tools"));
  view.setCamera(nullptr);
  (void)hw::shutDown(*rig);
}

TEST(ViewerToolsGui, ReplayKeysStepPlayLoopReverseAndMark) {
  application();
  ReplayView view;
  view.resize(1000, 600);
  view.setShot(syntheticShot(30));
  activate(&view);
  ASSERT_EQ(view.frameIndex(), 10);  // the trigger frame, id 0
  QTest::keyClick(&view, Qt::Key_Right);
  EXPECT_EQ(view.frameIndex(), 11);
  QTest::keyClick(&view, Qt::Key_Right, Qt::ShiftModifier);
  EXPECT_EQ(view.frameIndex(), 21);
  QTest::keyClick(&view, Qt::Key_Left);
  EXPECT_EQ(view.frameIndex(), 20);
  QTest::keyClick(&view, Qt::Key_End);
  EXPECT_EQ(view.frameIndex(), 29);
  QTest::keyClick(&view, Qt::Key_Home);
  EXPECT_EQ(view.frameIndex(), 0);
  // The shown image is the frame stepped to (each frame's pixels are its index).
  QTest::keyClick(&view, Qt::Key_Right);
  EXPECT_EQ(qGray(view.imageView()->image().pixel(3, 3)), 1);

  // Space plays at the chosen rate and stops at the last frame; with loop
  // and reverse it runs backwards through frame 0 round to the end.
  view.findChild<QComboBox*>("playback_speed")->setCurrentIndex(5);  // 100 frames/s
  EXPECT_DOUBLE_EQ(view.playbackRate(), 100.0);
  QTest::keyClick(&view, Qt::Key_Space);
  EXPECT_TRUE(view.playing());
  ASSERT_TRUE(QTest::qWaitFor([&] { return !view.playing(); }, 5000));
  EXPECT_EQ(view.frameIndex(), 29);
  QTest::mouseClick(view.findChild<QCheckBox*>("loop"), Qt::LeftButton);
  QTest::mouseClick(view.findChild<QCheckBox*>("reverse"), Qt::LeftButton);
  view.showFrame(3);
  view.setFocus();
  QTest::keyClick(&view, Qt::Key_Space);
  ASSERT_TRUE(QTest::qWaitFor([&] { return view.frameIndex() > 20; }, 5000));
  EXPECT_TRUE(view.playing()) << "looping: never stops by itself";
  QTest::keyClick(&view, Qt::Key_Space);
  EXPECT_FALSE(view.playing());

  // I and O mark the frames to export; the export writes exactly those.
  view.showFrame(5);
  QTest::keyClick(&view, Qt::Key_I);
  view.showFrame(9);
  QTest::keyClick(&view, Qt::Key_O);
  EXPECT_EQ(view.markIn(), 5);
  EXPECT_EQ(view.markOut(), 9);
  const std::string dir = freshDir("export-marked");
  ASSERT_TRUE(view.exportMarkedFrames(QString::fromStdString(dir)).isEmpty());
  int pngs = 0;
  for (const auto& e : fs::directory_iterator(dir)) pngs += e.path().extension() == ".png";
  EXPECT_EQ(pngs, 5);
  // Writing into a file instead of a folder fails with a message, not silently.
  const std::string file = dir + "/frame.png.txt";
  std::ofstream(file) << "x";
  EXPECT_FALSE(view.exportMarkedFrames(QString::fromStdString(file)).isEmpty());
}

TEST(ViewerToolsGui, FireByKeyOnlyWhenArmedAndSettled) {
  application();
  const std::string dir = freshDir("keys");
  MainWindow w(windowOptions(sourcePath("config/sim.toml"), dir + "/shots"));
  w.resize(1366, 768);
  activate(&w);
  ASSERT_TRUE(waitUntilRigRunning(w));
  auto* fire = w.findChild<QPushButton*>("fire_button");
  ASSERT_TRUE(fire);
  // Not armed: the fire chord does nothing.
  QTest::keyClick(&w, Qt::Key_F, Qt::ControlModifier | Qt::ShiftModifier);
  QTest::qWait(500);
  EXPECT_EQ(w.lastShot(), nullptr);
  // Armed by its chord, fired by its chord once settled.
  QTest::keyClick(&w, Qt::Key_A, Qt::ControlModifier | Qt::ShiftModifier);
  ASSERT_TRUE(QTest::qWaitFor([&] { return fire->isEnabled(); }, 20000));
  QTest::keyClick(&w, Qt::Key_F, Qt::ControlModifier | Qt::ShiftModifier);
  ASSERT_TRUE(QTest::qWaitFor([&] { return w.lastShot() != nullptr; }, 20000));
  EXPECT_EQ(w.lastShot()->status, hw::ShotStatus::Ok);
  // The rig's state arrives before the shot: as soon as the shot shows,
  // Disarm answers (its chord was lost when pressed in between, in CI).
  auto* disarm = w.findChild<QPushButton*>("disarm_button");
  ASSERT_TRUE(disarm);
  EXPECT_TRUE(disarm->isEnabled());
  QTest::keyClick(&w, Qt::Key_D, Qt::ControlModifier | Qt::ShiftModifier);
  ASSERT_TRUE(QTest::qWaitFor([&] { return !w.rigPanel()->lastStatus().armed; }, 20000));
}

TEST(ViewerToolsGui, VendorFootageOpensInReplayAndCorruptFilesAreNamed) {
  application();
  const std::string dir = freshDir("footage");
  MainWindow w(windowOptions(sourcePath("config/sim.toml"), dir + "/shots"));
  w.resize(1366, 768);
  w.show();
  QString opened, error = "not yet";
  QObject::connect(&w, &MainWindow::recordingOpened, [&](QString path, QString e) {
    opened = path;
    error = e;
  });
  const QString cine = QString::fromStdString(sourcePath("tests/data/footage/cine_781.cine"));
  w.openRecording(cine);
  ASSERT_TRUE(QTest::qWaitFor([&] { return opened == cine; }, 30000));
  EXPECT_TRUE(error.isEmpty()) << error.toStdString();
  auto footage = vision::Footage::open(cine.toStdString());
  ASSERT_TRUE(footage);
  ASSERT_NE(w.replayView()->shot(), nullptr);
  EXPECT_EQ(w.replayView()->frameCount(), static_cast<int>(footage->info().frame_count));
  EXPECT_EQ(w.replayView()->imageView()->image().width(), footage->info().width);
  EXPECT_EQ(w.tabs()->currentWidget(), w.replayView());
  EXPECT_TRUE(screenshot(w.replayView(), "replay_footage"));
  // The tools on real footage: zoomed on the middle, a measurement, the crosshair.
  ImageView* image = w.replayView()->imageView();
  const QPointF middle(image->width() / 2.0, image->height() / 2.0);
  wheelAt(image, middle, 3);
  drag(image, middle - QPointF(120, 0), middle + QPointF(120, 60), Qt::RightButton);
  QTest::mouseClick(w.replayView()->findChild<QCheckBox*>("crosshair"), Qt::LeftButton);
  mouse(image, QEvent::MouseMove, middle + QPointF(-60, -80), Qt::NoButton, Qt::NoButton);
  EXPECT_TRUE(image->crosshair());
  EXPECT_FALSE(image->cursorText().isEmpty());
  EXPECT_TRUE(screenshot(w.replayView(), "replay_tools"));

  // A truncated camera file: the message names it; Replay keeps what it showed.
  const std::string bad = dir + "/truncated.cine";
  {
    std::ifstream in(cine.toStdString(), std::ios::binary);
    std::string head(200, '\0');
    in.read(head.data(), 200);
    std::ofstream(bad, std::ios::binary) << head;
  }
  opened.clear();
  w.openRecording(QString::fromStdString(bad));
  ASSERT_TRUE(QTest::qWaitFor([&] { return !opened.isEmpty(); }, 30000));
  EXPECT_FALSE(error.isEmpty());
  EXPECT_TRUE(w.messages().last().contains("truncated.cine")) << w.messages().last().toStdString();
  EXPECT_EQ(w.replayView()->frameCount(), static_cast<int>(footage->info().frame_count));
}

TEST(ViewerToolsGui, ANoteTypedInTheShotListIsKeptInTheShotFile) {
  application();
  const std::string dir = freshDir("notes");
  auto profile = hw::loadRigProfile(sourcePath("config/sim.toml"));
  ASSERT_TRUE(profile);
  auto rig = app::buildRig(*profile);
  ASSERT_TRUE(rig);
  hw::Shot fired = hw::Sequencer(*rig).fire(hw::ShotRequest::atSpeeds(2.0, 2.0));
  (void)hw::shutDown(*rig);
  fired.id = app::makeShotId(fired.wall_time_unix_ns, 1);
  auto id = app::saveShot(dir, fired);
  ASSERT_TRUE(id) << id.error().message;

  ShotBrowser browser;
  browser.resize(1300, 500);
  activate(&browser);
  browser.setFolder(QString::fromStdString(dir));
  auto* table = browser.findChild<QTableWidget*>("shot_table");
  ASSERT_TRUE(table);
  ASSERT_EQ(table->rowCount(), 1);
  const int note_column = table->columnCount() - 1;
  ASSERT_EQ(table->horizontalHeaderItem(note_column)->text(), "note");
  QString saved_id, saved_error = "not yet";
  QObject::connect(&browser, &ShotBrowser::noteSaved, [&](QString i, QString e) {
    saved_id = i;
    saved_error = e;
  });
  // Click the note cell, F2, type, Enter: as a user writes a note.
  QTableWidgetItem* cell = table->item(0, note_column);
  table->scrollToItem(cell);
  QTest::mouseClick(table->viewport(), Qt::LeftButton, {}, table->visualItemRect(cell).center());
  QTest::keyClick(table, Qt::Key_F2);
  QWidget* editor = QApplication::focusWidget();
  ASSERT_NE(editor, table) << "F2 opened no editor";
  QTest::keyClicks(editor, "new lamp; sphere 2 scuffed");
  QTest::keyClick(editor, Qt::Key_Return);
  ASSERT_TRUE(QTest::qWaitFor([&] { return !saved_id.isEmpty(); }, 10000));
  EXPECT_TRUE(saved_error.isEmpty()) << saved_error.toStdString();
  auto read = app::readShot(dir + "/" + app::shotFileName(*id), {.frames = false});
  ASSERT_TRUE(read);
  EXPECT_EQ(read->note, "new lamp; sphere 2 scuffed");
  ASSERT_EQ(browser.rows().size(), 1u);
  EXPECT_EQ(browser.rows()[0].note, "new lamp; sphere 2 scuffed");
  EXPECT_EQ(table->item(0, note_column)->text(), "new lamp; sphere 2 scuffed");
  // Other columns are not editable: F2 on the shot id opens nothing.
  QTest::mouseClick(table->viewport(), Qt::LeftButton, {},
                    table->visualItemRect(table->item(0, 0)).center());
  QTest::keyClick(table, Qt::Key_F2);
  EXPECT_EQ(QApplication::focusWidget(), table);
  EXPECT_TRUE(screenshot(&browser, "shots_note"));
}
