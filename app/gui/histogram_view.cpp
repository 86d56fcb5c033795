#include "app/gui/histogram_view.hpp"

#include <QLocale>
#include <QPainter>
#include <algorithm>
#include <cmath>

namespace collide::gui {

Histogram histogramOf(const cv::Mat& image, int max_value, int bins) {
  Histogram h;
  h.max_value = std::max(1, max_value);
  h.counts.assign(static_cast<std::size_t>(std::max(1, bins)), 0);
  if (image.empty() || image.channels() != 1) return h;
  const double per_bin = double(h.counts.size()) / (h.max_value + 1.0);
  auto add = [&](int v) {
    if (v >= h.max_value) ++h.saturated;
    const auto bin = static_cast<std::size_t>(std::min(v, h.max_value) * per_bin);
    ++h.counts[std::min(bin, h.counts.size() - 1)];
  };
  for (int r = 0; r < image.rows; ++r) {
    if (image.depth() == CV_16U) {
      const auto* row = image.ptr<std::uint16_t>(r);
      for (int c = 0; c < image.cols; ++c) add(row[c]);
    } else if (image.depth() == CV_8U) {
      const auto* row = image.ptr<std::uint8_t>(r);
      for (int c = 0; c < image.cols; ++c) add(row[c]);
    } else {
      return h;  // not a camera format
    }
  }
  h.pixels = static_cast<std::uint64_t>(image.total());
  return h;
}

HistogramView::HistogramView(QWidget* parent) : QWidget(parent) {
  setMinimumSize(160, 90);
  setToolTip(
      tr("Brightness histogram of the shown frame (log counts), 0 to full scale; red: "
         "pixels at full scale (saturated)"));
}

void HistogramView::setHistogram(Histogram h) {
  histogram_ = std::move(h);
  update();
}

QString HistogramView::warning() const {
  if (histogram_.saturated == 0) return {};
  return tr("%1 % of the pixels saturated (%2 at %3): shorten the exposure or lower the gain")
      .arg(100.0 * histogram_.saturatedFraction(), 0, 'f',
           histogram_.saturatedFraction() < 0.01 ? 2 : 1)
      .arg(QLocale().toString(static_cast<qulonglong>(histogram_.saturated)))
      .arg(histogram_.max_value);
}

void HistogramView::paintEvent(QPaintEvent*) {
  QPainter p(this);
  p.fillRect(rect(), QColor(30, 30, 30));
  const auto& c = histogram_.counts;
  if (c.empty() || histogram_.pixels == 0) return;
  const double top = std::log10(1.0 + double(*std::max_element(c.begin(), c.end())));
  const double w = double(width()) / double(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double h = top > 0 ? std::log10(1.0 + double(c[i])) / top * (height() - 4) : 0;
    const bool last = i + 1 == c.size();
    p.fillRect(QRectF(i * w, height() - h, std::max(1.0, w - 1), h),
               last && histogram_.saturated ? QColor(230, 60, 50) : QColor(170, 170, 170));
  }
}

}  // namespace collide::gui
