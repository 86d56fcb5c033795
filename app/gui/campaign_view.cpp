#include "app/gui/campaign_view.hpp"

#include <QChart>
#include <QChartView>
#include <QComboBox>
#include <QDir>
#include <QDoubleSpinBox>
#include <QFile>
#include <QFileDialog>
#include <QFontMetrics>
#include <QFormLayout>
#include <QGridLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QLegendMarker>
#include <QLineSeries>
#include <QPainter>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QScatterSeries>
#include <QScrollArea>
#include <QSpinBox>
#include <QSvgGenerator>
#include <QVBoxLayout>
#include <QValueAxis>
#include <QtConcurrent/QtConcurrentRun>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "app/report/campaign_report.hpp"

namespace collide::gui {
namespace {

const QColor kPalette[] = {QColor(31, 119, 180), QColor(214, 39, 40),   QColor(44, 160, 44),
                           QColor(255, 127, 14), QColor(148, 103, 189), QColor(140, 86, 75)};

QColor paletteColour(int i) {
  return kPalette[((i % 6) + 6) % 6];
}

// "value ± sigma" rounded to the uncertainty (two significant digits of it);
// a zero or unknown uncertainty is said, not printed as "± 0.0000".
QString withSigma(double value, double sigma) {
  if (!std::isfinite(value)) return QObject::tr("n/a");
  if (!(std::isfinite(sigma) && sigma > 0))
    return QObject::tr("%1 (no uncertainty estimate)").arg(value, 0, 'g', 4);
  const int decimals = std::clamp(1 - static_cast<int>(std::floor(std::log10(sigma))), 0, 8);
  return QString("%1 ± %2").arg(value, 0, 'f', decimals).arg(sigma, 0, 'f', decimals);
}

// Axis range covering the data with a small margin (or the spec's fixed one).
void setRange(QValueAxis* axis, std::optional<double> lo, std::optional<double> hi, double dmin,
              double dmax) {
  if (!std::isfinite(dmin) || !std::isfinite(dmax)) dmin = 0, dmax = 1;
  if (dmax - dmin < 1e-12) dmin -= 0.5, dmax += 0.5;
  const double pad = 0.05 * (dmax - dmin);
  axis->setRange(lo.value_or(dmin - pad), hi.value_or(dmax + pad));
  axis->applyNiceNumbers();
}

}  // namespace

QChartView* makeChartView(const app::PlotSpec& spec) {
  auto* chart = new QChart;
  // "<plot>: <fit>" on two lines: one is elided in a half-width chart.
  const QString title = QString::fromStdString(spec.title);
  const qsizetype colon = title.indexOf(": ");
  chart->setTitle(colon < 0 ? title.toHtmlEscaped()
                            : title.left(colon).toHtmlEscaped() + "<br>" +
                                  title.mid(colon + 2).toHtmlEscaped());
  auto* x = new QValueAxis;
  auto* y = new QValueAxis;
  x->setTitleText(QString::fromStdString(spec.x_label));
  y->setTitleText(QString::fromStdString(spec.y_label));
  chart->addAxis(x, Qt::AlignBottom);
  chart->addAxis(y, Qt::AlignLeft);
  double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin, ymin = xmin, ymax = -xmin;
  auto attach = [&](QXYSeries* s, bool in_legend) {
    chart->addSeries(s);
    s->attachAxis(x);
    s->attachAxis(y);
    if (!in_legend)
      for (QLegendMarker* m : chart->legend()->markers(s)) m->setVisible(false);
  };
  for (const app::Series& series : spec.series) {
    const QColor colour = paletteColour(series.colour);
    QXYSeries* s = nullptr;
    if (series.style == app::Series::Style::Points) {
      auto* scatter = new QScatterSeries;
      scatter->setMarkerSize(7);
      scatter->setBorderColor(colour.darker(130));
      s = scatter;
    } else {
      auto* line = new QLineSeries;
      line->setPen(QPen(colour, 2));
      s = line;
    }
    s->setName(QString::fromStdString(series.label));
    s->setColor(colour);
    const std::size_t n = std::min(series.x.size(), series.y.size());
    for (std::size_t i = 0; i < n; ++i) {
      if (!std::isfinite(series.x[i]) || !std::isfinite(series.y[i])) continue;
      s->append(series.x[i], series.y[i]);
      // The range takes in the error bars too.
      const double e =
          i < series.y_err.size() && std::isfinite(series.y_err[i]) ? series.y_err[i] : 0;
      xmin = std::min(xmin, series.x[i]);
      xmax = std::max(xmax, series.x[i]);
      ymin = std::min(ymin, series.y[i] - e);
      ymax = std::max(ymax, series.y[i] + e);
    }
    attach(s, !series.label.empty());
    // One-sigma error bars: a short vertical line per point.
    if (series.y_err.size() == series.y.size()) {
      for (std::size_t i = 0; i < n; ++i) {
        const double e = series.y_err[i];
        if (!std::isfinite(e) || e <= 0 || !std::isfinite(series.x[i])) continue;
        auto* bar = new QLineSeries;
        bar->setPen(QPen(colour, 1));
        bar->append(series.x[i], series.y[i] - e);
        bar->append(series.x[i], series.y[i] + e);
        attach(bar, false);
      }
    }
  }
  setRange(x, spec.x_min, spec.x_max, xmin, xmax);
  setRange(y, spec.y_min, spec.y_max, ymin, ymax);
  chart->legend()->setAlignment(Qt::AlignBottom);
  auto* view = new QChartView(chart);
  view->setRenderHint(QPainter::Antialiasing);
  // Tall enough that the plot area holds the y-axis title (Qt elides a
  // longer one): the chart's title, x axis and legend take about 190 px.
  const int y_title_px = QFontMetrics(y->titleFont()).horizontalAdvance(y->titleText());
  view->setMinimumSize(360, std::max(260, y_title_px + 190));
  return view;
}

std::string plotCsv(const app::PlotSpec& plot) {
  std::ostringstream out;
  out.precision(10);
  auto quoted = [](const std::string& s) {
    std::string q = "\"";
    for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
  };
  out << "series,style," << quoted(plot.x_label) << "," << quoted(plot.y_label) << ",y_sigma\n";
  for (const app::Series& s : plot.series) {
    const char* style = s.style == app::Series::Style::Points ? "points" : "line";
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      out << quoted(s.label) << "," << style << "," << s.x[i] << "," << s.y[i] << ",";
      if (i < s.y_err.size()) out << s.y_err[i];
      out << "\n";
    }
  }
  return out.str();
}

