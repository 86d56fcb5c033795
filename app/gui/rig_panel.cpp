#include "app/gui/rig_panel.hpp"

#include <QChart>
#include <QChartView>
#include <QDoubleSpinBox>
#include <QEvent>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLineSeries>
#include <QMessageBox>
#include <QPushButton>
#include <QScatterSeries>
#include <QScrollArea>
#include <QTableWidget>
#include <QTime>
#include <QVBoxLayout>
#include <QValueAxis>
#include <algorithm>
#include <cmath>

#include "app/gui/guarded_spin_box.hpp"
#include "hw/device_health.hpp"

namespace collide::gui {
namespace {

QString qs(const std::string& s) {
  return QString::fromStdString(s);
}

}  // namespace

RigPanel::RigPanel(QWidget* parent) : QWidget(parent) {
  setObjectName("rig_panel");
  auto* outer = new QVBoxLayout(this);
  outer->setContentsMargins(0, 0, 0, 0);
  // The settings scroll (down only: the panel fits its dock's width) ...
  auto* scroll = new QScrollArea;
  scroll->setObjectName("rig_settings_scroll");
  scroll->setWidgetResizable(true);
  scroll->setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  scroll->setFrameShape(QFrame::NoFrame);
  auto* settings = new QWidget;
  auto* layout = new QVBoxLayout(settings);
  scroll->setWidget(settings);
  outer->addWidget(scroll, 1);
  addProfileBox(layout);
  addLaunchers(layout);
  addCalibrationChart(layout);
  addBurstBox(layout);
  addSafetyBox(layout);
  layout->addStretch();
  // ... the action bar does not: always on screen.
  outer->addWidget(makeActionBar());
  updateButtons();
}

// The profile's name and its devices' table.
void RigPanel::addProfileBox(QVBoxLayout* layout) {
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
}

// Each launcher's exit speed and pressure setpoint (either sets the other
// through the calibration) and the regulator's read-back.
void RigPanel::addLaunchers(QVBoxLayout* layout) {
  auto* launch_row = new QHBoxLayout;
  for (int i = 0; i < 2; ++i) {
    launcher_box_[i] = new QGroupBox(tr("Launcher %1").arg(i + 1));
    auto* form = new QFormLayout(launcher_box_[i]);
    speed_[i] = new GuardedDoubleSpinBox;
    speed_[i]->setObjectName(QString("speed_%1").arg(i));
    speed_[i]->setDecimals(3);
    speed_[i]->setSingleStep(0.05);
    speed_[i]->setSuffix(" m/s");
    pressure_[i] = new GuardedDoubleSpinBox;
    pressure_[i]->setObjectName(QString("pressure_%1").arg(i));
    pressure_[i]->setDecimals(2);
    pressure_[i]->setSingleStep(1.0);
    pressure_[i]->setSuffix(" kPa");
    for (auto* box : {speed_[i], pressure_[i]})
      connect(box, &GuardedDoubleSpinBox::refused, this,
              [this, i, box](double typed, double lo, double hi) {
                const QString unit = box->suffix().trimmed();
                emit inputRefused(
                    tr("Launcher %1: %2 %3 refused, the value stays %4 %3. Allowed: %5 to %6 %3 "
                       "(the calibration's working range within the regulator's limits).")
                        .arg(i + 1)
                        .arg(typed)
                        .arg(unit)
                        .arg(box->value(), 0, 'f', box->decimals())
                        .arg(lo, 0, 'f', box->decimals())
                        .arg(hi, 0, 'f', box->decimals()));
              });
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
}

void RigPanel::addCalibrationChart(QVBoxLayout* layout) {
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
  curve_x_->setTitleText(tr("pressure p (kPa)"));
  curve_y_ = new QValueAxis;
  curve_y_->setTitleText(tr("v (m/s)"));  // fits the chart's height
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
}

// The burst's frames, frame rate and exposure, applied together.
void RigPanel::addBurstBox(QVBoxLayout* layout) {
  auto* burst_box = new QGroupBox(tr("Burst"));
  auto* bf = new QFormLayout(burst_box);
  pre_ = new GuardedSpinBox;
  pre_->setObjectName("pre_trigger_frames");
  pre_->setRangeWithTip(0, 100000, tr("Frames kept before the trigger"), tr("frames"));
  post_ = new GuardedSpinBox;
  post_->setObjectName("post_trigger_frames");
  post_->setRangeWithTip(1, 100000, tr("Frames recorded from the trigger on"), tr("frames"));
  fps_ = new GuardedDoubleSpinBox;
  fps_->setObjectName("fps");
  fps_->setDecimals(1);
  fps_->setSuffix(" frames/s");
  fps_->setRangeWithTip(1, 1e6, tr("Camera frame rate"), tr("frames/s"),
                        tr("the camera may refuse rates it cannot reach"));
  exposure_ = new GuardedDoubleSpinBox;
  exposure_->setObjectName("exposure_us");
  exposure_->setDecimals(1);
  exposure_->setSuffix(" us");
  exposure_->setRangeWithTip(1, 1e7, tr("Exposure time"), tr("us"),
                             tr("at most one frame interval"));
  apply_burst_ = new QPushButton(tr("Apply burst settings"));
  apply_burst_->setObjectName("apply_burst");
  burst_pending_ = new QLabel;
  burst_pending_->setObjectName("burst_pending");
  burst_pending_->setStyleSheet("color: #a05a00;");
  burst_pending_->setWordWrap(true);
  bf->addRow(tr("pre-trigger frames"), pre_);
  bf->addRow(tr("post-trigger frames"), post_);
  bf->addRow(tr("frame rate"), fps_);
  bf->addRow(tr("exposure"), exposure_);
  bf->addRow(apply_burst_);
  bf->addRow(burst_pending_);
  connect(pre_, &QSpinBox::valueChanged, this, &RigPanel::updateBurstPending);
  connect(post_, &QSpinBox::valueChanged, this, &RigPanel::updateBurstPending);
  connect(fps_, &QDoubleSpinBox::valueChanged, this, &RigPanel::updateBurstPending);
  connect(exposure_, &QDoubleSpinBox::valueChanged, this, &RigPanel::updateBurstPending);
  for (GuardedSpinBox* box : {pre_, post_})
    connect(box, &GuardedSpinBox::refused, this, [this, box](double typed, double lo, double hi) {
      emit inputRefused(tr("%1 refused for %2: allowed %3 to %4; the value stays %5.")
                            .arg(typed)
                            .arg(box->objectName().replace('_', ' '))
                            .arg(lo)
                            .arg(hi)
                            .arg(box->value()));
    });
  for (GuardedDoubleSpinBox* box : {fps_, exposure_})
    connect(box, &GuardedDoubleSpinBox::refused, this,
            [this, box](double typed, double lo, double hi) {
              emit inputRefused(tr("%1%2 refused: allowed %3 to %4%2; the value stays %5%2.")
                                    .arg(typed)
                                    .arg(box->suffix())
                                    .arg(lo)
                                    .arg(hi)
                                    .arg(box->value()));
            });
  connect(apply_burst_, &QPushButton::clicked, this, [this] {
    emit burstSettingsRequested(
        BurstSettings{pre_->value(), post_->value(), fps_->value(), exposure_->value()});
  });
  layout->addWidget(burst_box);
}

void RigPanel::addSafetyBox(QVBoxLayout* layout) {
  auto* safety_box = new QGroupBox(tr("Safety limits (from the profile)"));
  auto* sl = new QVBoxLayout(safety_box);
  safety_ = new QLabel("-");
  safety_->setObjectName("safety_limits");
  safety_->setWordWrap(true);
  sl->addWidget(safety_);
  layout->addWidget(safety_box);
}

// The action bar: a pending setpoint, the buttons, the state and what to do next.
QFrame* RigPanel::makeActionBar() {
  auto* bar = new QFrame;
  action_bar_ = bar;
  bar->installEventFilter(this);
  bar->setObjectName("action_bar");
  bar->setFrameShape(QFrame::StyledPanel);
  auto* al = new QVBoxLayout(bar);
  al->setContentsMargins(6, 4, 6, 4);
  al->setSpacing(3);
  addSetpointRow(al);
  addActionButtons(al);
  addStateLabels(al);
  return bar;
}

// An edited setpoint while armed, waiting for its confirmation.
void RigPanel::addSetpointRow(QVBoxLayout* al) {
  auto* pending_row = new QHBoxLayout;
  setpoint_pending_ = new QLabel;
  setpoint_pending_->setObjectName("setpoint_pending");
  setpoint_pending_->setWordWrap(true);
  setpoint_pending_->setStyleSheet("color: #a05a00;");
  apply_setpoint_ = new QPushButton(tr("Apply new setpoint..."));
  apply_setpoint_->setObjectName("apply_setpoint");
  apply_setpoint_->setToolTip(
      tr("Sends the edited setpoints to the armed regulator after a "
         "confirmation."));
  pending_row->addWidget(setpoint_pending_, 1);
  pending_row->addWidget(apply_setpoint_);
  al->addLayout(pending_row);
  setpoint_pending_->hide();
  apply_setpoint_->hide();
  connect(apply_setpoint_, &QPushButton::clicked, this, &RigPanel::confirmSetpoint);
}

void RigPanel::addActionButtons(QVBoxLayout* al) {
  auto* buttons = new QHBoxLayout;
  arm_ = new QPushButton(tr("Arm"));
  arm_->setObjectName("arm_button");
  arm_->setToolTip(tr("Pressurise both lines to the setpoints shown above."));
  disarm_ = new QPushButton(tr("Disarm"));
  disarm_->setObjectName("disarm_button");
  disarm_->setToolTip(tr("Vent both lines to 0 kPa and close the valves."));
  fire_ = new QPushButton(tr("Fire"));
  fire_->setObjectName("fire_button");
  fire_->setToolTip(
      tr("Open both valves and record the burst (enabled when armed and "
         "settled)."));
  fire_->setStyleSheet(
      "QPushButton:enabled { background: #c0392b; color: white; font-weight: bold; }");
  cancel_ = new QPushButton(tr("Cancel"));
  cancel_->setObjectName("cancel_button");
  cancel_->setToolTip(tr("Stop the running shot or campaign between steps."));
  reconnect_ = new QPushButton(tr("Reconnect"));
  reconnect_->setObjectName("reconnect_button");
  reconnect_->setToolTip(
      tr("Look for the lost devices again: each is closed, reopened and asked to answer "
         "(enabled while a device is lost)."));
  // Keyboard: two-hand chords for what pressurises or fires, Escape for what
  // stops. A button's shortcut acts only while the button is enabled, so Fire
  // by key needs the same armed-and-settled state as by mouse.
  arm_->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_A));
  disarm_->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_D));
  fire_->setShortcut(QKeySequence(Qt::CTRL | Qt::SHIFT | Qt::Key_F));
  cancel_->setShortcut(QKeySequence(Qt::Key_Escape));
  for (auto* b : {arm_, disarm_, fire_, cancel_, reconnect_}) {
    if (!b->shortcut().isEmpty())
      b->setToolTip(b->toolTip() + "  (" + b->shortcut().toString(QKeySequence::NativeText) + ")");
    b->setMinimumWidth(60);
    b->setSizePolicy(QSizePolicy::Preferred, QSizePolicy::Fixed);
    buttons->addWidget(b);
  }
  arm_tip_ = arm_->toolTip();
  fire_tip_ = fire_->toolTip();
  al->addLayout(buttons);
  connect(arm_, &QPushButton::clicked, this, [this] {
    // Armed with an edited setpoint, Arm changes the pressure like Apply: it
    // asks first.
    if (pending_ && status_.armed) {
      confirmSetpoint();
      return;
    }
    emit armRequested(wantedSpeeds());
  });
  connect(disarm_, &QPushButton::clicked, this, [this] { emit disarmRequested(); });
  connect(fire_, &QPushButton::clicked, this, [this] {
    fire_->setEnabled(false);  // until the worker reports back
    emit fireRequested(wantedSpeeds());
  });
  connect(cancel_, &QPushButton::clicked, this, [this] { emit cancelRequested(); });
  connect(reconnect_, &QPushButton::clicked, this, [this] {
    reconnecting_ = true;  // until the worker reports back
    reconnect_result_.clear();
    showLost();
    updateButtons();
    emit reconnectRequested();
  });
}

