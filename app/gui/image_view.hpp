#pragma once
// A camera frame on screen with drawings over it (detected spheres and dots,
// fitted trajectories, the collision point), scaled to fit the widget while
// keeping the aspect ratio. Coordinates of the overlays are image pixels
// (u right, v down, origin at the top-left pixel's centre).
//
// The tools a vendor viewer has: the mouse wheel over the image zooms about
// the cursor (double-click or the 0 key: whole image again), dragging with
// the left button pans a zoomed image, the position and raw value of the
// pixel under the cursor are shown, dragging with the right button (or
// Shift + left) measures a distance in pixels and, given the pixel size, in
// millimetres (Escape clears it), and a crosshair marks the image centre.
#include <QColor>
#include <QImage>
#include <QLineF>
#include <QPointF>
#include <QString>
#include <QWidget>
#include <optional>
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
  /// The shown frame's raw pixels (CV_8U or CV_16U, same size as the image)
  /// and their format, for the value under the cursor; empty: the 8-bit
  /// display value is shown instead.
  void setRawFrame(cv::Mat raw, vision::PixelFormat format);
  void setOverlay(Overlay overlay);
  void clear(const QString& message = {});
  const QImage& image() const { return image_; }
  const Overlay& overlay() const { return overlay_; }
  QSize sizeHint() const override { return {640, 480}; }

  /// Metres per pixel in the object plane, for the measuring tool (0: pixels only).
  void setPixelSize(double metres_per_px);
  void setCrosshair(bool on);
  bool crosshair() const { return crosshair_; }

  /// 1: the whole image fits the widget; up to kMaxZoom.
  double zoom() const { return zoom_; }
  /// Zooms to `zoom` keeping the image point under widget point `anchor` in place.
  void zoomAbout(double zoom, QPointF anchor);
  void resetZoom();
  static constexpr double kMaxZoom = 64.0;

  /// Image pixel coordinates (u, v) of a widget point, and back.
  QPointF toImage(QPointF widget_point) const;
  QPointF toWidget(QPointF image_point) const;
  /// "u 123, v 45: 2048 of 4095" for the pixel under the cursor; empty when
  /// the cursor is not over the image.
  QString cursorText() const { return cursor_text_; }
  /// The measured segment in image pixels, and its text ("12.3 px = 4.56 mm").
  std::optional<QLineF> measurement() const { return measure_; }
  QString measurementText() const;

 signals:
  /// The pixel under the cursor changed (text as cursorText()).
  void cursorMoved(const QString& text);

 protected:
  void paintEvent(QPaintEvent*) override;
  void wheelEvent(QWheelEvent* event) override;
  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;
  void mouseReleaseEvent(QMouseEvent* event) override;
  void mouseDoubleClickEvent(QMouseEvent* event) override;
  void keyPressEvent(QKeyEvent* event) override;
  void leaveEvent(QEvent* event) override;

 private:
  double scale() const;  ///< widget pixels per image pixel
  void clampCentre();
  void updateCursor(QPointF widget_point);
  void paintOverlay(QPainter& p, double scale) const;
  void paintLegend(QPainter& p, const QRectF& visible) const;
  void paintTools(QPainter& p) const;

  QImage image_;
  cv::Mat raw_;
  vision::PixelFormat raw_format_ = vision::PixelFormat::Mono8;
  Overlay overlay_;
  QString message_;
  double zoom_ = 1.0;
  QPointF centre_;  ///< image-space point (pixel u at u + 0.5) at the widget's centre
  double pixel_size_m_ = 0.0;
  bool crosshair_ = false;
  enum class Drag { None, Pan, Measure } drag_ = Drag::None;
  QPointF drag_start_widget_, drag_start_centre_;
  std::optional<QLineF> measure_;
  QString cursor_text_;
};

}  // namespace collide::gui
