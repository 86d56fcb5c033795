#include "app/gui/live_view.hpp"

#include <QCheckBox>
#include <QHBoxLayout>
#include <QLabel>
#include <QVBoxLayout>
#include <QtConcurrent/QtConcurrentRun>

#include "vision/dot_detector.hpp"
#include "vision/sphere_detector.hpp"

namespace collide::gui {

Overlay detectSpheresAndDots(const vision::Frame& frame, vision::PixelFormat format) {
  Overlay o;
  if (frame.image.empty()) return o;
  static const vision::SphereDetector detector;  // const detect(): thread-safe
  const int max_value = vision::maxValue(format);
  const vision::FrameSpheres found = detector.detect(frame.image, max_value);
  const QColor colours[2] = {QColor(60, 220, 90), QColor(70, 190, 255)};
  for (std::size_t i = 0; i < found.spheres.size(); ++i) {
    const vision::SphereMeasurement& s = found.spheres[i];
    o.circles.push_back(
        {QPointF(s.circle.u, s.circle.v), s.circle.radius, colours[i % 2], s.touching});
    for (const vision::Dot& d : vision::findDots(frame.image, s, max_value).dots)
      o.markers.push_back({QPointF(d.u_px, d.v_px), QColor(255, 210, 40), {}});
  }
  return o;
}

LiveView::LiveView(QWidget* parent) : QWidget(parent) {
  auto* outer = new QHBoxLayout(this);
  auto* layout = new QVBoxLayout;
  outer->addLayout(layout, 1);
  view_ = new ImageView;
  view_->setObjectName("live_image");
  view_->clear(tr("no camera: open a rig profile"));
  layout->addWidget(view_, 1);
  auto* row = new QHBoxLayout;
  info_ = new QLabel;
  info_->setObjectName("live_info");
  overlays_ = new QCheckBox(tr("detections"));
  overlays_->setChecked(true);
  crosshair_ = new QCheckBox(tr("crosshair"));
  crosshair_->setObjectName("live_crosshair");
  row->addWidget(info_, 1);
  row->addWidget(overlays_);
  row->addWidget(crosshair_);
  layout->addLayout(row);
  connect(crosshair_, &QCheckBox::toggled, view_, &ImageView::setCrosshair);

  // Beside the image: what the camera is set to, and how the frame fills its range.
  auto* side = new QVBoxLayout;
  outer->addLayout(side);
  auto* settings_title = new QLabel(tr("<b>Camera</b>"));
  settings_ = new QLabel;
  settings_->setObjectName("live_camera_settings");
  settings_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  settings_->setToolTip(
      tr("Set in the rig profile's [camera] table (exposure, gain, frame rate "
         "and region of interest of the burst)"));
  histogram_ = new HistogramView;
  histogram_->setObjectName("live_histogram");
  saturation_ = new QLabel;
  saturation_->setObjectName("live_saturation");
  saturation_->setWordWrap(true);
  saturation_->setStyleSheet("color: #c0392b; font-weight: bold;");
  saturation_->setMaximumWidth(240);
  for (QWidget* w : std::initializer_list<QWidget*>{
           settings_title, settings_, new QLabel(tr("<b>Histogram</b>")), histogram_, saturation_})
    side->addWidget(w);
  side->addStretch(1);
  connect(&timer_, &QTimer::timeout, this, &LiveView::refresh);
  connect(&detection_, &QFutureWatcher<Overlay>::finished, this, [this] {
    Overlay o = detection_.result();
    o.caption = view_->overlay().caption;
    if (overlays_->isChecked()) view_->setOverlay(std::move(o));
  });
  setRefreshRate(30);
  clock_.start();
}

LiveView::~LiveView() {
  detection_.waitForFinished();
}

void LiveView::setRefreshRate(double hz) {
  timer_.start(static_cast<int>(1000.0 / hz));
}

void LiveView::setCamera(CameraPtr camera) {
  camera_ = std::move(camera);
  last_published_ = 0;
  if (!camera_) {
    view_->clear(tr("no camera: open a rig profile"));
    histogram_->setHistogram({});
    saturation_->clear();
  }
  showCameraSettings();
}

QString LiveView::saturationWarning() const {
  return saturation_->text();
}

QString LiveView::cameraSettingsText() const {
  return settings_->text();
}

void LiveView::showCameraSettings() {
  if (!camera_) return settings_->setText(tr("no camera"));
  const hw::CameraConfig c = camera_->config();
  settings_->setText(tr("exposure %1 us\ngain %2 dB\nframe rate %3 frames/s\nregion %4 x %5 at "
                        "(%6, %7) px\nformat %8")
                         .arg(c.exposure_us, 0, 'f', 0)
                         .arg(c.gain_db, 0, 'f', 1)
                         .arg(c.fps, 0, 'f', 0)
                         .arg(c.width)
                         .arg(c.height)
                         .arg(c.roi_x)
                         .arg(c.roi_y)
                         .arg(QString::fromLatin1(vision::toString(c.format))));
}

void LiveView::refresh() {
  if (!camera_ || !isVisible()) return;
  const std::uint64_t published = camera_->publishedFrames();
  if (published == last_published_) return;
  std::shared_ptr<const vision::Frame> frame = camera_->latestFrame();
  if (!frame || frame->image.empty()) return;
  const vision::PixelFormat format = camera_->config().format;
  view_->setImage(toDisplayImage(frame->image, format));
  view_->setRawFrame(frame->image, format);
  histogram_->setHistogram(histogramOf(frame->image, vision::maxValue(format)));
  saturation_->setText(histogram_->warning());
  showCameraSettings();
  const double dt = clock_.restart() / 1000.0;
  if (dt > 0) display_fps_ = 0.8 * display_fps_ + 0.2 / dt;
  const std::uint64_t skipped = published - last_published_ - 1;
  last_published_ = published;
  ++shown_;
  Overlay caption;
  caption.caption = tr("live  %1x%2 %3")
                        .arg(frame->image.cols)
                        .arg(frame->image.rows)
                        .arg(vision::toString(format));
  view_->setOverlay(caption);
  info_->setText(tr("%1 frames published by the camera; showing about %2 per second (%3 skipped "
                    "since the last)")
                     .arg(published)
                     .arg(display_fps_, 0, 'f', 0)
                     .arg(skipped));
  if (detector_ && overlays_->isChecked() && !detection_.isRunning()) {
    Detector d = detector_;
    detection_.setFuture(QtConcurrent::run([d, frame, format] { return d(*frame, format); }));
  }
}

}  // namespace collide::gui