CampaignView::CampaignView(QWidget* parent) : QWidget(parent) {
  auto* layout = new QVBoxLayout(this);
  addControls(layout);
  addAdaptiveTargets(layout);
  addReportArea(layout);
  showMode();
  connect(&loader_, &QFutureWatcher<Loaded>::finished, this, [this] {
    Loaded l = loader_.result();
    setCharts(std::move(l.charts), l.summary);
    if (refresh_again_) {
      refresh_again_ = false;
      refresh();
    }
  });
}

// The campaign's kind, size, seed and incidence range; Run, Cancel, Export all.
void CampaignView::addControls(QVBoxLayout* layout) {
  auto* controls = new QHBoxLayout;
  mode_ = new QComboBox;
  mode_->setObjectName("campaign_mode");
  mode_->addItem(tr("Uniform sweep"));
  mode_->addItem(tr("Adaptive"));
  mode_->setToolTip(
      tr("Uniform sweep: the shots spread evenly over the incidence range.\nAdaptive: each shot "
         "is analysed and the fit redone, and the next incidence is chosen where mu or beta_0 is "
         "least known; it stops when both sigmas reach their targets or the budget is spent."));
  shots_ = new QSpinBox;
  shots_->setObjectName("campaign_shots");
  shots_->setRange(1, 1000);
  shots_->setValue(20);
  shots_->setPrefix(tr("shots: "));
  seed_ = new QSpinBox;
  seed_->setObjectName("campaign_seed");
  seed_->setRange(0, 1'000'000);
  seed_->setValue(1);
  seed_->setPrefix(tr("seed: "));
  angle_min_ = new QDoubleSpinBox;
  angle_max_ = new QDoubleSpinBox;
  angle_min_->setObjectName("campaign_angle_min");
  angle_max_->setObjectName("campaign_angle_max");
  for (auto* a : {angle_min_, angle_max_}) {
    a->setRange(0, 89);
    a->setDecimals(0);
    a->setSuffix(QString::fromUtf8("°"));
  }
  angle_min_->setValue(10);
  angle_max_->setValue(80);
  run_ = new QPushButton(tr("Run campaign"));
  run_->setObjectName("run_campaign");
  cancel_ = new QPushButton(tr("Cancel"));
  cancel_->setObjectName("cancel_campaign");
  cancel_->setToolTip(
      tr("Stops the campaign; every shot recorded is kept (a shot still waiting for its "
         "pressure is abandoned and saved as failed, 'cancelled')"));
  cancel_->setEnabled(false);
  auto* export_all = new QPushButton(tr("Export all..."));
  export_all->setObjectName("export_all");
  controls->addWidget(mode_);
  controls->addWidget(shots_);
  controls->addWidget(seed_);
  controls->addWidget(new QLabel(tr("incidence")));
  controls->addWidget(angle_min_);
  controls->addWidget(new QLabel(tr("to")));
  controls->addWidget(angle_max_);
  controls->addWidget(run_);
  controls->addWidget(cancel_);
  controls->addStretch();
  controls->addWidget(export_all);
  layout->addLayout(controls);

  connect(mode_, &QComboBox::currentIndexChanged, this, [this] { showMode(); });
  connect(run_, &QPushButton::clicked, this, [this] {
    if (adaptiveSelected())
      emit adaptiveCampaignRequested(shots_->value(), static_cast<quint64>(seed_->value()),
                                     angle_min_->value(), angle_max_->value(), target_mu_->value(),
                                     target_beta0_->value());
    else
      emit campaignRequested(shots_->value(), static_cast<quint64>(seed_->value()),
                             angle_min_->value(), angle_max_->value());
  });
  connect(cancel_, &QPushButton::clicked, this, [this] { emit cancelRequested(); });
  connect(export_all, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Export the plots into"), dir_);
    if (dir.isEmpty()) return;
    QString error;
    if (!exportAll(dir, &error)) summary_->setText(error);
  });
}

