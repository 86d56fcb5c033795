#pragma once
// The result card: one shot's collision properties (v_n, v_s, gamma, e, beta,
// f, and the collision instant), each with its standard uncertainty, and the
// quality flags that say when not to trust them.
#include <QGroupBox>
#include <QString>
#include <map>
#include <optional>

#include "app/gui/shot_analysis_service.hpp"

class QLabel;
class QGridLayout;

namespace collide::gui {

class ResultCard : public QGroupBox {
  Q_OBJECT
 public:
  explicit ResultCard(QWidget* parent = nullptr);

  /// Shows the analysis of shot `shot_id`; `time_origin` says where its clock
  /// starts (timeOrigin() of the shot).
  void setAnalysis(const QString& shot_id, AnalysisPtr analysis, const QString& time_origin);
  /// No numbers: a message instead ("analysing...", an error, "analysis not available").
  void setMessage(const QString& shot_id, const QString& message);

  bool hasResult() const { return analysis_ != nullptr; }
  QString shotId() const { return shot_id_; }
  /// The value on the card, by name: "vn_m_s", "vs_m_s", "gamma_deg", "e",
  /// "beta", "f", "t_collision_ms".
  std::optional<vision::Measured> value(const std::string& name) const;
  QStringList qualityFlags() const;
  QString message() const;

 private:
  QString shot_id_;
  AnalysisPtr analysis_;
  std::map<std::string, vision::Measured> values_;
  std::map<std::string, QLabel*> labels_;
  QLabel* title_ = nullptr;
  QLabel* flags_ = nullptr;
  QLabel* message_ = nullptr;
};

}  // namespace collide::gui