void RigPanel::addStateLabels(QVBoxLayout* al) {
  lost_ = new QLabel;
  lost_->setObjectName("lost_devices");
  lost_->setWordWrap(true);
  lost_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  lost_->setStyleSheet("color: #b03020;");
  lost_->hide();
  state_ = new QLabel(tr("disarmed"));
  state_->setObjectName("arm_state");
  hint_ = new QLabel;
  hint_->setObjectName("next_step_hint");
  hint_->setWordWrap(true);
  step_ = new QLabel;
  step_->setObjectName("step_label");
  step_->hide();
  shots_dir_ = new QLabel;
  shots_dir_->setObjectName("shots_dir_label");
  shots_dir_->setWordWrap(true);
  shots_dir_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  al->addWidget(lost_);
  al->addWidget(state_);
  al->addWidget(hint_);
  al->addWidget(step_);
  al->addWidget(shots_dir_);
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
    pressure_[i]->setRangeWithTip(p_lo, p_hi, tr("Launch pressure setpoint"), "kPa",
                                  tr("the calibration's working range within the regulator's "
                                     "limits"));
    if (curve)
      speed_[i]->setRangeWithTip(curve->speed_m_s(p_lo), curve->speed_m_s(p_hi),
                                 tr("Wanted exit speed"), "m/s",
                                 tr("what the launch calibration reaches at %1 to %2 kPa")
                                     .arg(p_lo, 0, 'f', 1)
                                     .arg(p_hi, 0, 'f', 1));
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
  updateBurstPending();

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
    // A campaign builds its own rig per shot: the panel's devices are closed
    // on purpose meanwhile, which is not an alarm.
    const bool campaign_owned = s.busy && s.state[r] == "closed";
    const QString cells[3] = {s.backend[r], s.device[r],
                              s.lost[r]        ? tr("lost")
                              : campaign_owned ? tr("in use by the shot")
                                               : s.state[r]};
    const QString why = s.lost[r] ? qs(hw::lostMessage(*s.lost[r])) : QString();
    for (int c = 0; c < 3; ++c) {
      auto* item = devices_->item(r, c);
      if (!item) devices_->setItem(r, c, item = new QTableWidgetItem);
      item->setText(cells[c]);
      item->setToolTip(why);
      if (c == 2) {
        QFont font = item->font();
        font.setBold(s.lost[r].has_value());
        item->setFont(font);
        item->setForeground(s.lost[r]                 ? QColor(170, 40, 30)
                            : s.state[r] == "running" ? QColor(20, 130, 40)
                            : campaign_owned          ? QColor(110, 110, 110)
                                                      : QColor(170, 40, 30));
      }
    }
  }
  // A lost regulator's last read-back is stale: it is not shown as a pressure.
  for (int i = 0; i < 2; ++i) {
    if (s.lost[0]) {
      readback_[i]->setText(tr("<b>lost</b>"));
      readback_[i]->setStyleSheet("color: #b03020;");
      readback_[i]->setToolTip(qs(hw::lostMessage(*s.lost[0])));
    } else {
      readback_[i]->setText(tr("%1 kPa (set %2)")
                                .arg(s.readback_kPa[i], 0, 'f', 2)
                                .arg(s.setpoint_kPa[i], 0, 'f', 2));
      readback_[i]->setStyleSheet({});
      readback_[i]->setToolTip({});
    }
  }
  showLost();
  state_->setText(s.busy      ? tr("<b>busy</b>: firing")
                  : !s.armed  ? tr("disarmed")
                  : s.settled ? tr("<b>armed and settled</b>: ready to fire")
                              : tr("<b>armed</b>: pressures settling"));
  if (!s.armed && pending_) {
    pending_ = false;
    setpoint_pending_->hide();
    apply_setpoint_->hide();
  }
  updateButtons();
}

