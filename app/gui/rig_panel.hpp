#pragma once
// The rig panel: the loaded profile (backend, device and state of each
// device), per launcher the wanted exit speed and the pressure setpoint linked
// both ways through the launch calibration (drawn beside them) with the
// regulator's read-back, the burst settings, the safety limits, and arm /
// disarm / fire / cancel. Fire is enabled only when armed, settled and idle.
// The panel never touches a device: it asks through signals.
#include <QWidget>
#include <array>

#include "app/gui/rig_worker.hpp"

class QDoubleSpinBox;
class QSpinBox;
class QLabel;
class QPushButton;
class QTableWidget;
class QGroupBox;
class QChartView;
class QLineSeries;
class QScatterSeries;
class QValueAxis;

namespace collide::gui {

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

 signals:
  void armRequested(std::array<double, 2> speed_m_s);
  void disarmRequested();
  void fireRequested(std::array<double, 2> speed_m_s);
  void cancelRequested();
  void burstSettingsRequested(collide::gui::BurstSettings settings);

 private:
  void speedEdited(int i);
  void pressureEdited(int i);
  void updateButtons();
  void updateCurveMarkers();

  ProfilePtr profile_;
  RigStatus status_;
  QLabel* profile_label_ = nullptr;
  QTableWidget* devices_ = nullptr;
  std::array<QGroupBox*, 2> launcher_box_{};
  std::array<QDoubleSpinBox*, 2> speed_{};
  std::array<QDoubleSpinBox*, 2> pressure_{};
  std::array<QLabel*, 2> readback_{};
  QChartView* curve_view_ = nullptr;
  QLineSeries* curve_ = nullptr;
  QScatterSeries* setpoints_ = nullptr;
  QValueAxis* curve_x_ = nullptr;
  QValueAxis* curve_y_ = nullptr;
  QSpinBox* pre_ = nullptr;
  QSpinBox* post_ = nullptr;
  QDoubleSpinBox* fps_ = nullptr;
  QDoubleSpinBox* exposure_ = nullptr;
  QPushButton* apply_burst_ = nullptr;
  QLabel* safety_ = nullptr;
  QPushButton* arm_ = nullptr;
  QPushButton* disarm_ = nullptr;
  QPushButton* fire_ = nullptr;
  QPushButton* cancel_ = nullptr;
  QLabel* state_ = nullptr;
  QLabel* step_ = nullptr;
  bool linking_ = false;
};

}  // namespace collide::gui

Q_DECLARE_METATYPE(collide::gui::BurstSettings)
