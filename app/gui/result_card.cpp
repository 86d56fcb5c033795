#include "app/gui/result_card.hpp"

#include <QFontMetrics>
#include <QGridLayout>
#include <QLabel>
#include <cmath>

namespace collide::gui {
namespace {

struct Row {
  const char* key;
  const char* name;
  const char* unit;
  int decimals;
};

constexpr Row kRows[] = {
    {"vn_m_s", "v<sub>n</sub>", "m/s", 4},
    {"vs_m_s", "v<sub>s</sub>", "m/s", 4},
    {"gamma_deg", "&gamma;", "deg", 2},
    {"e", "e", "", 4},
    {"beta", "&beta;", "", 4},
    {"f", "f", "", 4},
    {"t_collision_ms", "t<sub>collision</sub>", "ms", 3},
};

// "0.9712 ± 0.0031": the uncertainty with two significant figures, the value
// to the same decimal place.
QString withSigma(const vision::Measured& m, int fallback_decimals) {
  if (!std::isfinite(m.value)) return QStringLiteral("n/a");
  int decimals = fallback_decimals;
  if (std::isfinite(m.sigma) && m.sigma > 0)
    decimals = std::clamp(1 - static_cast<int>(std::floor(std::log10(m.sigma))), 0, 8);
  QString s = QString::number(m.value, 'f', decimals);
  if (std::isfinite(m.sigma) && m.sigma > 0)
    s += QString::fromUtf8(" ± ") + QString::number(m.sigma, 'f', decimals);
  return s;
}

}  // namespace

ResultCard::ResultCard(QWidget* parent) : QGroupBox(tr("Result"), parent) {
  setObjectName("result_card");
  auto* grid = new QGridLayout(this);
  title_ = new QLabel;
  title_->setObjectName("result_title");
  grid->addWidget(title_, 0, 0, 1, 3);
  int r = 1;
  for (const Row& row : kRows) {
    auto* name = new QLabel(QString::fromUtf8(row.name));
    name->setTextFormat(Qt::RichText);
    auto* value = new QLabel("-");
    value->setObjectName(QString("result_") + row.key);
    value->setTextInteractionFlags(Qt::TextSelectableByMouse);
    QFont f = value->font();
    f.setFamily("monospace");
    value->setFont(f);
    // Room for "value ± uncertainty" at the precision withSigma() uses.
    value->setMinimumWidth(
        QFontMetrics(f).horizontalAdvance(QString::fromUtf8("-0.0000000 ± 0.0000000")));
    grid->addWidget(name, r, 0);
    grid->addWidget(value, r, 1);
    grid->addWidget(new QLabel(row.unit), r, 2);
    labels_[row.key] = value;
    ++r;
  }
  flags_ = new QLabel;
  flags_->setObjectName("result_flags");
  flags_->setWordWrap(true);
  grid->addWidget(flags_, r++, 0, 1, 3);
  message_ = new QLabel;
  message_->setObjectName("result_message");
  message_->setWordWrap(true);
  // The message takes the card's remaining height: a long, wrapped error is
  // read whole, not cut after two lines (a wrapped label's height is not
  // known to the layout until its width is).
  message_->setAlignment(Qt::AlignLeft | Qt::AlignTop);
  message_->setSizePolicy(QSizePolicy::Preferred, QSizePolicy::Expanding);
  message_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  grid->addWidget(message_, r, 0, 1, 3);
  grid->setRowStretch(r, 1);
  setMessage({}, tr("no shot yet"));
}

void ResultCard::setAnalysis(const QString& shot_id, AnalysisPtr analysis,
                             const QString& time_origin) {
  shot_id_ = shot_id;
  analysis_ = std::move(analysis);
  values_.clear();
  if (!analysis_) return setMessage(shot_id, tr("no result"));
  const vision::CollisionProperties& c = analysis_->collision;
  values_["vn_m_s"] = c.vn_m_s;
  values_["vs_m_s"] = c.vs_m_s;
  values_["gamma_deg"] = c.gamma_deg;
  values_["e"] = c.e;
  values_["beta"] = c.beta;
  values_["f"] = c.f;
  values_["t_collision_ms"] = {c.t_collision_s.value * 1e3, c.t_collision_s.sigma * 1e3};
  for (const Row& row : kRows) labels_[row.key]->setText(withSigma(values_[row.key], row.decimals));
  title_->setText(tr("shot <b>%1</b>").arg(shot_id));
  QStringList flags = qualityFlags();
  flags_->setText(
      flags.isEmpty()
          ? tr("<span style='color:#1e8c3a'>quality: no flags</span>")
          : tr("<span style='color:#b03a2e'>quality flags: %1</span>").arg(flags.join(", ")));
  // The two-sphere analysis' clock starts at its first analysed frame (the
  // replay's caption gives the contact on the trigger's clock), the wall
  // analysis' at frame 0: say which.
  message_->setText(tr("t<sub>collision</sub> counts from %1. Collision instant from the track "
                       "before the impact: %2 ms; from the track after it: %3 ms")
                        .arg(time_origin)
                        .arg(c.t_collision_before_s * 1e3, 0, 'f', 3)
                        .arg(c.t_collision_after_s * 1e3, 0, 'f', 3));
}

void ResultCard::setMessage(const QString& shot_id, const QString& message) {
  shot_id_ = shot_id;
  analysis_.reset();
  values_.clear();
  for (auto& [key, label] : labels_) label->setText("-");
  title_->setText(shot_id.isEmpty() ? QString() : tr("shot <b>%1</b>").arg(shot_id));
  flags_->clear();
  message_->setText(message);
}

std::optional<vision::Measured> ResultCard::value(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end()) return std::nullopt;
  return it->second;
}

QStringList ResultCard::qualityFlags() const {
  QStringList out;
  if (analysis_)
    for (const auto& f : analysis_->quality_flags) out << QString::fromStdString(f);
  return out;
}

QString ResultCard::message() const {
  return message_->text();
}

}  // namespace collide::gui
