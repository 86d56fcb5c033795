#include "app/gui/live_view.hpp"

#include <QCheckBox>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QVBoxLayout>
#include <QtConcurrent/QtConcurrentRun>
#include <cmath>

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
  info_->setWordWrap(true);  // a long line must not widen the window past the screen
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
  QWidget* controls = makeCameraControls();
  settings_ = new QLabel;
  settings_->setObjectName("live_camera_settings");
  settings_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  settings_->setToolTip(
      tr("What the camera runs with. Exposure, gain and frame rate are edited above (not "
         "while armed); the region of interest in the rig profile's [camera] table"));
  histogram_ = new HistogramView;
  histogram_->setObjectName("live_histogram");
  saturation_ = new QLabel;
  saturation_->setObjectName("live_saturation");
  saturation_->setWordWrap(true);
  saturation_->setStyleSheet("color: #c0392b; font-weight: bold;");
  saturation_->setMaximumWidth(240);
  for (QWidget* w :
       std::initializer_list<QWidget*>{settings_title, controls, settings_,
                                       new QLabel(tr("<b>Histogram</b>")), histogram_, saturation_})
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

QWidget* LiveView::makeCameraControls() {
  auto* box = new QWidget;
  box->setMaximumWidth(240);
  auto* form = new QFormLayout(box);
  form->setContentsMargins(0, 0, 0, 0);
  form->setRowWrapPolicy(QFormLayout::WrapAllRows);  // narrow: labels above the fields
  auto make = [&](const char* name, const QString& label, const QString& suffix, int decimals) {
    auto* b = new GuardedDoubleSpinBox;
    b->setObjectName(name);
    b->setSuffix(suffix);
    b->setDecimals(decimals);
    form->addRow(label, b);
    connect(b, &QDoubleSpinBox::valueChanged, this, [this] {
      if (!locked_) apply_timer_->start();
    });
    connect(b, &GuardedDoubleSpinBox::refused, this, [this, b](double typed, double lo, double hi) {
      emit inputRefused(tr("%1%2 refused: allowed %3 to %4%2; the camera keeps %5%2.")
                            .arg(typed)
                            .arg(b->suffix())
                            .arg(lo)
                            .arg(hi)
                            .arg(b->value()));
    });
    return b;
  };
  exposure_ = make("live_exposure_us", tr("exposure"), " us", 1);
  gain_ = make("live_gain_db", tr("gain"), " dB", 1);
  fps_ = make("live_fps", tr("frame rate"), " frames/s", 1);
  controls_note_ = new QLabel;
  controls_note_->setObjectName("live_camera_note");
  controls_note_->setWordWrap(true);
  form->addRow(controls_note_);
  apply_timer_ = new QTimer(this);
  apply_timer_->setSingleShot(true);
  apply_timer_->setInterval(300);
  connect(apply_timer_, &QTimer::timeout, this, &LiveView::requestCameraSettings);
  updateCameraControlState();
  return box;
}

void LiveView::requestCameraSettings() {
  if (locked_ || !camera_) return;  // armed meanwhile: nothing is applied
  const hw::CameraConfig c = camera_->config();
  if (std::abs(fps_->value() - c.fps) < 0.05 &&
      std::abs(exposure_->value() - c.exposure_us) < 0.05 &&
      std::abs(gain_->value() - c.gain_db) < 0.05)
    return;
  controls_note_->setText(tr("applying..."));
  emit cameraSettingsRequested(fps_->value(), exposure_->value(), gain_->value());
}

// The boxes show what the camera runs with, in the ranges it accepts.
void LiveView::syncCameraControls() {
  apply_timer_->stop();
  for (GuardedDoubleSpinBox* b : {exposure_, gain_, fps_}) b->blockSignals(true);
  if (camera_) {
    const hw::CameraInfo& info = camera_info_;
    const hw::CameraConfig c = camera_->config();
    fps_->setRangeWithTip(1, std::max(1.0, info.max_fps), tr("Camera frame rate"), tr("frames/s"),
                          tr("the exposure must fit in one frame period"));
    exposure_->setRangeWithTip(1, 1e6 / c.fps, tr("Exposure time"), tr("us"),
                               tr("at most one frame period at %1 frames/s").arg(c.fps));
    gain_->setRangeWithTip(0, info.max_gain_db, tr("Analogue gain"), tr("dB"));
    fps_->setValue(c.fps);
    exposure_->setValue(c.exposure_us);
    gain_->setValue(c.gain_db);
  }
  for (GuardedDoubleSpinBox* b : {exposure_, gain_, fps_}) b->blockSignals(false);
  updateCameraControlState();
}

// Enabled only unarmed, and only for what the backend can change; the
// tooltip of a disabled control says why.
void LiveView::updateCameraControlState() {
  const QString backend = QString::fromStdString(camera_info_.backend);
  const bool replay = backend == "replay";
  const bool fixed_gain = camera_ && camera_info_.max_gain_db <= 0;
  QString why = !camera_  ? tr("no camera: open a rig profile")
                : lost_   ? tr("a device is lost: press Reconnect in the rig panel first")
                : locked_ ? tr("locked while the rig is armed or firing: disarm to change")
                : replay  ? tr("a replayed recording: exposure, gain and frame rate were fixed "
                                "when it was recorded")
                          : QString();
  for (GuardedDoubleSpinBox* b : {exposure_, gain_, fps_}) {
    const bool off = !why.isEmpty() || (b == gain_ && fixed_gain);
    b->setEnabled(!off);
    if (off)
      b->setToolTip(b == gain_ && why.isEmpty()
                        ? tr("this camera (%1 backend) reports no adjustable gain").arg(backend)
                        : why);
  }
  controls_note_->setText(lost_     ? tr("locked: a device is lost")
                          : locked_ ? tr("locked: armed")
                                    : QString());
}

void LiveView::setRigStatus(const RigStatus& status) {
  // Applying rebuilds the rig: not while armed, nor while a device is lost
  // (the rebuilt rig would not ask it; Reconnect does).
  const bool lost = status.anyLost();
  const bool locked = status.armed || status.busy || lost;
  if (locked == locked_ && lost == lost_) return;
  locked_ = locked;
  lost_ = lost;
  // Back to what the camera runs with: an edit not yet applied is dropped,
  // not kept for later; the controls' tooltips say why they are off, or their range.
  syncCameraControls();
}

void LiveView::setRefreshRate(double hz) {
  timer_.start(static_cast<int>(1000.0 / hz));
}

void LiveView::setCamera(CameraPtr camera) {
  camera_ = std::move(camera);
  // Read once, after the control thread opened the camera (profileLoaded).
  camera_info_ = camera_ ? camera_->info() : hw::CameraInfo{};
  last_published_ = 0;
  if (!camera_) {
    view_->clear(tr("no camera: open a rig profile"));
    histogram_->setHistogram({});
    saturation_->clear();
  }
  showCameraSettings();
  syncCameraControls();
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
