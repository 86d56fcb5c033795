#pragma once
// The calibration dialog: exit speeds measured from recorded shots against
// the launch pressure (regulator read-back when the valve fired), the
// profile's cubic v(p) and its least-squares refit (analysis/calibration.hpp)
// drawn over them, and, after confirmation, the refitted coefficients written
// into the rig profile file (atomically, the previous file kept as .bak).
// The pressures the launches span are shaded; a refit is not extrapolated
// beyond them silently: when the profile's working range is wider, saving
// narrows it to the measured range (the offered default) or is refused.
#include <QDialog>
#include <optional>
#include <vector>

#include "analysis/calibration.hpp"
#include "app/gui/rig_worker.hpp"
#include "app/gui/shot_analysis_service.hpp"

class QChartView;
class QCheckBox;
class QLabel;
class QPushButton;
class QTableWidget;

namespace collide::gui {

class CalibrationDialog : public QDialog {
  Q_OBJECT
 public:
  /// `profile_path`: the file to save into (empty: the profile is built in and
  /// cannot be saved).
  CalibrationDialog(ProfilePtr profile, QString profile_path, QWidget* parent = nullptr);

  void setLaunches(std::vector<MeasuredLaunch> launches);
  const std::vector<MeasuredLaunch>& launches() const { return launches_; }
  /// Refits the cubic to the launches. False (and the reason shown) if it cannot.
  bool refit();
  const std::optional<CalibrationRefit>& result() const { return refit_; }
  /// Writes the refitted coefficients into the profile file. With `ask`, only
  /// after the user confirms. Errors: no refit, no file, the edited profile
  /// does not parse, the file cannot be written (all shown in the dialog too).
  Status saveToProfile(bool ask = true);
  QString backupPath() const { return backup_path_; }
  QString statusText() const;
  /// The profile's working range reaches beyond the measured pressures.
  bool extrapolates() const { return extrapolates_; }
  /// Measured pressure range (kPa) of the launches (0, 0 if none).
  std::pair<double, double> measuredRange() const { return {measured_lo_, measured_hi_}; }

 signals:
  /// The profile file was rewritten: reload it.
  void profileSaved(QString path);

 private:
  void redraw();
  void updateSave();

  ProfilePtr profile_;
  QString profile_path_;
  std::vector<MeasuredLaunch> launches_;
  std::optional<CalibrationRefit> refit_;
  QString backup_path_;
  QTableWidget* table_ = nullptr;
  QChartView* chart_ = nullptr;
  QLabel* status_ = nullptr;
  QPushButton* refit_button_ = nullptr;
  QPushButton* save_button_ = nullptr;
  QCheckBox* narrow_ = nullptr;
  bool extrapolates_ = false;
  double measured_lo_ = 0, measured_hi_ = 0;
};

}  // namespace collide::gui