void RigPanel::reconnectFinished(bool ok, const QString& message) {
  reconnecting_ = false;
  (void)message;  // the window's message bar shows it whole
  reconnect_result_ = ok ? QString() : QTime::currentTime().toString("HH:mm:ss");
  showLost();
  updateButtons();
}

void RigPanel::showLost() {
  // Short (the action bar has little room): what happened and what to check;
  // the whole message is the tooltip and in the window's message bar.
  QStringList lines, whole;
  for (const auto& l : status_.lost) {
    if (!l) continue;
    lines << tr("<b>%1 is lost</b> (%2): check %3, then press Reconnect.")
                 .arg(qs(l->device).toHtmlEscaped(), qs(l->what_happened).toHtmlEscaped(),
                      qs(l->what_to_check).toHtmlEscaped());
    whole << qs(hw::lostMessage(*l));
  }
  lost_->setToolTip(whole.join("\n\n"));
  if (reconnecting_)
    lines << tr("<i>Reconnecting: reopening and asking the lost devices...</i>");
  else if (!reconnect_result_.isEmpty() && !lines.isEmpty())
    lines << tr("<b>Reconnect at %1 did not find it</b>: it still does not answer.")
                 .arg(reconnect_result_);
  lost_->setText(lines.join("<br>"));
  lost_->setVisible(!lines.isEmpty());
  fitActionBar();
}

