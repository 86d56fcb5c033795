#pragma once
// The campaign view: the thesis' five plots of a shot folder (beta against
// -v_n/v_s with the fitted Walton lines, -v_s'/v_n against -v_s/v_n, f and e
// against tan psi, e against |v_n| with the fitted law), redrawn as analysed
// shots accumulate, each exportable as PNG, SVG and CSV; and the controls that
// start a campaign on the rig. The plots' content comes from app/ (the same
// PlotSpec `collide fit` draws), so the GUI and the command line always agree.
#include <QFutureWatcher>
#include <QWidget>
#include <string>
#include <vector>

#include "app/report/plot.hpp"

class QChartView;
class QLabel;
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
  void cancelRequested();
  /// The plots were redrawn.
  void refreshed();

 public:
  void setCampaignRunning(bool running);
  /// What the last campaign did (planned, fired, saved, why any was not
  /// fired), above the plots; `warning` when shots are missing or failed.
  void setReport(const QString& text, bool warning);
  QString reportText() const;

  struct Loaded {
    std::vector<ChartData> charts;
    QString summary;
  };

 private:
  void rebuild();

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
  QPushButton* run_ = nullptr;
  QPushButton* cancel_ = nullptr;
  QFutureWatcher<Loaded> loader_;
  bool refresh_again_ = false;
};

}  // namespace collide::gui
