#include "app/gui/calibration_dialog.hpp"

#include <QAreaSeries>
#include <QChart>
#include <QChartView>
#include <QCheckBox>
#include <QFile>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLegendMarker>
#include <QLineSeries>
#include <QMessageBox>
#include <QPushButton>
#include <QScatterSeries>
#include <QSplitter>
#include <QTableWidget>
#include <QTextStream>
#include <QVBoxLayout>
#include <QValueAxis>
#include <algorithm>
#include <cmath>

#include "app/profile_edit.hpp"

namespace collide::gui {
namespace {

QString coefficientText(const LaunchCalibration::Coefficients& c) {
  return QString("v(p) = %1 + %2 x %3 %4 x² + %5 x³  (x = p/100)")
      .arg(c[0], 0, 'f', 4)
      .arg(c[1], 0, 'f', 4)
      .arg(c[2] < 0 ? "-" : "+")
      .arg(std::abs(c[2]), 0, 'f', 4)
      .arg(c[3], 0, 'f', 4);
}

// The cubic itself, also outside a calibration's working range.
double cubic(const LaunchCalibration::Coefficients& c, double p_kPa) {
  const double x = p_kPa / 100.0;
  return c[0] + x * (c[1] + x * (c[2] + x * c[3]));
}

}  // namespace

CalibrationDialog::CalibrationDialog(ProfilePtr profile, QString profile_path, QWidget* parent)
    : QDialog(parent), profile_(std::move(profile)), profile_path_(std::move(profile_path)) {
  setObjectName("calibration_dialog");
  setWindowTitle(tr("Launch calibration"));
  auto* layout = new QVBoxLayout(this);
  auto* splitter = new QSplitter;
  table_ = new QTableWidget(0, 4);
  table_->setObjectName("calibration_points");
  table_->setHorizontalHeaderLabels(
      {tr("shot"), tr("launcher"), tr("pressure (kPa)"), tr("exit speed (m/s)")});
  table_->horizontalHeader()->setStretchLastSection(true);
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  splitter->addWidget(table_);
  chart_ = new QChartView(new QChart);
  chart_->setObjectName("calibration_chart");
  chart_->setRenderHint(QPainter::Antialiasing);
  chart_->setMinimumSize(420, 300);
  splitter->addWidget(chart_);
  splitter->setStretchFactor(1, 2);
  table_->setMinimumWidth(380);
  layout->addWidget(splitter, 1);
  status_ = new QLabel;
  status_->setObjectName("calibration_status");
  status_->setWordWrap(true);
  status_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(status_);
  narrow_ = new QCheckBox;
  narrow_->setObjectName("narrow_range");
  narrow_->setChecked(true);
  narrow_->hide();
  layout->addWidget(narrow_);
  connect(narrow_, &QCheckBox::toggled, this, [this] { updateSave(); });
  auto* buttons = new QHBoxLayout;
  refit_button_ = new QPushButton(tr("Refit cubic"));
  refit_button_->setObjectName("refit_button");
  save_button_ = new QPushButton(tr("Save to profile..."));
  save_button_->setObjectName("save_calibration");
  save_button_->setEnabled(false);
  auto* close = new QPushButton(tr("Close"));
  buttons->addWidget(refit_button_);
  buttons->addStretch();
  buttons->addWidget(save_button_);
  buttons->addWidget(close);
  layout->addLayout(buttons);
  connect(refit_button_, &QPushButton::clicked, this, [this] { refit(); });
  connect(save_button_, &QPushButton::clicked, this, [this] { (void)saveToProfile(true); });
  connect(close, &QPushButton::clicked, this, &QDialog::reject);
  resize(900, 520);
  redraw();
}

void CalibrationDialog::setLaunches(std::vector<MeasuredLaunch> launches) {
  launches_ = std::move(launches);
  refit_.reset();
  measured_lo_ = measured_hi_ = 0;
  if (!launches_.empty()) {
    auto [a, b] = std::minmax_element(launches_.begin(), launches_.end(),
                                      [](const MeasuredLaunch& x, const MeasuredLaunch& y) {
                                        return x.pressure_kPa < y.pressure_kPa;
                                      });
    measured_lo_ = a->pressure_kPa;
    measured_hi_ = b->pressure_kPa;
  }
  // More than 1 kPa (a regulator's resolution) beyond the data counts.
  extrapolates_ = !launches_.empty() && (profile_->calibration.min_kPa < measured_lo_ - 1.0 ||
                                         profile_->calibration.max_kPa > measured_hi_ + 1.0);
  narrow_->hide();
  table_->setRowCount(static_cast<int>(launches_.size()));
  for (int i = 0; i < static_cast<int>(launches_.size()); ++i) {
    const MeasuredLaunch& m = launches_[i];
    const QString cells[4] = {
        m.shot_id, QString::number(m.launcher + 1), QString::number(m.pressure_kPa, 'f', 2),
        m.speed_sigma_m_s > 0
            ? QString("%1 ± %2").arg(m.speed_m_s, 0, 'f', 3).arg(m.speed_sigma_m_s, 0, 'f', 3)
            : QString::number(m.speed_m_s, 'f', 3)};
    for (int c = 0; c < 4; ++c) table_->setItem(i, c, new QTableWidgetItem(cells[c]));
  }
  table_->resizeColumnsToContents();
  status_->setText(launches_.empty()
                       ? tr("No measured launches yet: fire and analyse shots at several pressures "
                            "(a campaign does), then open this dialog again.")
                       : tr("%1 measured launches. Profile: %2")
                             .arg(launches_.size())
                             .arg(coefficientText(profile_->calibration.coefficients)));
  save_button_->setEnabled(false);
  redraw();
}

bool CalibrationDialog::refit() {
  refit_.reset();
  const int n = static_cast<int>(launches_.size());
  Eigen::VectorXd p(n), v(n), sigma(n);
  bool sigmas = n > 0;
  for (int i = 0; i < n; ++i) {
    p[i] = launches_[i].pressure_kPa;
    v[i] = launches_[i].speed_m_s;
    sigma[i] = launches_[i].speed_sigma_m_s;
    sigmas = sigmas && sigma[i] > 0 && std::isfinite(sigma[i]);
  }
  const Weights weights = sigmas ? Weights::fromSigmas(sigma) : Weights::equal();
  const double lo = profile_->calibration.min_kPa, hi = profile_->calibration.max_kPa;
  auto result = refitLaunchCalibration(p, v, weights, lo, hi);
  // A cubic that turns over outside the data is still good inside it: refit
  // for the measured range (saving then narrows the working range to it).
  if (!result && extrapolates_)
    result = refitLaunchCalibration(p, v, weights, std::max(lo, measured_lo_),
                                    std::min(hi, measured_hi_));
  if (!result) {
    status_->setText(tr("Cannot refit: %1").arg(QString::fromStdString(result.error().message)));
    save_button_->setEnabled(false);
    redraw();
    return false;
  }
  refit_ = std::move(result).value();
  const auto& c = refit_->calibration.coefficients();
  QString sig;
  for (int k = 0; k < 4; ++k)
    sig += QString("c%1 = %2 ± %3  ")
               .arg(k)
               .arg(c[k], 0, 'f', 4)
               .arg(std::sqrt(refit_->covariance(k, k)), 0, 'f', 4);
  status_->setText(tr("Refit from %1 launches: %2<br>%3<br>residual RMS %4 m/s. Was: %5")
                       .arg(n)
                       .arg(coefficientText(c))
                       .arg(sig)
                       .arg(refit_->rms_m_s, 0, 'f', 4)
                       .arg(coefficientText(profile_->calibration.coefficients)));
  if (extrapolates_) {
    status_->setText(
        status_->text() +
        tr("<br><span style='color:#a05a00'><b>Warning:</b> the launches span only %1 to %2 kPa "
           "(shaded); the profile's working range %3 to %4 kPa would be extrapolated (the refit "
           "gives %5 m/s at %4 kPa).</span>")
            .arg(measured_lo_, 0, 'f', 1)
            .arg(measured_hi_, 0, 'f', 1)
            .arg(lo, 0, 'f', 1)
            .arg(hi, 0, 'f', 1)
            .arg(cubic(refit_->calibration.coefficients(), hi), 0, 'f', 2));
    narrow_->setText(tr("Save with the working range narrowed to the measured %1 to %2 kPa "
                        "(untick: the calibration is not saved)")
                         .arg(measured_lo_, 0, 'f', 1)
                         .arg(measured_hi_, 0, 'f', 1));
  }
  narrow_->setVisible(extrapolates_);
  if (profile_path_.isEmpty())
    status_->setText(status_->text() + tr("<br>The profile is built in: open a profile file "
                                          "(File > Open rig profile) to save a calibration."));
  updateSave();
  redraw();
  return true;
}

void CalibrationDialog::updateSave() {
  const bool can = refit_ && !profile_path_.isEmpty() && (!extrapolates_ || narrow_->isChecked());
  save_button_->setEnabled(can);
  save_button_->setToolTip(refit_ && extrapolates_ && !narrow_->isChecked()
                               ? tr("Not saved: the refit would be used beyond the measured "
                                    "pressures. Tick the narrowing, or measure launches across "
                                    "the whole range.")
                               : QString());
}

Status CalibrationDialog::saveToProfile(bool ask) {
  auto report = [&](const QString& message) -> Status {
    status_->setText(message);
    return fail(message.toStdString());
  };
  if (!refit_) return report(tr("Nothing to save: refit the cubic first."));
  if (profile_path_.isEmpty())
    return report(tr("The profile is built in: open a profile file to save a calibration."));
  const auto& c = refit_->calibration.coefficients();
  if (extrapolates_ && !narrow_->isChecked())
    return report(
        tr("Not saved: the profile's working range reaches beyond the measured "
           "pressures. Narrow it to them, or measure launches across the whole range."));
  // The narrowed range: the measured one, rounded outwards to 0.1 kPa, inside the old one.
  const double new_lo =
      std::max(profile_->calibration.min_kPa, std::floor(measured_lo_ * 10.0) / 10.0);
  const double new_hi =
      std::min(profile_->calibration.max_kPa, std::ceil(measured_hi_ * 10.0) / 10.0);
  const QString range_text = extrapolates_ ? tr("\n\nWorking range narrowed from %1 - %2 kPa to "
                                                "%3 - %4 kPa (the measured pressures).")
                                                 .arg(profile_->calibration.min_kPa)
                                                 .arg(profile_->calibration.max_kPa)
                                                 .arg(new_lo)
                                                 .arg(new_hi)
                                           : QString();
  if (ask && QMessageBox::question(
                 this, tr("Save the calibration"),
                 tr("Write the refitted calibration into %1?\n\n%2%3\n\nThe current "
                    "file is kept as %1.bak.")
                     .arg(profile_path_, coefficientText(c), range_text)) != QMessageBox::Yes)
    return report(tr("Not saved."));
  // Edit the file as it is on disk now (not as it was loaded), so nothing
  // else the user changed in it since is lost.
  QFile file(profile_path_);
  if (!file.open(QIODevice::ReadOnly))
    return report(tr("Cannot read %1: %2").arg(profile_path_, file.errorString()));
  const std::string text = QString::fromUtf8(file.readAll()).toStdString();
  file.close();
  auto edited = app::setProfileValue(text, "calibration", "coefficients",
                                     app::tomlNumberArray({c[0], c[1], c[2], c[3]}));
  if (edited && extrapolates_)
    edited = app::setProfileValue(*edited, "calibration", "min_kpa",
                                  QString::number(new_lo, 'f', 1).toStdString());
  if (edited && extrapolates_)
    edited = app::setProfileValue(*edited, "calibration", "max_kpa",
                                  QString::number(new_hi, 'f', 1).toStdString());
  if (!edited) return report(QString::fromStdString(edited.error().message));
  auto parsed = hw::parseRigProfile(*edited, profile_path_.toStdString());
  if (!parsed)
    return report(tr("Not saved: the edited profile would not load: %1")
                      .arg(QString::fromStdString(parsed.error().message)));
  std::string backup;
  if (Status s = app::writeProfileFile(profile_path_.toStdString(), *edited, &backup); !s)
    return report(tr("Not saved: %1").arg(QString::fromStdString(s.error().message)));
  backup_path_ = QString::fromStdString(backup);
  status_->setText(
      tr("Saved into %1 (previous file kept as %2).").arg(profile_path_, backup_path_));
  save_button_->setEnabled(false);
  emit profileSaved(profile_path_);
  return Ok{};
}

QString CalibrationDialog::statusText() const {
  return status_->text();
}

void CalibrationDialog::redraw() {
  auto* chart = new QChart;
  chart->setTitle(tr("Exit speed against launch pressure"));
  auto* x = new QValueAxis;
  auto* y = new QValueAxis;
  x->setTitleText(tr("pressure (kPa, gauge)"));
  y->setTitleText(tr("exit speed (m/s)"));
  chart->addAxis(x, Qt::AlignBottom);
  chart->addAxis(y, Qt::AlignLeft);
  const double lo = profile_->calibration.min_kPa, hi = profile_->calibration.max_kPa;
  auto addCurve = [&](const LaunchCalibration& curve, const QString& name, QColor colour) {
    auto* s = new QLineSeries;
    s->setName(name);
    s->setPen(QPen(colour, 2));
    for (int k = 0; k <= 60; ++k)
      s->append(lo + (hi - lo) * k / 60.0, curve.speed_m_s(lo + (hi - lo) * k / 60.0));
    chart->addSeries(s);
    s->attachAxis(x);
    s->attachAxis(y);
  };
  double vmax = 1;
  if (auto curve = profile_->calibration.curve()) {
    addCurve(*curve, tr("profile"), QColor(120, 120, 120));
    vmax = curve->maxSpeed_m_s();
  }
  if (!launches_.empty() && measured_hi_ > measured_lo_) {
    // The measured pressures, shaded: a curve is known only there.
    auto* top = new QLineSeries;
    auto* bottom = new QLineSeries;
    const double ytop = 1e3;  // clipped by the axis
    top->append(measured_lo_, ytop);
    top->append(measured_hi_, ytop);
    bottom->append(measured_lo_, 0);
    bottom->append(measured_hi_, 0);
    auto* area = new QAreaSeries(top, bottom);
    area->setName(tr("measured range"));
    area->setColor(QColor(31, 119, 180, 40));
    area->setBorderColor(QColor(31, 119, 180, 90));
    chart->addSeries(area);
    area->attachAxis(x);
    area->attachAxis(y);
  }
  if (refit_) {
    // Solid where measured, dashed where it would be extrapolated.
    const LaunchCalibration& r = refit_->calibration;
    const double a = std::max(lo, measured_lo_), b = std::min(hi, measured_hi_);
    auto* in = new QLineSeries;
    in->setName(tr("refit"));
    in->setPen(QPen(QColor(214, 39, 40), 2));
    for (int k = 0; k <= 40; ++k)
      in->append(a + (b - a) * k / 40.0, cubic(r.coefficients(), a + (b - a) * k / 40.0));
    chart->addSeries(in);
    in->attachAxis(x);
    in->attachAxis(y);
    for (auto [from, to] : {std::pair{lo, a}, std::pair{b, hi}}) {
      if (to - from < 1e-9) continue;
      auto* out = new QLineSeries;
      out->setName(tr("refit, extrapolated"));
      out->setPen(QPen(QColor(214, 39, 40), 1.5, Qt::DashLine));
      for (int k = 0; k <= 30; ++k)
        out->append(from + (to - from) * k / 30.0,
                    cubic(r.coefficients(), from + (to - from) * k / 30.0));
      chart->addSeries(out);
      out->attachAxis(x);
      out->attachAxis(y);
      if (from > lo)  // one legend entry for both pieces
        for (auto* m : chart->legend()->markers(out)) m->setVisible(false);
    }
    for (int k = 0; k <= 20; ++k)
      vmax = std::max(vmax, cubic(r.coefficients(), a + (b - a) * k / 20.0));
  }
  auto* points = new QScatterSeries;
  points->setName(tr("measured"));
  points->setMarkerSize(7);
  for (const auto& m : launches_) {
    points->append(m.pressure_kPa, m.speed_m_s);
    vmax = std::max(vmax, m.speed_m_s);
  }
  chart->addSeries(points);
  points->attachAxis(x);
  points->attachAxis(y);
  x->setRange(lo, hi);
  y->setRange(0, vmax * 1.05);
  chart->legend()->setAlignment(Qt::AlignBottom);
  QChart* old = chart_->chart();
  chart_->setChart(chart);
  delete old;
}

}  // namespace collide::gui