void RigPanel::fitActionBar() {
  // The dock lays the panel out by size hints, not by height for width: the
  // bar's word-wrapped labels (the lost message, the hint) would overlap when
  // they wrap to more lines than their hints assume. The bar asks for what its
  // labels need at its width.
  if (QLayout* l = action_bar_->layout())
    action_bar_->setMinimumHeight(l->totalHeightForWidth(action_bar_->width()));
}

bool RigPanel::eventFilter(QObject* watched, QEvent* event) {
  if (watched == action_bar_ && event->type() == QEvent::Resize) fitActionBar();
  return QWidget::eventFilter(watched, event);
}

void RigPanel::setStep(const QString& step) {
  step_->setText(step);
  step_->setVisible(!step.isEmpty());
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
  setpointEdited();
}

void RigPanel::pressureEdited(int i) {
  if (linking_ || !profile_) return;
  auto curve = profile_->calibration.curve();
  if (!curve) return;
  linking_ = true;
  speed_[i]->setValue(curve->speed_m_s(pressure_[i]->value()));
  linking_ = false;
  updateCurveMarkers();
  setpointEdited();
}

void RigPanel::setpointEdited() {
  // Disarmed, a setpoint is only a number; armed, the regulator would follow
  // it at once: that waits for Apply and a confirmation.
  if (!status_.armed || status_.busy) return;
  pending_ = true;
  QString text;
  for (int i = 0; i < 2; ++i)
    text += tr("%1launcher %2: %3 kPa (armed at %4)")
                .arg(i ? "; " : "")
                .arg(i + 1)
                .arg(pressure_[i]->value(), 0, 'f', 2)
                .arg(status_.setpoint_kPa[i], 0, 'f', 2);
  setpoint_pending_->setText(tr("New setpoint not applied: %1").arg(text));
  setpoint_pending_->show();
  apply_setpoint_->show();
  updateButtons();
}