void CampaignView::addAdaptiveTargets(QVBoxLayout* layout) {
  // The adaptive campaign's targets (mu and beta_0 are dimensionless).
  adaptive_controls_ = new QWidget;
  auto* targets = new QHBoxLayout(adaptive_controls_);
  targets->setContentsMargins(0, 0, 0, 0);
  target_mu_ = new QDoubleSpinBox;
  target_mu_->setObjectName("campaign_target_sigma_mu");
  // Down to 1e-5: the simulated rig's precise imaging gets sigmas of a few 1e-5.
  target_mu_->setRange(0.00001, 0.5);
  target_mu_->setDecimals(5);
  target_mu_->setSingleStep(0.001);
  target_mu_->setValue(0.005);
  target_mu_->setPrefix(QString::fromUtf8("stop at σ(μ) ≤ "));
  target_beta0_ = new QDoubleSpinBox;
  target_beta0_->setObjectName("campaign_target_sigma_beta0");
  target_beta0_->setRange(0.00001, 1.0);
  target_beta0_->setDecimals(5);
  target_beta0_->setSingleStep(0.005);
  target_beta0_->setValue(0.02);
  target_beta0_->setPrefix(QString::fromUtf8("and σ(β₀) ≤ "));
  targets->addWidget(target_mu_);
  targets->addWidget(target_beta0_);
  auto* note = new QLabel(tr("(dimensionless; the shots box is the budget)"));
  note->setToolTip(
      tr("The design chooses each shot's incidence, and its speed (the slowest or the fastest of "
         "the campaign's speed range) once the shots so far show how the noise scales with "
         "speed; until then speeds are drawn from the range, as in a uniform sweep."));
  targets->addWidget(note);
  targets->addStretch();
  layout->addWidget(adaptive_controls_);
}

