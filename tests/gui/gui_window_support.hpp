#pragma once
// Shared by the GUI tests that drive the main window: finding its widgets,
// typing into spin boxes as a user does, and a window on a given profile and
// shot folder that has brought its rig up.
#include <QAbstractSpinBox>
#include <QLineEdit>
#include <QTest>
#include <QWheelEvent>
#include <QWindow>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "app/gui/main_window.hpp"
#include "app/gui/rig_panel.hpp"

namespace collide::gui::testing {

/// The child of `parent` named `name`; throws (failing the test) if none.
template <class T>
T* child(QWidget* parent, const char* name) {
  T* w = parent->findChild<T*>(name);
  if (!w) throw std::runtime_error(std::string("no widget named ") + name);
  return w;
}

/// Types `text` into a spin box as a user would: click into it, select all, type, Enter.
inline void typeInto(QAbstractSpinBox* box, const QString& text) {
  QTest::mouseClick(box->findChild<QLineEdit*>(), Qt::LeftButton);
  QTest::keyClick(box, Qt::Key_A, Qt::ControlModifier);
  QTest::keyClicks(box, text);
  QTest::keyClick(box, Qt::Key_Return);
  QApplication::processEvents();
}

/// Shows `w`, makes it the active window and gives it the keyboard focus, so
/// that key events reach it as a user's would.
inline void activate(QWidget* w) {
  w->show();
  QApplication::setActiveWindow(w);
  w->activateWindow();
  (void)QTest::qWaitForWindowActive(w, 2000);
  w->setFocus();
  QApplication::processEvents();
}

/// Wheel notches over `widget` (120 each; positive up, negative down), as
/// delivered to it by the platform.
inline void wheel(QWidget* widget, int notches) {
  for (int k = 0; k < std::abs(notches); ++k) {
    const QPointF at = widget->rect().center();
    QWheelEvent e(at, widget->mapToGlobal(at), QPoint(), QPoint(0, notches > 0 ? 120 : -120),
                  Qt::NoButton, Qt::NoModifier, Qt::NoScrollPhase, false);
    QApplication::sendEvent(widget, &e);
  }
  QApplication::processEvents();
}

/// The centre of `widget` in its window's coordinates.
inline QPoint centreInWindow(QWidget* widget) {
  return widget->mapTo(widget->window(), widget->rect().center());
}

/// A left click where `widget` is on screen, delivered to the window as the
/// platform would: it reaches `widget` only if nothing covers it there.
inline void clickThroughWindow(QWidget* widget) {
  QTest::mouseClick(widget->window()->windowHandle(), Qt::LeftButton, {}, centreInWindow(widget));
}

/// Options for a window on `profile` saving into `shots`, without QSettings.
inline MainWindowOptions windowOptions(const std::string& profile, const std::string& shots) {
  MainWindowOptions o;
  o.rig_profile = QString::fromStdString(profile);
  o.shots_dir = QString::fromStdString(shots);
  o.restore_settings = false;
  return o;
}

/// Waits (up to 20 s) until the window's profile is loaded and its
/// regulator, valves and camera run.
inline bool waitUntilRigRunning(MainWindow& w) {
  return QTest::qWaitFor(
      [&] {
        const RigStatus& s = w.rigPanel()->lastStatus();
        return w.profile() != nullptr && s.state[0] == "running" && s.state[1] == "running" &&
               s.state[2] == "running";
      },
      20000);
}

}  // namespace collide::gui::testing