void RigPanel::confirmSetpoint() {
  if (!pending_) return;
  // Non-blocking: the window (and the rig's status) keep updating meanwhile.
  auto* box = new QMessageBox(QMessageBox::Warning, tr("Change the armed pressure"),
                              tr("The lines are pressurised. Set the regulator to %1 kPa "
                                 "(launcher 1) and %2 kPa (launcher 2)?")
                                  .arg(pressure_[0]->value(), 0, 'f', 2)
                                  .arg(pressure_[1]->value(), 0, 'f', 2),
                              QMessageBox::Yes | QMessageBox::Cancel, this);
  box->setObjectName("confirm_setpoint");
  box->setDefaultButton(QMessageBox::Cancel);
  box->setAttribute(Qt::WA_DeleteOnClose);
  connect(box, &QMessageBox::finished, this, [this, box] {
    if (box->result() != QMessageBox::Yes || !pending_) return;
    pending_ = false;
    setpoint_pending_->hide();
    apply_setpoint_->hide();
    if (status_.armed && !status_.busy) emit armRequested(wantedSpeeds());
    updateButtons();
  });
  box->open();
}

void RigPanel::updateBurstPending() {
  if (!profile_) return;
  const hw::RigProfile& p = *profile_;
  const bool differs = pre_->value() != p.burst.pre_trigger_frames ||
                       post_->value() != p.burst.post_trigger_frames ||
                       std::abs(fps_->value() - p.camera_config.fps) > 0.05 ||
                       std::abs(exposure_->value() - p.camera_config.exposure_us) > 0.05;
  burst_pending_->setText(differs ? tr("Edited, not applied: shots use the profile's %1 + %2 "
                                       "frames at %3 frames/s until you press Apply.")
                                        .arg(p.burst.pre_trigger_frames)
                                        .arg(p.burst.post_trigger_frames)
                                        .arg(p.camera_config.fps)
                                  : QString());
  burst_pending_->setVisible(differs);
}

