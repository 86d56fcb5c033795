#pragma once
// The brightness histogram of the live frame with a saturation warning, as a
// vendor viewer shows it beside the image: bins over the format's full scale
// (log counts), the share of pixels at full scale in red when there are any.
#include <QWidget>
#include <opencv2/core.hpp>
#include <vector>

namespace collide::gui {

struct Histogram {
  std::vector<std::uint64_t> counts;  ///< bins spanning 0..max_value
  std::uint64_t pixels = 0;
  std::uint64_t saturated = 0;  ///< pixels at max_value (or above: a 16-bit field with fewer bits)
  int max_value = 255;
  double saturatedFraction() const { return pixels ? double(saturated) / double(pixels) : 0.0; }
};

/// Histogram of a CV_8U or CV_16U single-channel image over 0..max_value.
Histogram histogramOf(const cv::Mat& image, int max_value, int bins = 64);

class HistogramView : public QWidget {
  Q_OBJECT
 public:
  explicit HistogramView(QWidget* parent = nullptr);
  void setHistogram(Histogram h);
  const Histogram& histogram() const { return histogram_; }
  /// "3.2 % of the pixels saturated (9,830 at 4095)", or empty when none are.
  QString warning() const;
  QSize sizeHint() const override { return {220, 120}; }

 protected:
  void paintEvent(QPaintEvent*) override;

 private:
  Histogram histogram_;
};

}  // namespace collide::gui
