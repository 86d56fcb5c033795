#pragma once
// Plan a shot from the GUI (issue 16 §1, as `collide plan`): the physicist
// types the incidence and the speed wanted at the contact; the dialog shows
// how to set the rig (launcher 2's slide, exit speeds, pressures, valve
// delays, where and when the spheres meet) and Walton's prediction, or why
// the wish cannot be fired with the nearest shot that can (one click plans
// it). "Use this plan" saves the aimed profile (the slide moved) under a name
// the user chooses and hands it with the exit speeds to the main window,
// which loads it and sets the launchers: nothing is pressurised or fired here.
#include <QDialog>
#include <array>
#include <optional>

#include "app/gui/rig_worker.hpp"
#include "app/plan.hpp"

class QLabel;
class QPlainTextEdit;
class QPushButton;

namespace collide::gui {

class GuardedDoubleSpinBox;

class PlanDialog : public QDialog {
  Q_OBJECT
 public:
  PlanDialog(ProfilePtr profile, QString profile_path, QWidget* parent = nullptr);

  /// Plans what the fields say; the result is shown and kept.
  void plan();
  const std::optional<app::ShotPlan>& currentPlan() const { return plan_; }
  /// The nearest feasible wish after a refused one.
  const std::optional<app::PlanRequest>& nearest() const { return nearest_; }
  QString shownText() const;
  /// Writes the plan's aimed profile to `path` and emits planApplied.
  /// Returns an error message, empty on success.
  QString applyTo(const QString& path);

 signals:
  /// The aimed profile was written to `profile_path`; the launchers should be
  /// set to `exit_speeds_m_s` once it is loaded.
  void planApplied(QString profile_path, std::array<double, 2> exit_speeds_m_s);

 private:
  void planNearest();
  void chooseFileAndApply();

  ProfilePtr profile_;
  QString profile_path_;
  GuardedDoubleSpinBox* incidence_ = nullptr;
  GuardedDoubleSpinBox* speed_ = nullptr;
  QPlainTextEdit* text_ = nullptr;
  QLabel* verdict_ = nullptr;
  QPushButton* nearest_button_ = nullptr;
  QPushButton* apply_ = nullptr;
  std::optional<app::ShotPlan> plan_;
  std::optional<app::PlanRequest> nearest_;
};

}  // namespace collide::gui
