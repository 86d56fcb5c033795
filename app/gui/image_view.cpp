#include "app/gui/image_view.hpp"

#include <QKeyEvent>
#include <QMouseEvent>
#include <QPainter>
#include <QPainterPath>
#include <QWheelEvent>
#include <algorithm>
#include <cmath>
#include <cstring>

#include "vision/video_export.hpp"

namespace collide::gui {

QImage toDisplayImage(const cv::Mat& image, vision::PixelFormat format) {
  if (image.empty()) return {};
  // The scaling video export uses too: what is written is what was seen.
  const cv::Mat grey8 = vision::displayGrey8(image, format);
  QImage out(grey8.cols, grey8.rows, QImage::Format_Grayscale8);
  for (int r = 0; r < grey8.rows; ++r)
    std::memcpy(out.scanLine(r), grey8.ptr(r), static_cast<std::size_t>(grey8.cols));
  return out;
}

ImageView::ImageView(QWidget* parent) : QWidget(parent) {
  setMinimumSize(160, 120);
  setSizePolicy(QSizePolicy::Expanding, QSizePolicy::Expanding);
  setAttribute(Qt::WA_OpaquePaintEvent);
  setMouseTracking(true);  // the pixel under the cursor, without a button held
  setFocusPolicy(Qt::ClickFocus);
  setToolTip(
      tr("Wheel: zoom about the cursor; left drag: pan; right drag (or Shift + left "
         "drag): measure; double-click or 0: whole image; Esc: clear the measurement"));
}

void ImageView::setImage(QImage image) {
  // A new size (another shot or camera) starts from the whole image; frames
  // of the same size keep the zoom, so stepping through a burst stays put.
  if (image.size() != image_.size()) {
    zoom_ = 1.0;
    centre_ = QPointF(image.width() / 2.0, image.height() / 2.0);
    measure_.reset();
  }
  image_ = std::move(image);
  raw_ = cv::Mat();
  message_.clear();
  update();
}

void ImageView::setRawFrame(cv::Mat raw, vision::PixelFormat format) {
  raw_ = std::move(raw);
  raw_format_ = format;
}

void ImageView::setOverlay(Overlay overlay) {
  overlay_ = std::move(overlay);
  update();
}

void ImageView::clear(const QString& message) {
  image_ = {};
  raw_ = cv::Mat();
  overlay_ = {};
  message_ = message;
  measure_.reset();
  cursor_text_.clear();
  update();
}

void ImageView::setPixelSize(double metres_per_px) {
  pixel_size_m_ = std::isfinite(metres_per_px) && metres_per_px > 0 ? metres_per_px : 0.0;
  update();
}

void ImageView::setCrosshair(bool on) {
  crosshair_ = on;
  update();
}

double ImageView::scale() const {
  if (image_.isNull()) return 1.0;
  return zoom_ * std::min(width() / double(image_.width()), height() / double(image_.height()));
}

// Image space: pixel (u, v) covers [u, u + 1) x [v, v + 1), its centre at
// (u + 0.5, v + 0.5); centre_ is the image-space point at the widget's centre.
QPointF ImageView::toImage(QPointF w) const {
  const QPointF wc(width() / 2.0, height() / 2.0);
  return (w - wc) / scale() + centre_ - QPointF(0.5, 0.5);
}

QPointF ImageView::toWidget(QPointF q) const {
  const QPointF wc(width() / 2.0, height() / 2.0);
  return wc + (q + QPointF(0.5, 0.5) - centre_) * scale();
}

void ImageView::clampCentre() {
  if (image_.isNull()) return;
  const double s = scale();
  auto clampAxis = [](double c, double half_visible, double extent) {
    return 2 * half_visible >= extent ? extent / 2
                                      : std::clamp(c, half_visible, extent - half_visible);
  };
  centre_.setX(clampAxis(centre_.x(), width() / (2 * s), image_.width()));
  centre_.setY(clampAxis(centre_.y(), height() / (2 * s), image_.height()));
}

void ImageView::zoomAbout(double zoom, QPointF anchor) {
  if (image_.isNull()) return;
  const QPointF wc(width() / 2.0, height() / 2.0);
  const QPointF under = (anchor - wc) / scale() + centre_;  // stays under the anchor
  zoom_ = std::clamp(zoom, 1.0, kMaxZoom);
  centre_ = under - (anchor - wc) / scale();
  clampCentre();
  updateCursor(anchor);
  update();
}

void ImageView::resetZoom() {
  zoom_ = 1.0;
  centre_ = QPointF(image_.width() / 2.0, image_.height() / 2.0);
  update();
}

void ImageView::updateCursor(QPointF w) {
  QString text;
  if (!image_.isNull()) {
    const QPointF q = toImage(w);
    const int u = static_cast<int>(std::floor(q.x() + 0.5));
    const int v = static_cast<int>(std::floor(q.y() + 0.5));
    if (u >= 0 && v >= 0 && u < image_.width() && v < image_.height()) {
      if (!raw_.empty() && raw_.cols == image_.width() && raw_.rows == image_.height()) {
        const int value =
            raw_.depth() == CV_16U ? raw_.at<std::uint16_t>(v, u) : raw_.at<std::uint8_t>(v, u);
        text =
            tr("u %1, v %2: %3 of %4").arg(u).arg(v).arg(value).arg(vision::maxValue(raw_format_));
      } else {
        text = tr("u %1, v %2: %3 of 255").arg(u).arg(v).arg(qGray(image_.pixel(u, v)));
      }
    }
  }
  if (text != cursor_text_) {
    cursor_text_ = text;
    emit cursorMoved(text);
    update();
  }
}

QString ImageView::measurementText() const {
  if (!measure_) return {};
  const double px = measure_->length();
  // Angle from the image's u axis, counter-clockwise as seen (v points down).
  const double angle =
      std::atan2(-(measure_->dy()), measure_->dx()) * 180.0 / 3.14159265358979323846;
  QString text = tr("%1 px").arg(px, 0, 'f', 1);
  if (pixel_size_m_ > 0) text += tr(" = %1 mm").arg(px * pixel_size_m_ * 1e3, 0, 'f', 2);
  return text + tr(", %1°").arg(angle, 0, 'f', 1);
}

void ImageView::wheelEvent(QWheelEvent* event) {
  const double notches = event->angleDelta().y() / 120.0;
  if (image_.isNull() || notches == 0) {
    event->ignore();
    return;
  }
  zoomAbout(zoom_ * std::pow(1.25, notches), event->position());
  event->accept();  // never passed on: a scroll area around must not scroll
}

void ImageView::mousePressEvent(QMouseEvent* event) {
  if (image_.isNull()) return QWidget::mousePressEvent(event);
  const bool measure =
      event->button() == Qt::RightButton ||
      (event->button() == Qt::LeftButton && (event->modifiers() & Qt::ShiftModifier));
  if (measure) {
    drag_ = Drag::Measure;
    const QPointF q = toImage(event->position());
    measure_ = QLineF(q, q);
  } else if (event->button() == Qt::LeftButton) {
    drag_ = Drag::Pan;
    drag_start_widget_ = event->position();
    drag_start_centre_ = centre_;
  }
  event->accept();
  update();
}

void ImageView::mouseMoveEvent(QMouseEvent* event) {
  if (drag_ == Drag::Pan) {
    centre_ = drag_start_centre_ - (event->position() - drag_start_widget_) / scale();
    clampCentre();
  } else if (drag_ == Drag::Measure && measure_) {
    measure_->setP2(toImage(event->position()));
  }
  updateCursor(event->position());
  update();
}

void ImageView::mouseReleaseEvent(QMouseEvent* event) {
  if (drag_ == Drag::Measure && measure_ && measure_->length() < 0.5) measure_.reset();  // a click
  drag_ = Drag::None;
  event->accept();
  update();
}

void ImageView::mouseDoubleClickEvent(QMouseEvent* event) {
  resetZoom();
  event->accept();
}

void ImageView::keyPressEvent(QKeyEvent* event) {
  const QPointF middle(width() / 2.0, height() / 2.0);
  switch (event->key()) {
    case Qt::Key_Escape:
      if (!measure_) return QWidget::keyPressEvent(event);
      measure_.reset();
      update();
      return;
    case Qt::Key_0: resetZoom(); return;
    case Qt::Key_Plus:
    case Qt::Key_Equal: zoomAbout(zoom_ * 1.25, middle); return;
    case Qt::Key_Minus: zoomAbout(zoom_ / 1.25, middle); return;
    default: QWidget::keyPressEvent(event);
  }
}

void ImageView::leaveEvent(QEvent* event) {
  if (!cursor_text_.isEmpty()) {
    cursor_text_.clear();
    emit cursorMoved({});
    update();
  }
  QWidget::leaveEvent(event);
}

void ImageView::paintEvent(QPaintEvent*) {
  QPainter p(this);
  p.fillRect(rect(), QColor(24, 24, 24));
  if (image_.isNull()) {
    p.setPen(QColor(200, 200, 200));
    p.drawText(rect(), Qt::AlignCenter | Qt::TextWordWrap,
               message_.isEmpty() ? tr("no frame") : message_);
    return;
  }
  clampCentre();  // the widget may have been resized
  const double s = scale();
  const QRectF target(toWidget(QPointF(-0.5, -0.5)),
                      QSizeF(image_.width() * s, image_.height() * s));
  const QRectF visible = target.intersected(QRectF(rect()));
  // Only the visible part of the image is drawn (a zoomed frame is large);
  // nearest pixels when enlarged, so single pixels can be inspected.
  const QRectF source((visible.left() - target.left()) / s, (visible.top() - target.top()) / s,
                      visible.width() / s, visible.height() / s);
  p.setRenderHint(QPainter::SmoothPixmapTransform, s < 1.0);
  p.drawImage(visible, image_, source);

  p.save();
  p.setClipRect(visible);
  p.translate(target.topLeft());
  p.scale(s, s);
  p.translate(0.5, 0.5);
  paintOverlay(p, s);
  p.restore();
  if (!overlay_.caption.isEmpty()) {
    p.setPen(QColor(255, 220, 80));
    p.drawText(visible.adjusted(6, 4, -6, -4), Qt::AlignLeft | Qt::AlignTop, overlay_.caption);
  }
  paintLegend(p, visible);
  p.setClipRect(visible);
  paintTools(p);
}

void ImageView::paintOverlay(QPainter& p, double scale) const {
  p.setRenderHint(QPainter::Antialiasing);
  auto pen = [&](const QColor& c, bool dashed) {
    QPen pen(c, 1.5 / scale);
    pen.setCosmetic(false);
    if (dashed) pen.setStyle(Qt::DashLine);
    return pen;
  };
  p.setBrush(Qt::NoBrush);
  for (const auto& path : overlay_.paths) {
    if (path.points.size() < 2) continue;
    QPainterPath pp(path.points.front());
    for (std::size_t i = 1; i < path.points.size(); ++i) pp.lineTo(path.points[i]);
    p.setPen(pen(path.colour, path.dashed));
    p.drawPath(pp);
  }
  for (const auto& c : overlay_.circles) {
    p.setPen(pen(c.colour, c.dashed));
    p.drawEllipse(c.centre, c.radius, c.radius);
  }
  const double arm = 5.0 / scale;
  QFont font = p.font();
  font.setPointSizeF(std::max(1.0, font.pointSizeF() / scale));
  p.setFont(font);
  for (const auto& m : overlay_.markers) {
    p.setPen(pen(m.colour, false));
    p.drawLine(m.at + QPointF(-arm, 0), m.at + QPointF(arm, 0));
    p.drawLine(m.at + QPointF(0, -arm), m.at + QPointF(0, arm));
    if (!m.label.isEmpty()) p.drawText(m.at + QPointF(arm * 1.5, -arm * 1.5), m.label);
  }
}

void ImageView::paintLegend(QPainter& p, const QRectF& visible) const {
  if (overlay_.legend.empty()) return;
  // In the image's bottom-left corner, on a dark band, clear of the spheres
  // in the middle of the field.
  const QFontMetrics fm(p.font());
  const int line = fm.height();
  int width = 0;
  for (const auto& e : overlay_.legend) width = std::max(width, fm.horizontalAdvance(e.text));
  const int h = line * static_cast<int>(overlay_.legend.size()) + 6;
  const QRect box(static_cast<int>(visible.left()) + 6, static_cast<int>(visible.bottom()) - h - 4,
                  width + line + 14, h);
  p.fillRect(box, QColor(0, 0, 0, 150));
  int y = box.top() + 3;
  for (const auto& e : overlay_.legend) {
    p.fillRect(QRect(box.left() + 5, y + line / 4, line / 2, line / 2), e.colour);
    p.setPen(e.colour.lighter(115));
    p.drawText(QPoint(box.left() + 5 + line, y + fm.ascent()), e.text);
    y += line;
  }
}

// Crosshair, measurement and the pixel readout, in widget coordinates so
// that they keep their size at any zoom.
void ImageView::paintTools(QPainter& p) const {
  p.setRenderHint(QPainter::Antialiasing);
  if (crosshair_) {
    const QPointF c = toWidget(QPointF((image_.width() - 1) / 2.0, (image_.height() - 1) / 2.0));
    QPen pen(QColor(80, 220, 255, 200), 1, Qt::DashLine);
    p.setPen(pen);
    p.drawLine(QPointF(0, c.y()), QPointF(width(), c.y()));
    p.drawLine(QPointF(c.x(), 0), QPointF(c.x(), height()));
  }
  if (measure_) {
    const QPointF a = toWidget(measure_->p1()), b = toWidget(measure_->p2());
    p.setPen(QPen(QColor(255, 90, 220), 1.5));
    p.drawLine(a, b);
    for (const QPointF& e : {a, b}) p.drawEllipse(e, 3, 3);
    const QString text = measurementText();
    const QFontMetrics fm(p.font());
    const QRectF box(b + QPointF(8, 8), QSizeF(fm.horizontalAdvance(text) + 8, fm.height() + 4));
    p.fillRect(box, QColor(0, 0, 0, 170));
    p.drawText(box, Qt::AlignCenter, text);
  }
  if (!cursor_text_.isEmpty()) {
    const QFontMetrics fm(p.font());
    const QString text =
        zoom_ > 1.0 ? cursor_text_ + tr("   zoom %1x").arg(zoom_, 0, 'f', 1) : cursor_text_;
    const QRectF box(width() - fm.horizontalAdvance(text) - 16, height() - fm.height() - 10,
                     fm.horizontalAdvance(text) + 10, fm.height() + 6);
    p.fillRect(box, QColor(0, 0, 0, 170));
    p.setPen(QColor(230, 230, 230));
    p.drawText(box, Qt::AlignCenter, text);
  }
}

}  // namespace collide::gui