// The adaptive campaign's status and log, the report, the summary and the plots.
void CampaignView::addReportArea(QVBoxLayout* layout) {
  adaptive_status_ = new QLabel;
  adaptive_status_->setObjectName("campaign_adaptive_status");
  adaptive_status_->setWordWrap(true);
  adaptive_status_->hide();
  layout->addWidget(adaptive_status_);
  adaptive_log_ = new QPlainTextEdit;
  adaptive_log_->setObjectName("campaign_adaptive_log");
  adaptive_log_->setReadOnly(true);
  adaptive_log_->setLineWrapMode(QPlainTextEdit::WidgetWidth);
  adaptive_log_->setMaximumHeight(130);
  adaptive_log_->hide();
  layout->addWidget(adaptive_log_);
  report_ = new QLabel;
  report_->setObjectName("campaign_report");
  report_->setWordWrap(true);
  report_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  report_->hide();
  layout->addWidget(report_);
  summary_ = new QLabel(tr("no shot folder"));
  summary_->setObjectName("campaign_summary");
  summary_->setWordWrap(true);
  layout->addWidget(summary_);
  auto* scroll = new QScrollArea;
  scroll->setWidgetResizable(true);
  grid_host_ = new QWidget;
  new QGridLayout(grid_host_);
  scroll->setWidget(grid_host_);
  layout->addWidget(scroll, 1);
}

CampaignView::~CampaignView() {
  loader_.waitForFinished();
}

bool CampaignView::adaptiveSelected() const {
  return mode_->currentIndex() == 1;
}

void CampaignView::showMode() {
  const bool adaptive = adaptiveSelected();
  adaptive_controls_->setVisible(adaptive);
  shots_->setPrefix(adaptive ? tr("budget: ") : tr("shots: "));
  shots_->setToolTip(adaptive ? tr("At most this many shots; fewer when the targets are reached")
                              : tr("Shots to fire, spread evenly over the incidence range"));
}

void CampaignView::setCampaignRunning(bool running) {
  run_->setEnabled(!running);
  cancel_->setEnabled(running);
  // The mode and targets stay as the running campaign was started with.
  for (QWidget* w :
       {static_cast<QWidget*>(mode_), static_cast<QWidget*>(shots_), static_cast<QWidget*>(seed_),
        static_cast<QWidget*>(angle_min_), static_cast<QWidget*>(angle_max_), adaptive_controls_})
    w->setEnabled(!running);
  if (!running) return;
  report_->hide();
  adaptive_lines_.clear();
  adaptive_log_->clear();
  adaptive_log_->setVisible(adaptiveSelected());
  adaptive_status_->setText(tr("Adaptive campaign: firing the first shot..."));
  adaptive_status_->setVisible(adaptiveSelected());
}

void CampaignView::addAdaptiveShot(const QString& line, const QString& sigmas) {
  adaptive_lines_ << line;
  adaptive_log_->appendPlainText(line);
  adaptive_log_->show();
  adaptive_status_->setText(tr("After shot %1: %2").arg(adaptive_lines_.size()).arg(sigmas));
  adaptive_status_->show();
}

QStringList CampaignView::adaptiveLog() const {
  return adaptive_lines_;
}

QString CampaignView::adaptiveStatus() const {
  return adaptive_status_->isVisible() ? adaptive_status_->text() : QString();
}

void CampaignView::setReport(const QString& text, bool warning) {
  report_->setText(text);
  report_->setStyleSheet(warning ? "QLabel { background: #fff0c2; color: #6b3d00; padding: 4px; }"
                                 : "QLabel { background: #e3f1e0; padding: 4px; }");
  report_->show();
}

