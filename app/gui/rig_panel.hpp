#pragma once
// The rig panel: the loaded profile (backend, device and state of each
// device), per launcher the wanted exit speed and the pressure setpoint linked
// both ways through the launch calibration (drawn beside them) with the
// regulator's read-back, the burst settings, the safety limits, and arm /
// disarm / fire / cancel. Fire is enabled only when armed, settled and idle.
// The settings scroll; the action bar below them (Arm / Disarm / Fire /
// Cancel, the armed-settled state, what to do next and where shots go) never
// does, so it is on screen at any window size. Set-points change only on
// purpose: the wheel only in a focused field, typed values out of range are
// refused with the range, and a new setpoint while armed waits for "Apply"
// and a confirmation. A lost device (it stopped answering) shows as "lost"
// with what happened and what to check; Arm and Fire stay off until Reconnect
// finds every device again. The panel never touches a device: it asks
// through signals.
#include <QWidget>
#include <array>

#include "app/gui/rig_worker.hpp"

class QLabel;
class QPushButton;
class QTableWidget;
class QGroupBox;
class QFrame;
class QVBoxLayout;
class QChartView;
class QLineSeries;
class QScatterSeries;
class QValueAxis;

namespace collide::gui {

class GuardedDoubleSpinBox;
class GuardedSpinBox;

struct BurstSettings {
  int pre_trigger_frames = 0;
  int post_trigger_frames = 0;
  double fps = 0;
  double exposure_us = 0;
};

class RigPanel : public QWidget {
  Q_OBJECT
 public:
  explicit RigPanel(QWidget* parent = nullptr);

  void setProfile(ProfilePtr profile);
  void setStatus(const RigStatus& status);
  void setStep(const QString& step);

  std::array<double, 2> wantedSpeeds() const;
  /// Sets launcher i's wanted speed (m/s); its pressure follows.
  void setWantedSpeed(int launcher, double speed_m_s);
  const RigStatus& lastStatus() const { return status_; }
  /// Shown in the action bar ("shots go to ..."); `created`: the folder is new.
  void setShotsDir(const QString& dir, bool usable, bool created = false);
  /// True while a setpoint edited when armed waits for Apply.
  bool setpointPending() const { return pending_; }
  /// A Reconnect asked for with reconnectRequested finished (the worker's
  /// reconnectFinished; the window's message bar shows `message`): a failed
  /// one is noted under the lost devices.
  void reconnectFinished(bool ok, const QString& message);

 protected:
  /// Keeps the action bar's messages whole: its height follows its width.
  bool eventFilter(QObject* watched, QEvent* event) override;

 signals:
  void armRequested(std::array<double, 2> speed_m_s);
  void disarmRequested();
  void fireRequested(std::array<double, 2> speed_m_s);
  void cancelRequested();
  /// Look for the lost devices again (enabled only while one is lost).
  void reconnectRequested();
  void burstSettingsRequested(collide::gui::BurstSettings settings);
  /// A typed value was refused (the message says which and the allowed range).
  void inputRefused(QString message);

 private:
  // The constructor's parts, top to bottom.
  void addProfileBox(QVBoxLayout* layout);
  void addLaunchers(QVBoxLayout* layout);
  void addCalibrationChart(QVBoxLayout* layout);
  void addBurstBox(QVBoxLayout* layout);
  void addSafetyBox(QVBoxLayout* layout);
  QFrame* makeActionBar();
  void addSetpointRow(QVBoxLayout* al);
  void addActionButtons(QVBoxLayout* al);
  void addStateLabels(QVBoxLayout* al);

  void speedEdited(int i);
  void pressureEdited(int i);
  void updateButtons();
  void updateCurveMarkers();
  void setpointEdited();
  void confirmSetpoint();
  void updateBurstPending();
  void updateHint();
  void showLost();
  void fitActionBar();

  ProfilePtr profile_;
  RigStatus status_;
  QLabel* profile_label_ = nullptr;
  QTableWidget* devices_ = nullptr;
  std::array<QGroupBox*, 2> launcher_box_{};
  std::array<GuardedDoubleSpinBox*, 2> speed_{};
  std::array<GuardedDoubleSpinBox*, 2> pressure_{};
  std::array<QLabel*, 2> readback_{};
  QChartView* curve_view_ = nullptr;
  QLineSeries* curve_ = nullptr;
  QScatterSeries* setpoints_ = nullptr;
  QValueAxis* curve_x_ = nullptr;
  QValueAxis* curve_y_ = nullptr;
  GuardedSpinBox* pre_ = nullptr;
  GuardedSpinBox* post_ = nullptr;
  GuardedDoubleSpinBox* fps_ = nullptr;
  GuardedDoubleSpinBox* exposure_ = nullptr;
  QPushButton* apply_burst_ = nullptr;
  QLabel* burst_pending_ = nullptr;
  QPushButton* apply_setpoint_ = nullptr;
  QLabel* setpoint_pending_ = nullptr;
  QLabel* hint_ = nullptr;
  QLabel* shots_dir_ = nullptr;
  QLabel* safety_ = nullptr;
  QPushButton* arm_ = nullptr;
  QPushButton* disarm_ = nullptr;
  QPushButton* fire_ = nullptr;
  QPushButton* cancel_ = nullptr;
  QPushButton* reconnect_ = nullptr;
  QFrame* action_bar_ = nullptr;
  QLabel* lost_ = nullptr;      ///< every lost device's message, and the last Reconnect's result
  QString reconnect_result_;    ///< when the last Reconnect failed (empty: it did not)
  QString arm_tip_, fire_tip_;  ///< their tooltips when nothing is lost
  bool reconnecting_ = false;
  QLabel* state_ = nullptr;
  QLabel* step_ = nullptr;
  bool linking_ = false;
  bool pending_ = false;  ///< a setpoint edited while armed, not yet applied
  bool shots_usable_ = true;
};

}  // namespace collide::gui

Q_DECLARE_METATYPE(collide::gui::BurstSettings)
