#pragma once
// The campaign view: the thesis' five plots of a shot folder (beta against
// -v_n/v_s with the fitted Walton lines, -v_s'/v_n against -v_s/v_n, f and e
// against tan psi, e against |v_n| with the fitted law), redrawn as analysed
// shots accumulate, each exportable as PNG, SVG and CSV; and the controls that
// start a campaign on the rig: a uniform sweep of the incidence angle, or the
// adaptive campaign (app/adaptive_campaign.hpp), which chooses each shot where
// mu or beta_0 is least known, says why, and stops at the target sigmas or
// when the shot budget is spent. The plots' content comes from app/ (the same
// PlotSpec `collide fit` draws), so the GUI and the command line always agree.
#include <QFutureWatcher>
#include <QWidget>
#include <string>
#include <vector>

#include "app/report/plot.hpp"

class QChartView;
class QVBoxLayout;
class QComboBox;
class QLabel;
class QPlainTextEdit;
class QSpinBox;
class QDoubleSpinBox;
class QPushButton;

namespace collide::gui {

struct ChartData {
  std::string name;  ///< file stem, e.g. "beta_vs_cot"
  app::PlotSpec plot;
};

/// Draws `plot` into a Qt chart (points with error bars, lines, axes, legend).
class QChartView* makeChartView(const app::PlotSpec& plot);

/// The plot's series as CSV: one block per series, "series,x,y,y_err" rows.
std::string plotCsv(const app::PlotSpec& plot);

class CampaignView : public QWidget {
  Q_OBJECT
 public:
  explicit CampaignView(QWidget* parent = nullptr);
  ~CampaignView() override;

  /// The folder whose analysed shots are plotted; reloads.
  void setFolder(const QString& dir);
  QString folder() const { return dir_; }
  /// Re-reads the folder's results and refits (on a worker thread).
  void refresh();
  /// Shows these plots (normally from refresh()).
  void setCharts(std::vector<ChartData> charts, const QString& summary);

  const std::vector<ChartData>& charts() const { return charts_; }
  /// Points (not lines) in chart `name`, summed over its point series.
  int pointCount(const std::string& name) const;
  QString summary() const;
  /// Writes chart `index` as <stem>.png, <stem>.svg and <stem>.csv.
  bool exportChart(int index, const QString& stem, QString* error = nullptr);
  /// Writes chart `index` to `path`, as its extension says (.png, .svg, .csv).
  bool exportChartAs(int index, const QString& path, QString* error = nullptr);
  /// All charts into `dir` under their names.
  bool exportAll(const QString& dir, QString* error = nullptr);

  bool refreshing() const { return loader_.isRunning(); }

 signals:
  /// Fire a campaign of `shots` shots into the shot folder.
  void campaignRequested(int shots, quint64 seed, double angle_min_deg, double angle_max_deg);
  /// Fire an adaptive campaign of at most `budget` shots, stopping when
  /// sigma(mu) <= target_sigma_mu and sigma(beta_0) <= target_sigma_beta0.
  void adaptiveCampaignRequested(int budget, quint64 seed, double angle_min_deg,
                                 double angle_max_deg, double target_sigma_mu,
                                 double target_sigma_beta0);
  void cancelRequested();
  /// The plots were redrawn.
  void refreshed();

 public:
  void setCampaignRunning(bool running);
  /// What the last campaign did (planned, fired, saved, why any was not
  /// fired), above the plots; `warning` when shots are missing or failed.
  void setReport(const QString& text, bool warning);
  QString reportText() const;
  /// One adaptive shot done: `line` says which angle, why it was chosen (the
  /// engine's reason) and any note; `sigmas` the fit's sigmas against the
  /// targets after it (app::adaptiveSigmasText).
  void addAdaptiveShot(const QString& line, const QString& sigmas);
  /// The adaptive campaign's per-shot lines so far (empty for a sweep).
  QStringList adaptiveLog() const;
  /// "After shot N: sigma(mu) ... (target ...), ..." (empty for a sweep).
  QString adaptiveStatus() const;
  bool adaptiveSelected() const;

  struct Loaded {
    std::vector<ChartData> charts;
    QString summary;
  };

 private:
  // The constructor's parts, top to bottom.
  void addControls(QVBoxLayout* layout);
  void addAdaptiveTargets(QVBoxLayout* layout);
  void addReportArea(QVBoxLayout* layout);
  void rebuild();
  void showMode();

  QString dir_;
  std::vector<ChartData> charts_;
  std::vector<QChartView*> views_;
  QWidget* grid_host_ = nullptr;
  QLabel* summary_ = nullptr;
  QLabel* report_ = nullptr;
  QSpinBox* shots_ = nullptr;
  QSpinBox* seed_ = nullptr;
  QDoubleSpinBox* angle_min_ = nullptr;
  QDoubleSpinBox* angle_max_ = nullptr;
  QComboBox* mode_ = nullptr;
  QWidget* adaptive_controls_ = nullptr;
  QDoubleSpinBox* target_mu_ = nullptr;
  QDoubleSpinBox* target_beta0_ = nullptr;
  QPlainTextEdit* adaptive_log_ = nullptr;
  QLabel* adaptive_status_ = nullptr;
  QStringList adaptive_lines_;
  QPushButton* run_ = nullptr;
  QPushButton* cancel_ = nullptr;
  QFutureWatcher<Loaded> loader_;
  bool refresh_again_ = false;
};

}  // namespace collide::gui
