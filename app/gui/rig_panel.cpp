#include "app/gui/rig_panel.hpp"

#include <QChart>
#include <QChartView>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLineSeries>
#include <QPushButton>
#include <QScatterSeries>
#include <QSpinBox>
#include <QTableWidget>
#include <QVBoxLayout>
#include <QValueAxis>
#include <algorithm>

namespace collide::gui {
namespace {

QString qs(const std::string& s) {
  return QString::fromStdString(s);
}

}  // namespace

RigPanel::RigPanel(QWidget* parent) : QWidget(parent) {
  auto* layout = new QVBoxLayout(this);

  auto* profile_box = new QGroupBox(tr("Rig profile"));
  auto* pl = new QVBoxLayout(profile_box);
  profile_label_ = new QLabel(tr("no profile loaded"));
  profile_label_->setWordWrap(true);
  profile_label_->setObjectName("profile_label");
  pl->addWidget(profile_label_);
  devices_ = new QTableWidget(3, 3);
  devices_->setObjectName("device_table");
  devices_->setHorizontalHeaderLabels({tr("backend"), tr("device"), tr("state")});
  devices_->setVerticalHeaderLabels({tr("regulator"), tr("valves"), tr("camera")});
  devices_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  devices_->horizontalHeader()->setStretchLastSection(true);
  devices_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  devices_->setMaximumHeight(devices_->verticalHeader()->length() +
                             devices_->horizontalHeader()->height() + 6);
  pl->addWidget(devices_);
  layout->addWidget(profile_box);

  auto* launch_row = new QHBoxLayout;
  for (int i = 0; i < 2; ++i) {
    launcher_box_[i] = new QGroupBox(tr("Launcher %1").arg(i + 1));
    auto* form = new QFormLayout(launcher_box_[i]);
    speed_[i] = new QDoubleSpinBox;
    speed_[i]->setObjectName(QString("speed_%1").arg(i));
    speed_[i]->setDecimals(3);
    speed_[i]->setSingleStep(0.05);
    speed_[i]->setSuffix(" m/s");
    speed_[i]->setKeyboardTracking(false);
    pressure_[i] = new QDoubleSpinBox;
    pressure_[i]->setObjectName(QString("pressure_%1").arg(i));
    pressure_[i]->setDecimals(2);
    pressure_[i]->setSingleStep(1.0);
    pressure_[i]->setSuffix(" kPa");
    pressure_[i]->setKeyboardTracking(false);
    readback_[i] = new QLabel("-");
    readback_[i]->setObjectName(QString("readback_%1").arg(i));
    form->addRow(tr("exit speed"), speed_[i]);
    form->addRow(tr("setpoint"), pressure_[i]);
    form->addRow(tr("read-back"), readback_[i]);
    connect(speed_[i], &QDoubleSpinBox::valueChanged, this, [this, i] { speedEdited(i); });
    connect(pressure_[i], &QDoubleSpinBox::valueChanged, this, [this, i] { pressureEdited(i); });
    launch_row->addWidget(launcher_box_[i]);
  }
  layout->addLayout(launch_row);

  // The launch calibration v(p), with the two setpoints on it.
  auto* chart = new QChart;
  chart->legend()->hide();
  chart->setMargins(QMargins(2, 2, 2, 2));
  curve_ = new QLineSeries;
  setpoints_ = new QScatterSeries;
  setpoints_->setMarkerSize(8);
  chart->addSeries(curve_);
  chart->addSeries(setpoints_);
  curve_x_ = new QValueAxis;
  curve_x_->setTitleText(tr("pressure (kPa)"));
  curve_y_ = new QValueAxis;
  curve_y_->setTitleText(tr("exit speed (m/s)"));
  chart->addAxis(curve_x_, Qt::AlignBottom);
  chart->addAxis(curve_y_, Qt::AlignLeft);
  for (auto* s : {static_cast<QXYSeries*>(curve_), static_cast<QXYSeries*>(setpoints_)}) {
    s->attachAxis(curve_x_);
    s->attachAxis(curve_y_);
  }
  curve_view_ = new QChartView(chart);
  curve_view_->setObjectName("calibration_curve");
  curve_view_->setRenderHint(QPainter::Antialiasing);
  curve_view_->setMinimumHeight(170);
  layout->addWidget(curve_view_);

  auto* burst_box = new QGroupBox(tr("Burst"));
  auto* bf = new QFormLayout(burst_box);
  pre_ = new QSpinBox;
  pre_->setObjectName("pre_trigger_frames");
  pre_->setRange(0, 100000);
  post_ = new QSpinBox;
  post_->setObjectName("post_trigger_frames");
  post_->setRange(1, 100000);
  fps_ = new QDoubleSpinBox;
  fps_->setObjectName("fps");
  fps_->setRange(1, 1e6);
  fps_->setDecimals(1);
  fps_->setSuffix(" frames/s");
  exposure_ = new QDoubleSpinBox;
  exposure_->setObjectName("exposure_us");
  exposure_->setRange(1, 1e7);
  exposure_->setDecimals(1);
  exposure_->setSuffix(" us");
  apply_burst_ = new QPushButton(tr("Apply burst settings"));
  apply_burst_->setObjectName("apply_burst");
  bf->addRow(tr("pre-trigger frames"), pre_);
  bf->addRow(tr("post-trigger frames"), post_);
  bf->addRow(tr("frame rate"), fps_);
  bf->addRow(tr("exposure"), exposure_);
  bf->addRow(apply_burst_);
  connect(apply_burst_, &QPushButton::clicked, this, [this] {
    emit burstSettingsRequested(
        BurstSettings{pre_->value(), post_->value(), fps_->value(), exposure_->value()});
  });
  layout->addWidget(burst_box);

  auto* safety_box = new QGroupBox(tr("Safety limits (from the profile)"));
  auto* sl = new QVBoxLayout(safety_box);
  safety_ = new QLabel("-");
  safety_->setObjectName("safety_limits");
  safety_->setWordWrap(true);
  sl->addWidget(safety_);
  layout->addWidget(safety_box);

  auto* buttons = new QHBoxLayout;
  arm_ = new QPushButton(tr("Arm"));
  arm_->setObjectName("arm_button");
  disarm_ = new QPushButton(tr("Disarm"));
  disarm_->setObjectName("disarm_button");
  fire_ = new QPushButton(tr("Fire"));
  fire_->setObjectName("fire_button");
  fire_->setStyleSheet(
      "QPushButton:enabled { background: #c0392b; color: white; font-weight: bold; }");
  cancel_ = new QPushButton(tr("Cancel"));
  cancel_->setObjectName("cancel_button");
  for (auto* b : {arm_, disarm_, fire_, cancel_}) {
    b->setMinimumWidth(60);
    b->setSizePolicy(QSizePolicy::Preferred, QSizePolicy::Fixed);
    buttons->addWidget(b);
  }
  layout->addLayout(buttons);
  connect(arm_, &QPushButton::clicked, this, [this] { emit armRequested(wantedSpeeds()); });
  connect(disarm_, &QPushButton::clicked, this, [this] { emit disarmRequested(); });
  connect(fire_, &QPushButton::clicked, this, [this] {
    fire_->setEnabled(false);  // until the worker reports back
    emit fireRequested(wantedSpeeds());
  });
  connect(cancel_, &QPushButton::clicked, this, [this] { emit cancelRequested(); });

  state_ = new QLabel(tr("disarmed"));
  state_->setObjectName("arm_state");
  step_ = new QLabel;
  step_->setObjectName("step_label");
  layout->addWidget(state_);
  layout->addWidget(step_);
  layout->addStretch();
  updateButtons();
}

void RigPanel::setProfile(ProfilePtr profile) {
  const bool had_profile = profile_ != nullptr;
  const std::array<double, 2> previous = wantedSpeeds();
  profile_ = std::move(profile);
  if (!profile_) return;
  const hw::RigProfile& p = *profile_;
  profile_label_->setText(tr("<b>%1</b> (%2)<br>%3, %4 mm spheres")
                              .arg(qs(p.name), qs(p.source), qs(p.spheres.material_name))
                              .arg(p.spheres.diameter_m[0] * 1000, 0, 'g', 4));
  auto curve = p.calibration.curve();
  // Safety: only pressures inside both the calibration and the regulator's
  // working limits (already capped at safety.max_pressure_kpa) can be set.
  const double p_lo = std::max(p.calibration.min_kPa, p.regulator_config.min_kPa);
  const double p_hi = std::min(p.calibration.max_kPa, p.regulator_config.max_kPa);
  linking_ = true;
  for (int i = 0; i < 2; ++i) {
    launcher_box_[i]->setTitle(tr("Launcher %1 (%2)").arg(i + 1).arg(qs(p.launchers[i].name)));
    pressure_[i]->setRange(p_lo, p_hi);
    if (curve) speed_[i]->setRange(curve->speed_m_s(p_lo), curve->speed_m_s(p_hi));
  }
  linking_ = false;
  // Keep the speeds asked for so far (a reload after new burst settings must
  // not change them); 2 m/s on the first profile.
  for (int i = 0; i < 2; ++i)
    setWantedSpeed(
        i, std::clamp(had_profile ? previous[i] : 2.0, speed_[i]->minimum(), speed_[i]->maximum()));

  curve_->clear();
  if (curve) {
    for (int k = 0; k <= 60; ++k) {
      const double pk =
          p.calibration.min_kPa + (p.calibration.max_kPa - p.calibration.min_kPa) * k / 60.0;
      curve_->append(pk, curve->speed_m_s(pk));
    }
    curve_x_->setRange(p.calibration.min_kPa, p.calibration.max_kPa);
    curve_y_->setRange(0, curve->maxSpeed_m_s() * 1.05);
  }
  updateCurveMarkers();

  pre_->setValue(p.burst.pre_trigger_frames);
  post_->setValue(p.burst.post_trigger_frames);
  fps_->setValue(p.camera_config.fps);
  exposure_->setValue(p.camera_config.exposure_us);

  safety_->setText(tr("pressure %1..%2 kPa (regulator limits; safety maximum %3 kPa); valve pulse "
                      "%4 us (maximum %5 us); %6")
                       .arg(p.regulator_config.min_kPa)
                       .arg(p.regulator_config.max_kPa)
                       .arg(p.safety.max_pressure_kPa)
                       .arg(p.sequencer.pulse_us)
                       .arg(p.safety.max_valve_pulse_us)
                       .arg(p.safety.vent_on_failure ? tr("lines vented to 0 kPa when a shot fails")
                                                     : tr("pressure kept when a shot fails")));
  updateButtons();
}

void RigPanel::setStatus(const RigStatus& s) {
  status_ = s;
  for (int r = 0; r < 3; ++r) {
    const QString cells[3] = {s.backend[r], s.device[r], s.state[r]};
    for (int c = 0; c < 3; ++c) {
      auto* item = devices_->item(r, c);
      if (!item) devices_->setItem(r, c, item = new QTableWidgetItem);
      item->setText(cells[c]);
      if (c == 2)
        item->setForeground(s.state[r] == "running" ? QColor(20, 130, 40) : QColor(170, 40, 30));
    }
  }
  for (int i = 0; i < 2; ++i)
    readback_[i]->setText(
        tr("%1 kPa (set %2)").arg(s.readback_kPa[i], 0, 'f', 2).arg(s.setpoint_kPa[i], 0, 'f', 2));
  state_->setText(s.busy      ? tr("<b>busy</b>: firing")
                  : !s.armed  ? tr("disarmed")
                  : s.settled ? tr("<b>armed and settled</b>: ready to fire")
                              : tr("<b>armed</b>: pressures settling"));
  updateButtons();
}

void RigPanel::setStep(const QString& step) {
  step_->setText(step);
}

std::array<double, 2> RigPanel::wantedSpeeds() const {
  return {speed_[0]->value(), speed_[1]->value()};
}

void RigPanel::setWantedSpeed(int i, double v) {
  speed_[i]->setValue(v);
  speedEdited(i);
}

void RigPanel::speedEdited(int i) {
  if (linking_ || !profile_) return;
  auto curve = profile_->calibration.curve();
  if (!curve) return;
  auto p = curve->pressure_kPa(speed_[i]->value());
  if (!p) return;
  linking_ = true;
  pressure_[i]->setValue(*p);
  linking_ = false;
  updateCurveMarkers();
  if (status_.armed && !status_.busy) emit armRequested(wantedSpeeds());  // follow the new setpoint
}

void RigPanel::pressureEdited(int i) {
  if (linking_ || !profile_) return;
  auto curve = profile_->calibration.curve();
  if (!curve) return;
  linking_ = true;
  speed_[i]->setValue(curve->speed_m_s(pressure_[i]->value()));
  linking_ = false;
  updateCurveMarkers();
  if (status_.armed && !status_.busy) emit armRequested(wantedSpeeds());
}

void RigPanel::updateCurveMarkers() {
  setpoints_->clear();
  for (int i = 0; i < 2; ++i) setpoints_->append(pressure_[i]->value(), speed_[i]->value());
}

void RigPanel::updateButtons() {
  const bool loaded = profile_ != nullptr;
  const bool busy = status_.busy;
  arm_->setEnabled(loaded && !busy);
  disarm_->setEnabled(loaded && !busy && status_.armed);
  fire_->setEnabled(loaded && !busy && status_.armed && status_.settled);
  cancel_->setEnabled(busy);
  apply_burst_->setEnabled(loaded && !busy);
  for (int i = 0; i < 2; ++i) {
    speed_[i]->setEnabled(loaded && !busy);
    pressure_[i]->setEnabled(loaded && !busy);
  }
}

}  // namespace collide::gui
