#include "app/gui/replay_view.hpp"

#include <QCheckBox>
#include <QComboBox>
#include <QDir>
#include <QFileDialog>
#include <QHBoxLayout>
#include <QLabel>
#include <QPushButton>
#include <QShortcut>
#include <QSlider>
#include <QSplitter>
#include <QVBoxLayout>
#include <QtConcurrent/QtConcurrentRun>
#include <cmath>

#include "app/gui/video_export_dialog.hpp"
#include "vision/frame_io.hpp"
#include "vision/video_export.hpp"

namespace collide::gui {
namespace {

const QColor kSphere[2] = {QColor(60, 220, 90), QColor(70, 190, 255)};
const QColor kDot(255, 210, 40);
const QColor kContact(255, 80, 60);
const QColor kTruth(255, 60, 200);

struct Projection {
  double s, u0, v0;
  QPointF operator()(const Vec3& w) const { return {u0 + w.x() / s, v0 - w.y() / s}; }
};

// Seconds on the analysis clock of every burst frame: the analysis times its
// frames from the first analysed frame; frames carry camera timestamps.
std::vector<double> frameTimes(const hw::Shot& shot, const vision::ShotAnalysis& a) {
  const auto& frames = shot.burst.frames;
  std::vector<double> t(frames.size(), std::nan(""));
  if (a.frames.empty()) return t;
  const auto& ref = a.frames.front();
  std::int64_t ref_ts = 0;
  bool found = false;
  for (const auto& f : frames)
    if (f.id == ref.frame_id) {
      ref_ts = f.timestamp_ns;
      found = true;
    }
  for (std::size_t k = 0; k < frames.size(); ++k)
    t[k] = found ? ref.t_s + (frames[k].timestamp_ns - ref_ts) * 1e-9
                 : ref.t_s + (frames[k].id - ref.frame_id) / shot.burst.fps;
  return t;
}

}  // namespace

double contactFromTrigger_s(const hw::Shot& shot, const vision::ShotAnalysis& a) {
  // The analysis times frames from its first analysed frame; the replay
  // counts from the trigger (frame 0). One clock for the user: the trigger's.
  const double tc = a.collision.t_collision_s.value;
  if (!std::isfinite(tc) || a.frames.empty() || !(shot.burst.fps > 0)) return std::nan("");
  const auto& ref = a.frames.front();
  return tc - ref.t_s + static_cast<double>(ref.frame_id) / shot.burst.fps;
}

Overlay analysisOverlay(const hw::Shot& shot, const vision::ShotAnalysis& a, std::size_t index) {
  Overlay o;
  if (index >= shot.burst.frames.size()) return o;
  const std::int64_t id = shot.burst.frames[index].id;
  for (const auto& fd : a.frames) {
    if (fd.frame_id != id) continue;
    for (int i = 0; i < 2; ++i) {
      if (fd.sphere[i])
        o.circles.push_back({QPointF(fd.sphere[i]->u_px, fd.sphere[i]->v_px),
                             fd.sphere[i]->radius_px, kSphere[i], fd.sphere[i]->touching});
      for (const auto& d : fd.dots[i]) o.markers.push_back({QPointF(d.u_px, d.v_px), kDot, {}});
    }
  }
  const double s = a.pixel_size_m > 0 ? a.pixel_size_m : shot.scene.pixel_size_m;
  if (!(s > 0)) return o;
  const Projection project{s, shot.scene.origin_u_px, shot.scene.origin_v_px};
  const double tc = a.collision.t_collision_s.value;
  const std::vector<double> times = frameTimes(shot, a);
  for (int i = 0; i < 2; ++i) {
    for (int side = 0; side < 2; ++side) {
      const auto& fit = a.trajectory[i][side];
      if (!fit) continue;
      // Before impact: from the first fitted frame to the collision; after: on.
      double t0 = side == 0 ? fit->tFirst_s() : (std::isfinite(tc) ? tc : fit->tFirst_s());
      double t1 = side == 0 ? (std::isfinite(tc) ? tc : fit->tLast_s()) : fit->tLast_s();
      Overlay::Path path{{}, kSphere[i], side == 1};
      for (int k = 0; k <= 40; ++k)
        path.points.push_back(project(fit->positionAt_m(t0 + (t1 - t0) * k / 40.0).value));
      o.paths.push_back(std::move(path));
      // The fitted centre at this frame's instant, on its side of the impact.
      const double t = times[index];
      if (std::isfinite(t) && ((side == 0 && t <= tc) || (side == 1 && t > tc)))
        o.markers.push_back({project(fit->positionAt_m(t).value), kSphere[i], {}});
    }
  }
  const bool contact_shown = std::isfinite(tc) && a.trajectory[0][0] && a.trajectory[1][0];
  if (contact_shown) {
    const Vec3 contact = 0.5 * (a.trajectory[0][0]->positionAt_m(tc).value +
                                a.trajectory[1][0]->positionAt_m(tc).value);
    // No text on the image: it would cover the spheres; the time is in the
    // caption and the legend says what the red cross is.
    o.markers.push_back({project(contact), kContact, {}});
  }
  // The legend names only what this analysis draws: a wall shot has one
  // sphere (its fitted paths; the wall analysis keeps no per-frame
  // detections) and no contact between two.
  bool dots = false;
  for (int i = 0; i < 2; ++i) {
    const bool fitted = a.trajectory[i][0] || a.trajectory[i][1];
    bool detected = false;
    for (const auto& fd : a.frames) {
      detected = detected || fd.sphere[i].has_value();
      dots = dots || !fd.dots[i].empty();
    }
    if (detected || fitted)
      o.legend.push_back(
          {kSphere[i], (detected ? QObject::tr("sphere %1: detected, fitted path (dashed after "
                                               "impact)")
                                 : QObject::tr("sphere %1: fitted path (dashed after impact)"))
                           .arg(i + 1)});
  }
  if (dots) o.legend.push_back({kDot, QObject::tr("matched dots")});
  if (contact_shown) o.legend.push_back({kContact, QObject::tr("contact point")});
  return o;
}

Overlay truthOverlay(const hw::Shot& shot, std::size_t index) {
  Overlay o;
  if (!shot.truth || index >= shot.burst.frames.size()) return o;
  const auto& truth = *shot.truth;
  const std::int64_t id = shot.burst.frames[index].id;
  const Projection project{shot.scene.pixel_size_m, shot.scene.origin_u_px, shot.scene.origin_v_px};
  for (std::size_t k = 0; k < truth.frame_id.size(); ++k) {
    if (truth.frame_id[k] != id) continue;
    for (int i = 0; i < 2; ++i)
      o.circles.push_back({project(truth.states[k][i].position_m),
                           0.5 * shot.scene.diameter_m[i] / shot.scene.pixel_size_m, kTruth, true});
  }
  return o;
}

ReplayView::ReplayView(QWidget* parent) : QWidget(parent) {
  auto* outer = new QHBoxLayout(this);
  auto* splitter = new QSplitter;
  outer->addWidget(splitter);
  auto* left = new QWidget;
  auto* layout = new QVBoxLayout(left);
  layout->setContentsMargins(0, 0, 0, 0);
  view_ = new ImageView;
  view_->setObjectName("replay_image");
  view_->clear(tr("no shot: fire one, or open one from the Shots tab"));
  layout->addWidget(view_, 1);
  slider_ = new QSlider(Qt::Horizontal);
  slider_->setObjectName("frame_slider");
  slider_->setRange(0, 0);
  layout->addWidget(slider_);
  layout->addLayout(makeTransportRow());
  layout->addLayout(makeDisplayRow());
  layout->addLayout(makeExportRow());
  splitter->addWidget(left);

  card_ = new ResultCard;
  splitter->setChildrenCollapsible(false);
  splitter->addWidget(card_);
  splitter->setStretchFactor(0, 3);
  splitter->setStretchFactor(1, 1);

  connect(slider_, &QSlider::valueChanged, this, &ReplayView::showFrame);
  connect(show_analysis_, &QCheckBox::toggled, this, &ReplayView::redraw);
  connect(show_truth_, &QCheckBox::toggled, this, &ReplayView::redraw);
  connect(crosshair_, &QCheckBox::toggled, view_, &ImageView::setCrosshair);
  connect(speed_, &QComboBox::currentIndexChanged, this, [this] {
    play_timer_.setInterval(static_cast<int>(std::lround(1000.0 / playbackRate())));
  });
  play_timer_.setInterval(static_cast<int>(std::lround(1000.0 / playbackRate())));
  connect(&play_timer_, &QTimer::timeout, this, &ReplayView::playStep);
  connect(&video_export_, &QFutureWatcher<QString>::finished, this, &ReplayView::finishVideoExport);
  addKeys();
}

ReplayView::~ReplayView() {
  video_export_.waitForFinished();
}

// First, previous, play, next, last; the frame and the last export's outcome.
QHBoxLayout* ReplayView::makeTransportRow() {
  auto* row = new QHBoxLayout;
  auto button = [&](const QString& text, const char* name, const QString& tip) {
    auto* b = new QPushButton(text);
    b->setObjectName(name);
    b->setToolTip(tip);
    b->setMaximumWidth(44);
    row->addWidget(b);
    return b;
  };
  auto* first = button("|<", "first_frame", tr("First frame (Home)"));
  auto* prev = button("<", "previous_frame", tr("Previous frame (Left; Shift+Left: 10 back)"));
  play_ = button(tr("Play"), "play", tr("Play / pause (Space)"));
  play_->setMaximumWidth(70);
  auto* next = button(">", "next_frame", tr("Next frame (Right; Shift+Right: 10 on)"));
  auto* last = button(">|", "last_frame", tr("Last frame (End)"));
  frame_label_ = new QLabel;
  frame_label_->setObjectName("frame_label");
  row->addWidget(frame_label_, 1);
  export_status_ = new QLabel;
  export_status_->setObjectName("export_status");
  export_status_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  row->addWidget(export_status_);
  connect(first, &QPushButton::clicked, this, [this] { showFrame(0); });
  connect(prev, &QPushButton::clicked, this, [this] { showFrame(index_ - 1); });
  connect(next, &QPushButton::clicked, this, [this] { showFrame(index_ + 1); });
  connect(last, &QPushButton::clicked, this, [this] { showFrame(frameCount() - 1); });
  connect(play_, &QPushButton::clicked, this, &ReplayView::togglePlay);
  return row;
}

// How to play and what to draw.
QHBoxLayout* ReplayView::makeDisplayRow() {
  auto* row = new QHBoxLayout;
  speed_ = new QComboBox;
  speed_->setObjectName("playback_speed");
  for (int fps : {2, 5, 10, 25, 50, 100}) speed_->addItem(tr("%1 frames/s").arg(fps), fps);
  speed_->setCurrentIndex(3);
  speed_->setSizeAdjustPolicy(QComboBox::AdjustToContents);
  speed_->setToolTip(
      tr("Playback speed: frames shown per second of screen time, and what that is as a "
         "fraction of real time given the recording's frame rate"));
  speed_->setFocusPolicy(Qt::StrongFocus);  // the wheel only once clicked
  loop_ = new QCheckBox(tr("loop"));
  loop_->setObjectName("loop");
  reverse_ = new QCheckBox(tr("reverse"));
  reverse_->setObjectName("reverse");
  show_analysis_ = new QCheckBox(tr("analysis"));
  show_analysis_->setChecked(true);
  show_truth_ = new QCheckBox(tr("ground truth"));
  crosshair_ = new QCheckBox(tr("crosshair"));
  crosshair_->setObjectName("crosshair");
  for (QWidget* w :
       std::initializer_list<QWidget*>{new QLabel(tr("play at")), speed_, loop_, reverse_,
                                       show_analysis_, show_truth_, crosshair_})
    row->addWidget(w);
  row->addStretch(1);
  return row;
}

// The marked range, and what to do with it.
QHBoxLayout* ReplayView::makeExportRow() {
  auto* row = new QHBoxLayout;
  marks_ = new QLabel;
  marks_->setObjectName("export_marks");
  row->addWidget(marks_, 1);
  auto* export_frames = new QPushButton(tr("Export frames..."));
  export_frames->setObjectName("export_frames");
  export_frames->setToolTip(
      tr("Write the frames from the in mark to the out mark (keys I and O) as PNG files"));
  auto* export_video = export_video_ = new QPushButton(tr("Export video..."));
  export_video->setObjectName("export_video");
  export_video->setToolTip(
      tr("Write the frames from the in mark to the out mark (keys I and O) as an AVI video, "
         "slowed down to a chosen fraction of real time"));
  reanalyse_ = new QPushButton(tr("Re-run analysis"));
  reanalyse_->setObjectName("reanalyse");
  for (QPushButton* b : {export_frames, export_video, reanalyse_}) row->addWidget(b);
  connect(export_frames, &QPushButton::clicked, this, &ReplayView::chooseExportFolder);
  connect(export_video, &QPushButton::clicked, this, &ReplayView::chooseVideoFile);
  connect(reanalyse_, &QPushButton::clicked, this, [this] {
    if (shot_) emit reanalyseRequested(shot_);
  });
  return row;
}

// Keys anywhere in the view (the image, the slider, the buttons).
void ReplayView::addKeys() {
  auto key = [this](QKeySequence k, auto f) {
    auto* s = new QShortcut(k, this);
    s->setContext(Qt::WidgetWithChildrenShortcut);
    connect(s, &QShortcut::activated, this, f);
  };
  key(Qt::Key_Left, [this] { showFrame(index_ - 1); });
  key(Qt::Key_Right, [this] { showFrame(index_ + 1); });
  key(QKeySequence(Qt::SHIFT | Qt::Key_Left), [this] { showFrame(index_ - 10); });
  key(QKeySequence(Qt::SHIFT | Qt::Key_Right), [this] { showFrame(index_ + 10); });
  key(Qt::Key_Home, [this] { showFrame(0); });
  key(Qt::Key_End, [this] { showFrame(frameCount() - 1); });
  key(Qt::Key_Space, [this] { togglePlay(); });
  key(Qt::Key_I, [this] { setMark(true); });
  key(Qt::Key_O, [this] { setMark(false); });
}

double ReplayView::playbackRate() const {
  return speed_->currentData().toDouble();
}

double ReplayView::playbackRealTimeFraction() const {
  if (!shot_ || !(shot_->burst.fps > 0)) return std::nan("");
  return playbackRate() / shot_->burst.fps;
}

void ReplayView::relabelSpeeds() {
  const double recording_fps = shot_ ? shot_->burst.fps : 0.0;
  for (int k = 0; k < speed_->count(); ++k) {
    const double fps = speed_->itemData(k).toDouble();
    speed_->setItemText(
        k, recording_fps > 0
               ? tr("%1 frames/s = %2").arg(fps).arg(realTimeFraction(recording_fps / fps))
               : tr("%1 frames/s").arg(fps));
  }
}

void ReplayView::togglePlay() {
  if (!shot_ || frameCount() == 0) return;
  if (play_timer_.isActive()) {
    play_timer_.stop();
    play_->setText(tr("Play"));
    return;
  }
  // From the far end, a new pass starts at the other one.
  const bool back = reverse_->isChecked();
  if (!back && index_ + 1 >= frameCount()) showFrame(0);
  if (back && index_ <= 0) showFrame(frameCount() - 1);
  play_timer_.start();
  play_->setText(tr("Pause"));
}

void ReplayView::playStep() {
  const int step = reverse_->isChecked() ? -1 : 1;
  const int next = index_ + step;
  if (next >= 0 && next < frameCount()) return showFrame(next);
  if (loop_->isChecked()) return showFrame(step > 0 ? 0 : frameCount() - 1);
  play_timer_.stop();
  play_->setText(tr("Play"));
}

void ReplayView::setMark(bool in) {
  if (!shot_ || frameCount() == 0) return;
  if (in) {
    mark_in_ = index_;
    mark_out_ = std::max(mark_out_, mark_in_);
  } else {
    mark_out_ = index_;
    mark_in_ = std::min(mark_in_, mark_out_);
  }
  updateMarkLabel();
}

void ReplayView::updateMarkLabel() {
  if (!shot_ || frameCount() == 0) return marks_->clear();
  marks_->setText(tr("export %1 to %2 (%3 frames; I/O to mark)")
                      .arg(mark_in_ + 1)
                      .arg(mark_out_ + 1)
                      .arg(mark_out_ - mark_in_ + 1));
}

vision::Burst ReplayView::markedFrames() const {
  vision::Burst part = shot_->burst;  // frames share their pixels (cv::Mat)
  part.frames.assign(shot_->burst.frames.begin() + mark_in_,
                     shot_->burst.frames.begin() + mark_out_ + 1);
  return part;
}

QString ReplayView::exportMarkedFrames(const QString& dir) {
  if (!shot_ || frameCount() == 0) return tr("no shot to export frames from");
  auto written =
      vision::exportBurstPng(markedFrames(), dir.toStdString(), {.stretch_mono12 = true});
  if (!written) return QString::fromStdString(written.error().message);
  return {};
}

QString ReplayView::exportMarkedVideo(const QString& path, double playback_fps) {
  if (!shot_ || frameCount() == 0) return tr("no shot to export a video from");
  auto written =
      vision::exportBurstVideo(markedFrames(), path.toStdString(), {.playback_fps = playback_fps});
  if (!written) return QString::fromStdString(written.error().message);
  return {};
}

void ReplayView::showExportResult(const QString& done, const QString& error) {
  export_status_->setStyleSheet(error.isEmpty() ? QString() : "color: #c62828;");
  export_status_->setText(error.isEmpty() ? done : tr("not exported: %1").arg(error));
  export_status_->setToolTip(export_status_->text());
}

void ReplayView::chooseExportFolder() {
  if (!shot_ || frameCount() == 0) return;
  const QString dir = QFileDialog::getExistingDirectory(
      this, tr("Folder for frames %1 to %2").arg(mark_in_ + 1).arg(mark_out_ + 1));
  if (dir.isEmpty()) return;
  showExportResult(
      tr("wrote frames %1 to %2 into %3").arg(mark_in_ + 1).arg(mark_out_ + 1).arg(dir),
      exportMarkedFrames(dir));
}

void ReplayView::chooseVideoFile() {
  if (!shot_ || frameCount() == 0) return;
  if (!(shot_->burst.fps > 0))
    return showExportResult({},
                            tr("shot %1 has no frame rate").arg(QString::fromStdString(shot_->id)));
  const QString suggested =
      QDir::home().filePath(QString::fromStdString(shot_->id.empty() ? "shot" : shot_->id) +
                            QString("_frames%1-%2.avi").arg(mark_in_ + 1).arg(mark_out_ + 1));
  auto* dialog =
      new VideoExportDialog(shot_->burst.fps, mark_in_ + 1, mark_out_ + 1, suggested, this);
  dialog->setAttribute(Qt::WA_DeleteOnClose);
  connect(dialog, &QDialog::accepted, this, [this, dialog] {
    startVideoExport(dialog->path(), dialog->playbackFps(), dialog->slowDown());
  });
  dialog->open();  // window-modal, returns at once
}

// On a worker thread: a long burst must not freeze the window. The frames
// share their pixels with the shot (cv::Mat counts its references).
void ReplayView::startVideoExport(const QString& path, double playback_fps, int slow_down) {
  if (video_export_.isRunning()) return;
  video_done_ = tr("wrote frames %1 to %2 to %3 (%4)")
                    .arg(mark_in_ + 1)
                    .arg(mark_out_ + 1)
                    .arg(path, realTimeFraction(slow_down));
  export_video_->setEnabled(false);
  showExportResult(tr("writing %1 ...").arg(path), {});
  video_export_.setFuture(
      QtConcurrent::run([part = markedFrames(), file = path.toStdString(), playback_fps] {
        auto written = vision::exportBurstVideo(part, file, {.playback_fps = playback_fps});
        return written ? QString() : QString::fromStdString(written.error().message);
      }));
}

void ReplayView::finishVideoExport() {
  export_video_->setEnabled(true);
  showExportResult(video_done_, video_export_.result());
}

int ReplayView::frameCount() const {
  return shot_ ? static_cast<int>(shot_->burst.frames.size()) : 0;
}

void ReplayView::setShot(ShotPtr shot) {
  shot_ = std::move(shot);
  analysis_.reset();
  play_timer_.stop();
  play_->setText(tr("Play"));
  slider_->setRange(0, std::max(0, frameCount() - 1));
  export_status_->clear();
  if (!shot_ || frameCount() == 0) {
    view_->clear(shot_ ? tr("shot %1 has no frames (%2)")
                             .arg(QString::fromStdString(shot_->id),
                                  QString::fromStdString(shot_->failure_reason))
                       : tr("no shot"));
    frame_label_->clear();
    marks_->clear();
    relabelSpeeds();
    return;
  }
  relabelSpeeds();
  show_truth_->setEnabled(shot_->truth.has_value());
  view_->setPixelSize(shot_->scene.pixel_size_m);
  mark_in_ = 0;
  mark_out_ = frameCount() - 1;
  updateMarkLabel();
  // Start at frame 0, the trigger (the predicted contact).
  int start = 0;
  for (int k = 0; k < frameCount(); ++k)
    if (shot_->burst.frames[k].id == 0) start = k;
  index_ = -1;
  slider_->setValue(start);
  showFrame(start);
}

void ReplayView::setAnalysis(AnalysisPtr analysis) {
  analysis_ = std::move(analysis);
  // The analysis' scale (measured from the spheres when the footage had none).
  if (analysis_ && analysis_->pixel_size_m > 0) view_->setPixelSize(analysis_->pixel_size_m);
  redraw();
}

void ReplayView::showFrame(int index) {
  if (!shot_ || frameCount() == 0) return;
  index = std::clamp(index, 0, frameCount() - 1);
  if (index == index_) return;
  index_ = index;
  if (slider_->value() != index) slider_->setValue(index);
  const vision::Frame& f = shot_->burst.frames[index];
  view_->setImage(f.image.empty() ? QImage() : toDisplayImage(f.image, shot_->burst.format));
  view_->setRawFrame(f.image, shot_->burst.format);
  redraw();
}

void ReplayView::redraw() {
  if (!shot_ || frameCount() == 0) return;
  const vision::Frame& f = shot_->burst.frames[index_];
  Overlay o;
  if (analysis_ && show_analysis_->isChecked())
    o = analysisOverlay(*shot_, *analysis_, static_cast<std::size_t>(index_));
  if (show_truth_->isChecked()) {
    Overlay t = truthOverlay(*shot_, static_cast<std::size_t>(index_));
    o.circles.insert(o.circles.end(), t.circles.begin(), t.circles.end());
  }
  const double t_ms = (f.id) * 1e3 / shot_->burst.fps;
  const double contact_s = analysis_ ? contactFromTrigger_s(*shot_, *analysis_) : std::nan("");
  const QString contact = std::isfinite(contact_s)
                              ? tr("; contact at %1 ms").arg(contact_s * 1e3, 0, 'f', 2)
                              : QString();
  o.caption = tr("frame %1 (%2 of %3)  t = %4 ms from the trigger%5%6")
                  .arg(f.id)
                  .arg(index_ + 1)
                  .arg(frameCount())
                  .arg(t_ms, 0, 'f', 2)
                  .arg(contact)
                  .arg(f.status == vision::FrameStatus::Good ? QString() : tr("  [bad frame]"));
  view_->setOverlay(std::move(o));
  frame_label_->setText(
      tr("%1 / %2 (times from the trigger)%3").arg(index_ + 1).arg(frameCount()).arg(contact));
}

}  // namespace collide::gui
