#include "app/gui/guarded_spin_box.hpp"

#include <QKeyEvent>
#include <QLineEdit>
#include <QWheelEvent>
#include <optional>

namespace collide::gui {
namespace {

// The number in a spin box's text without its prefix and suffix (none if it
// is not a number).
std::optional<double> typedNumber(const QAbstractSpinBox& box, QString text, const QString& prefix,
                                  const QString& suffix) {
  if (!prefix.isEmpty() && text.startsWith(prefix)) text.remove(0, prefix.size());
  if (!suffix.isEmpty() && text.endsWith(suffix)) text.chop(suffix.size());
  text = text.trimmed();
  bool ok = false;
  double v = box.locale().toDouble(text, &ok);
  if (!ok) v = text.toDouble(&ok);
  if (!ok) return std::nullopt;
  return v;
}

QString rangeTip(const QString& min, const QString& max, const QString& what, const QString& unit,
                 const QString& note) {
  QString tip = QObject::tr("%1: %2 to %3%4").arg(what, min, max, unit.isEmpty() ? "" : " " + unit);
  if (!note.isEmpty()) tip += "; " + note;
  return tip + QObject::tr(
                   ".\nType a value and press Enter; the wheel changes it only after a "
                   "click into the field.");
}

// Enter and Return, the keys that commit a typed value.
bool commits(const QKeyEvent* e) {
  return e->key() == Qt::Key_Return || e->key() == Qt::Key_Enter;
}

}  // namespace

GuardedDoubleSpinBox::GuardedDoubleSpinBox(QWidget* parent) : QDoubleSpinBox(parent) {
  setFocusPolicy(Qt::StrongFocus);  // the wheel does not take the focus
  setKeyboardTracking(false);       // a value is taken on Enter, not per keystroke
}

void GuardedDoubleSpinBox::setRangeWithTip(double min, double max, const QString& what,
                                           const QString& unit, const QString& note) {
  setRange(min, max);
  setToolTip(rangeTip(QString::number(minimum(), 'f', decimals()),
                      QString::number(maximum(), 'f', decimals()), what, unit, note));
}

QValidator::State GuardedDoubleSpinBox::validate(QString& input, int& pos) const {
  const QValidator::State s = QDoubleSpinBox::validate(input, pos);
  // A complete number out of range stays in the field (Intermediate) so that
  // it can be refused as typed, not cut to a prefix that happens to fit.
  if (s == QValidator::Invalid && typedNumber(*this, input, prefix(), suffix()))
    return QValidator::Intermediate;
  return s;
}

void GuardedDoubleSpinBox::checkTyped() {
  const auto v = typedNumber(*this, lineEdit()->text(), prefix(), suffix());
  if (v && (*v < minimum() || *v > maximum())) emit refused(*v, minimum(), maximum());
}

void GuardedDoubleSpinBox::keyPressEvent(QKeyEvent* event) {
  if (commits(event)) checkTyped();
  QDoubleSpinBox::keyPressEvent(event);
}

void GuardedDoubleSpinBox::focusOutEvent(QFocusEvent* event) {
  checkTyped();
  QDoubleSpinBox::focusOutEvent(event);
}

void GuardedDoubleSpinBox::wheelEvent(QWheelEvent* event) {
  if (!hasFocus()) {
    event->ignore();  // to the parent: the panel scrolls
    return;
  }
  QDoubleSpinBox::wheelEvent(event);
}

GuardedSpinBox::GuardedSpinBox(QWidget* parent) : QSpinBox(parent) {
  setFocusPolicy(Qt::StrongFocus);
  setKeyboardTracking(false);
}

void GuardedSpinBox::setRangeWithTip(int min, int max, const QString& what, const QString& unit,
                                     const QString& note) {
  setRange(min, max);
  setToolTip(rangeTip(QString::number(min), QString::number(max), what, unit, note));
}

QValidator::State GuardedSpinBox::validate(QString& input, int& pos) const {
  const QValidator::State s = QSpinBox::validate(input, pos);
  if (s == QValidator::Invalid && typedNumber(*this, input, prefix(), suffix()))
    return QValidator::Intermediate;
  return s;
}

void GuardedSpinBox::checkTyped() {
  const auto v = typedNumber(*this, lineEdit()->text(), prefix(), suffix());
  if (v && (*v < minimum() || *v > maximum())) emit refused(*v, minimum(), maximum());
}

void GuardedSpinBox::keyPressEvent(QKeyEvent* event) {
  if (commits(event)) checkTyped();
  QSpinBox::keyPressEvent(event);
}

void GuardedSpinBox::focusOutEvent(QFocusEvent* event) {
  checkTyped();
  QSpinBox::focusOutEvent(event);
}

void GuardedSpinBox::wheelEvent(QWheelEvent* event) {
  if (!hasFocus()) {
    event->ignore();
    return;
  }
  QSpinBox::wheelEvent(event);
}

}  // namespace collide::gui