void RigPanel::setShotsDir(const QString& dir, bool usable, bool created) {
  shots_usable_ = usable;
  shots_dir_->setText(
      usable ? tr("Shots are saved in <b>%1</b>%2 (File &gt; Shot folder to "
                  "change)")
                   .arg(dir.toHtmlEscaped(), created ? tr(", <span style='color:#a05a00'>a new "
                                                          "folder created now: check the "
                                                          "name</span>")
                                                     : QString())
             : tr("<span style='color:#b03020'>Shots cannot be saved in "
                  "<b>%1</b>: choose a folder (File &gt; Shot folder).</span>")
                   .arg(dir.toHtmlEscaped()));
  updateButtons();
}

void RigPanel::updateHint() {
  QString hint;
  if (!profile_)
    hint = tr("First: open a rig profile (File &gt; Open rig profile).");
  else if (!shots_usable_)
    hint = tr("First: choose a shot folder you can write to (File &gt; Shot folder).");
  else if (status_.busy)
    hint = tr("Wait for the shot or campaign to finish, or Cancel it.");
  else if (status_.anyLost())
    hint =
        tr("Arm and Fire are off while a device is lost: check it (see above), then press "
           "<b>Reconnect</b>.");
  else if (pending_)
    hint = tr("Next: Apply the new setpoint (or Disarm).");
  else if (!status_.armed)
    hint = tr("Next: set each launcher's exit speed above, then <b>Arm</b>.");
  else if (!status_.settled)
    hint = tr("Next: wait until both pressures have settled (at most %1 s).")
               .arg(profile_->sequencer.settle_timeout_s);
  else
    hint = tr("Next: <b>Fire</b>. The shot opens in Replay with its results.");
  hint_->setText(hint);
  fitActionBar();
}

void RigPanel::updateCurveMarkers() {
  setpoints_->clear();
  for (int i = 0; i < 2; ++i) setpoints_->append(pressure_[i]->value(), speed_[i]->value());
}

void RigPanel::updateButtons() {
  const bool loaded = profile_ != nullptr;
  const bool busy = status_.busy || reconnecting_;
  const bool lost = status_.anyLost();
  arm_->setEnabled(loaded && !busy && shots_usable_ && !lost);
  disarm_->setEnabled(loaded && !busy && status_.armed);
  fire_->setEnabled(loaded && !busy && status_.armed && status_.settled && !pending_ &&
                    shots_usable_ && !lost);
  cancel_->setEnabled(status_.busy);
  reconnect_->setEnabled(loaded && lost && !busy);
  reconnect_->setText(reconnecting_ ? tr("Reconnecting...") : tr("Reconnect"));
  // Why Arm and Fire are off, where the pointer is.
  const QString off =
      lost ? tr("Off while a device is lost: press Reconnect once it is checked.") : QString();
  arm_->setToolTip(lost ? off : arm_tip_);
  fire_->setToolTip(lost ? off : fire_tip_);
  // Applying rebuilds the rig (lines vented): not while armed, as Live's camera
  // controls; nor while a device is lost (a rebuilt rig would start with a
  // clean record without asking the device: Reconnect checks it).
  apply_burst_->setEnabled(loaded && !busy && !status_.armed && !lost);
  apply_burst_->setToolTip(status_.armed ? tr("Disarm first: applying rebuilds the rig")
                           : lost        ? tr("A device is lost: press Reconnect first")
                                         : tr("Use these burst and camera settings for the next "
                                                     "shots (the rig is rebuilt, unarmed)"));
  for (int i = 0; i < 2; ++i) {
    speed_[i]->setEnabled(loaded && !busy);
    pressure_[i]->setEnabled(loaded && !busy);
  }
  updateHint();
}

}  // namespace collide::gui