QString CampaignView::reportText() const {
  return report_->isVisible() ? report_->text() : QString();
}

namespace {

// The folder's analysed shots, fitted, as the five plots (worker thread):
// the same entries, fits and PlotSpecs `collide fit` draws.
CampaignView::Loaded loadFolder(const std::string& dir) {
  CampaignView::Loaded out;
  auto entries = app::loadCampaign(dir);
  if (!entries) {
    out.summary = QString::fromStdString(entries.error().message);
    return out;
  }
  const std::vector<CampaignShot> usable = app::usableShots(*entries);
  int analysed = 0;
  for (const auto& e : *entries) analysed += e.results.has_value();
  auto report = app::fitCampaignFolder(*entries, /*resamples=*/0);
  for (auto& named : app::campaignPlots(*entries, report ? &*report : nullptr))
    out.charts.push_back({named.name, std::move(named.plot)});
  QString text = QObject::tr("%1 shots in the folder, %2 analysed, %3 used by the fits. ")
                     .arg(entries->size())
                     .arg(analysed)
                     .arg(usable.size());
  if (report) {
    const RestitutionMean& r = report->fit.restitution;
    text += QObject::tr("e = %1").arg(withSigma(r.e.value, r.e.sigma));
    if (const auto& f = report->fit.friction) {
      text +=
          QObject::tr(", mu = %1, beta0 = %2, gamma0 = %3 deg")
              .arg(withSigma(f->mu.value, f->mu.sigma), withSigma(f->beta0.value, f->beta0.sigma),
                   withSigma(f->switch_angle_deg.value, f->switch_angle_deg.sigma));
    } else {
      text += QObject::tr("; mu and beta0 not fitted: %1")
                  .arg(QString::fromStdString(f.error().message));
    }
    if (report->fit.laws)
      text += QObject::tr("; e(|v_n|): %1 preferred")
                  .arg(QString::fromStdString(restitutionLawName(report->fit.laws->preferred)));
    if (const auto& ls = report->launch_spin)
      text += QObject::tr(
                  "; launchers' spin %1 rad/s per axis (from %2 spins; the profile's "
                  "[analysis] launch_spin_rad_s)")
                  .arg(withSigma(ls->per_axis_rad_s, ls->sigma_rad_s))
                  .arg(ls->spins);
    if (!report->launch_spin_advice.empty())
      text += QObject::tr(". Note: %1").arg(QString::fromStdString(report->launch_spin_advice));
    if (const auto& t = report->track_offset)
      text += QObject::tr(
                  "; tracks' centre offset beyond what the analysis drew %1 px per axis (the "
                  "kinks of %2 shots; the profile's [analysis] centre_offset_px)")
                  .arg(t->excessPx(), 0, 'f', 4)
                  .arg(t->shots);
    if (!report->centre_offset_advice.empty())
      text += QObject::tr(". Note: %1").arg(QString::fromStdString(report->centre_offset_advice));
  } else {
    text += QObject::tr("No fit yet: %1").arg(QString::fromStdString(report.error().message));
  }
  out.summary = text;
  return out;
}

}  // namespace

void CampaignView::refresh() {
  if (dir_.isEmpty()) return;
  if (loader_.isRunning()) {
    refresh_again_ = true;
    return;
  }
  const std::string dir = dir_.toStdString();
  loader_.setFuture(QtConcurrent::run([dir] { return loadFolder(dir); }));
}

void CampaignView::setFolder(const QString& dir) {
  dir_ = dir;
  refresh();
}

QString CampaignView::summary() const {
  return summary_->text();
}

int CampaignView::pointCount(const std::string& name) const {
  for (const auto& c : charts_) {
    if (c.name != name) continue;
    int n = 0;
    for (const auto& s : c.plot.series)
      if (s.style == app::Series::Style::Points) n += static_cast<int>(s.x.size());
    return n;
  }
  return -1;
}

