#pragma once
// A camera frame on screen with drawings over it (detected spheres and dots,
// fitted trajectories, the collision point), scaled to fit the widget while
// keeping the aspect ratio. Coordinates of the overlays are image pixels
// (u right, v down, origin at the top-left pixel's centre).
#include <QColor>
#include <QImage>
#include <QPointF>
#include <QString>
#include <QWidget>
#include <vector>

#include "vision/frame.hpp"

namespace collide::gui {

struct Overlay {
  struct Circle {
    QPointF centre;
    double radius = 0;
    QColor colour;
    bool dashed = false;
  };
  struct Path {
    std::vector<QPointF> points;
    QColor colour;
    bool dashed = false;
  };
  struct Marker {  ///< a small cross, with an optional label
    QPointF at;
    QColor colour;
    QString label;
  };
  std::vector<Circle> circles;
  std::vector<Path> paths;
  std::vector<Marker> markers;
  QString caption;  ///< top-left text (frame number, time)
  struct LegendEntry {
    QColor colour;
    QString text;
  };
  std::vector<LegendEntry> legend;  ///< what the colours mean, bottom-left

  bool empty() const { return circles.empty() && paths.empty() && markers.empty(); }
};

/// 8-bit grey copy of a Mono8/12/16 frame for display (Mono12/16 scaled by the
/// format's full scale). Null image for an empty frame.
QImage toDisplayImage(const cv::Mat& image, vision::PixelFormat format);

class ImageView : public QWidget {
  Q_OBJECT
 public:
  explicit ImageView(QWidget* parent = nullptr);

  void setImage(QImage image);
  void setOverlay(Overlay overlay);
  void clear(const QString& message = {});
  const QImage& image() const { return image_; }
  const Overlay& overlay() const { return overlay_; }
  QSize sizeHint() const override { return {640, 480}; }

 protected:
  void paintEvent(QPaintEvent*) override;

 private:
  QImage image_;
  Overlay overlay_;
  QString message_;
};

}  // namespace collide::gui
