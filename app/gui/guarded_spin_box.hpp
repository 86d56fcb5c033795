#pragma once
// Spin boxes that cannot be changed by accident. A set-point on a rig must
// change only when the user means it:
// - the mouse wheel changes the value only when the box has the keyboard
//   focus (click or Tab into it first); over an unfocused box the wheel
//   scrolls the panel instead;
// - a typed number outside the range is not silently cut to a prefix ("15"
//   becoming "1") nor clamped: it is kept in the field while typing and, on
//   Enter or leaving the field, refused (the previous value stays) and
//   reported through `refused` with the allowed range, so the owner can say so.
// Every box carries a tooltip with its range and unit (setRangeWithTip).
#include <QDoubleSpinBox>
#include <QSpinBox>

namespace collide::gui {

class GuardedDoubleSpinBox : public QDoubleSpinBox {
  Q_OBJECT
 public:
  explicit GuardedDoubleSpinBox(QWidget* parent = nullptr);
  /// Range, and a tooltip "<what>: <min> to <max> <unit>[; <note>]".
  void setRangeWithTip(double min, double max, const QString& what, const QString& unit,
                       const QString& note = {});

 signals:
  /// A typed value outside [minimum, maximum] was refused; the value is unchanged.
  void refused(double typed, double minimum, double maximum);

 protected:
  QValidator::State validate(QString& input, int& pos) const override;
  void keyPressEvent(QKeyEvent* event) override;
  void focusOutEvent(QFocusEvent* event) override;
  void wheelEvent(QWheelEvent* event) override;

 private:
  void checkTyped();
};

class GuardedSpinBox : public QSpinBox {
  Q_OBJECT
 public:
  explicit GuardedSpinBox(QWidget* parent = nullptr);
  void setRangeWithTip(int min, int max, const QString& what, const QString& unit = {},
                       const QString& note = {});

 signals:
  void refused(double typed, double minimum, double maximum);

 protected:
  QValidator::State validate(QString& input, int& pos) const override;
  void keyPressEvent(QKeyEvent* event) override;
  void focusOutEvent(QFocusEvent* event) override;
  void wheelEvent(QWheelEvent* event) override;

 private:
  void checkTyped();
};

}  // namespace collide::gui