void CampaignView::setCharts(std::vector<ChartData> charts, const QString& summary) {
  charts_ = std::move(charts);
  summary_->setText(summary);
  rebuild();
  emit refreshed();
}

void CampaignView::rebuild() {
  auto* grid = static_cast<QGridLayout*>(grid_host_->layout());
  while (QLayoutItem* item = grid->takeAt(0)) {
    delete item->widget();
    delete item;
  }
  views_.clear();
  for (std::size_t i = 0; i < charts_.size(); ++i) {
    auto* cell = new QWidget;
    auto* v = new QVBoxLayout(cell);
    v->setContentsMargins(0, 0, 0, 0);
    QChartView* view = makeChartView(charts_[i].plot);
    view->setObjectName(QString::fromStdString("chart_" + charts_[i].name));
    views_.push_back(view);
    v->addWidget(view, 1);
    auto* row = new QHBoxLayout;
    row->addStretch();
    for (const char* kind : {"png", "svg", "csv"}) {
      auto* b = new QPushButton(tr("Export %1...").arg(QString(kind).toUpper()));
      row->addWidget(b);
      connect(b, &QPushButton::clicked, this, [this, i, kind] {
        const QString ext = QString(".") + kind;
        QString path = QFileDialog::getSaveFileName(
            this, tr("Export plot"),
            QDir(dir_).filePath(QString::fromStdString(charts_[i].name) + ext),
            QString("%1 (*%2)").arg(QString(kind).toUpper(), ext));
        if (path.isEmpty()) return;
        if (!path.endsWith(ext)) path += ext;
        QString error;
        if (!exportChartAs(static_cast<int>(i), path, &error)) summary_->setText(error);
      });
    }
    v->addLayout(row);
    grid->addWidget(cell, static_cast<int>(i) / 2, static_cast<int>(i) % 2);
  }
}

bool CampaignView::exportChart(int index, const QString& stem, QString* error) {
  for (const char* ext : {".png", ".svg", ".csv"})
    if (!exportChartAs(index, stem + ext, error)) return false;
  return true;
}

bool CampaignView::exportChartAs(int index, const QString& path, QString* error) {
  if (index < 0 || index >= static_cast<int>(charts_.size())) return false;
  const app::PlotSpec& plot = charts_[index].plot;
  auto failed = [&](const QString& why) {
    if (error) *error = tr("cannot write %1: %2").arg(path, why);
    return false;
  };
  if (path.endsWith(".csv")) {
    QFile csv(path);
    if (!csv.open(QIODevice::WriteOnly | QIODevice::Truncate) ||
        csv.write(QByteArray::fromStdString(plotCsv(plot))) < 0)
      return failed(csv.errorString());
    return true;
  }
  // A fresh view at a fixed size: the files do not depend on the window.
  std::unique_ptr<QChartView> view(makeChartView(plot));
  view->resize(800, 560);
  if (path.endsWith(".png")) {
    if (!view->grab().save(path)) return failed(tr("check the folder exists and is writable"));
    return true;
  }
  if (path.endsWith(".svg")) {
    QSvgGenerator svg;
    svg.setFileName(path);
    svg.setSize(view->size());
    svg.setViewBox(QRect(QPoint(0, 0), view->size()));
    svg.setTitle(QString::fromStdString(plot.title));
    QPainter painter;
    if (!painter.begin(&svg)) return failed(tr("check the folder exists and is writable"));
    view->render(&painter);
    painter.end();
    return true;
  }
  return failed(tr("choose a .png, .svg or .csv file name"));
}

bool CampaignView::exportAll(const QString& dir, QString* error) {
  for (std::size_t i = 0; i < charts_.size(); ++i)
    if (!exportChart(static_cast<int>(i),
                     QDir(dir).filePath(QString::fromStdString(charts_[i].name)), error))
      return false;
  return true;
}

}  // namespace collide::gui
