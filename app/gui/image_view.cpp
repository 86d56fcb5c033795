#include "app/gui/image_view.hpp"

#include <QPainter>
#include <QPainterPath>
#include <algorithm>

namespace collide::gui {

QImage toDisplayImage(const cv::Mat& image, vision::PixelFormat format) {
  if (image.empty()) return {};
  cv::Mat grey8;
  if (image.depth() == CV_8U)
    grey8 = image;
  else
    image.convertTo(grey8, CV_8U, 255.0 / vision::maxValue(format));
  QImage out(grey8.cols, grey8.rows, QImage::Format_Grayscale8);
  for (int r = 0; r < grey8.rows; ++r)
    std::memcpy(out.scanLine(r), grey8.ptr(r), static_cast<std::size_t>(grey8.cols));
  return out;
}

ImageView::ImageView(QWidget* parent) : QWidget(parent) {
  setMinimumSize(160, 120);
  setSizePolicy(QSizePolicy::Expanding, QSizePolicy::Expanding);
  setAttribute(Qt::WA_OpaquePaintEvent);
}

void ImageView::setImage(QImage image) {
  image_ = std::move(image);
  message_.clear();
  update();
}

void ImageView::setOverlay(Overlay overlay) {
  overlay_ = std::move(overlay);
  update();
}

void ImageView::clear(const QString& message) {
  image_ = {};
  overlay_ = {};
  message_ = message;
  update();
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
  // Fit the image, keeping its aspect ratio; pixel (u, v) centre maps to
  // (u + 0.5, v + 0.5) in image space.
  const double scale =
      std::min(width() / double(image_.width()), height() / double(image_.height()));
  const double w = image_.width() * scale, h = image_.height() * scale;
  const QRectF target((width() - w) / 2, (height() - h) / 2, w, h);
  p.setRenderHint(QPainter::SmoothPixmapTransform, scale < 1.0);
  p.drawImage(target, image_);

  p.save();
  p.translate(target.topLeft());
  p.scale(scale, scale);
  p.translate(0.5, 0.5);
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
  p.restore();
  if (!overlay_.caption.isEmpty()) {
    p.setPen(QColor(255, 220, 80));
    p.drawText(QRectF(target).adjusted(6, 4, -6, -4), Qt::AlignLeft | Qt::AlignTop,
               overlay_.caption);
  }
  if (!overlay_.legend.empty()) {
    // In the image's bottom-left corner, on a dark band, clear of the spheres
    // in the middle of the field.
    const QFontMetrics fm(p.font());
    const int line = fm.height();
    int width = 0;
    for (const auto& e : overlay_.legend) width = std::max(width, fm.horizontalAdvance(e.text));
    const int h = line * static_cast<int>(overlay_.legend.size()) + 6;
    const QRect box(target.left() + 6, target.bottom() - h - 4, width + line + 14, h);
    p.fillRect(box, QColor(0, 0, 0, 150));
    int y = box.top() + 3;
    for (const auto& e : overlay_.legend) {
      p.fillRect(QRect(box.left() + 5, y + line / 4, line / 2, line / 2), e.colour);
      p.setPen(e.colour.lighter(115));
      p.drawText(QPoint(box.left() + 5 + line, y + fm.ascent()), e.text);
      y += line;
    }
  }
}

}  // namespace collide::gui
