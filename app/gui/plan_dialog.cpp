#include "app/gui/plan_dialog.hpp"

#include <QDialogButtonBox>
#include <QFileDialog>
#include <QFileInfo>
#include <QFormLayout>
#include <QLabel>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QVBoxLayout>
#include <fstream>

#include "app/gui/guarded_spin_box.hpp"

namespace collide::gui {

PlanDialog::PlanDialog(ProfilePtr profile, QString profile_path, QWidget* parent)
    : QDialog(parent), profile_(std::move(profile)), profile_path_(std::move(profile_path)) {
  setWindowTitle(tr("Plan a shot"));
  setObjectName("plan_dialog");
  auto* layout = new QVBoxLayout(this);
  auto* form = new QFormLayout;
  incidence_ = new GuardedDoubleSpinBox;
  incidence_->setObjectName("plan_incidence");
  incidence_->setDecimals(1);
  incidence_->setRangeWithTip(0.0, 89.0, tr("Incidence at contact"), tr("deg"),
                              tr("angle between the line of centres and the approach; 0 head-on"));
  incidence_->setValue(45.0);
  speed_ = new GuardedDoubleSpinBox;
  speed_->setObjectName("plan_speed");
  speed_->setDecimals(2);
  speed_->setRangeWithTip(0.05, 30.0, tr("Each sphere's speed just before contact"), tr("m/s"),
                          tr("the launch calibration limits what can be fired"));
  speed_->setValue(2.0);
  form->addRow(tr("incidence (deg)"), incidence_);
  form->addRow(tr("speed at contact (m/s)"), speed_);
  layout->addLayout(form);

  auto* buttons = new QHBoxLayout;
  auto* plan_button = new QPushButton(tr("Plan"));
  plan_button->setObjectName("plan_button");
  plan_button->setDefault(true);
  nearest_button_ = new QPushButton(tr("Plan the nearest feasible shot"));
  nearest_button_->setObjectName("plan_nearest");
  nearest_button_->setEnabled(false);
  apply_ = new QPushButton(tr("Use this plan..."));
  apply_->setObjectName("plan_apply");
  apply_->setEnabled(false);
  apply_->setToolTip(
      tr("Save the profile with launcher 2's slide moved, load it and set the "
         "launchers' exit speeds (nothing is armed or fired)"));
  for (auto* b : {plan_button, nearest_button_, apply_}) buttons->addWidget(b);
  layout->addLayout(buttons);

  verdict_ = new QLabel;
  verdict_->setObjectName("plan_verdict");
  verdict_->setWordWrap(true);
  layout->addWidget(verdict_);
  text_ = new QPlainTextEdit;
  text_->setObjectName("plan_text");
  text_->setReadOnly(true);
  text_->setMinimumSize(560, 300);
  QFont mono = text_->font();
  mono.setFamily("monospace");
  text_->setFont(mono);
  layout->addWidget(text_, 1);
  auto* close = new QDialogButtonBox(QDialogButtonBox::Close);
  layout->addWidget(close);

  connect(plan_button, &QPushButton::clicked, this, &PlanDialog::plan);
  connect(nearest_button_, &QPushButton::clicked, this, &PlanDialog::planNearest);
  connect(apply_, &QPushButton::clicked, this, &PlanDialog::chooseFileAndApply);
  connect(close, &QDialogButtonBox::rejected, this, &QDialog::reject);
  if (!profile_) {
    verdict_->setText(tr("No rig profile is loaded: open one (File > Open rig profile) to plan."));
    plan_button->setEnabled(false);
  }
}

void PlanDialog::plan() {
  if (!profile_) return;
  app::PlanRequest request;
  request.incidence_deg = incidence_->value();
  request.speed_m_s = {speed_->value(), speed_->value()};
  app::Infeasible infeasible;
  auto planned = app::planShot(*profile_, request, &infeasible);
  plan_.reset();
  nearest_.reset();
  if (planned) {
    plan_ = std::move(planned).value();
    verdict_->setStyleSheet("color: #1e8c3a;");
    verdict_->setText(tr("The rig can fire this shot:"));
    text_->setPlainText(QString::fromStdString(app::describePlan(*plan_)));
  } else {
    nearest_ = infeasible.nearest;
    verdict_->setStyleSheet("color: #b03a2e; font-weight: bold;");
    verdict_->setText(
        tr("This shot cannot be fired: %1")
            .arg(QString::fromStdString(infeasible.reason.empty() ? planned.error().message
                                                                  : infeasible.reason)));
    text_->setPlainText(QString::fromStdString(planned.error().message));
  }
  nearest_button_->setEnabled(nearest_.has_value());
  apply_->setEnabled(plan_.has_value());
}

void PlanDialog::planNearest() {
  if (!nearest_) return;
  incidence_->setValue(nearest_->incidence_deg);
  speed_->setValue(std::min(nearest_->speed_m_s[0], nearest_->speed_m_s[1]));
  plan();
}

QString PlanDialog::shownText() const {
  return verdict_->text() + "\n" + text_->toPlainText();
}

QString PlanDialog::applyTo(const QString& path) {
  if (!plan_) return tr("plan a feasible shot first");
  std::ofstream out(path.toStdString(), std::ios::trunc);
  out << plan_->aimed.text;
  out.close();
  if (!out) return tr("cannot write %1: choose a folder you can write to").arg(path);
  emit planApplied(path, plan_->exit_speed_m_s);
  return {};
}

void PlanDialog::chooseFileAndApply() {
  if (!plan_) return;
  const QFileInfo current(profile_path_);
  const QString suggested =
      current.dir().filePath(QString("%1-aimed-%2deg.toml")
                                 .arg(current.completeBaseName())
                                 .arg(plan_->request.incidence_deg, 0, 'f', 0));
  const QString path = QFileDialog::getSaveFileName(this, tr("Save the aimed rig profile"),
                                                    suggested, tr("Rig profiles (*.toml)"));
  if (path.isEmpty()) return;
  if (const QString error = applyTo(path); !error.isEmpty()) {
    verdict_->setStyleSheet("color: #b03a2e; font-weight: bold;");
    verdict_->setText(error);
  }
}

}  // namespace collide::gui
