#include "app/gui/video_export_dialog.hpp"

#include <QComboBox>
#include <QDialogButtonBox>
#include <QFileDialog>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <cmath>

namespace collide::gui {
namespace {

// Video players cope with 1 to 120 frames/s; slow-downs outside are not offered.
constexpr double kMinPlaybackFps = 1.0, kMaxPlaybackFps = 120.0;
constexpr double kPreferredFps = 25.0;

}  // namespace

QString realTimeFraction(double slow_down) {
  if (std::abs(slow_down - 1.0) < 1e-9) return QObject::tr("real time");
  if (slow_down > 1.0) return QObject::tr("1/%1x real time").arg(slow_down, 0, 'g', 6);
  return QObject::tr("%1x real time").arg(1.0 / slow_down, 0, 'g', 6);
}

VideoExportDialog::VideoExportDialog(double recording_fps, int first, int last, const QString& path,
                                     QWidget* parent)
    : QDialog(parent), recording_fps_(recording_fps), frames_(last - first + 1) {
  setObjectName("video_export_dialog");
  setWindowTitle(tr("Export frames %1 to %2 as a video").arg(first).arg(last));
  setMinimumWidth(560);  // room for a whole path
  auto* form = new QFormLayout(this);
  path_ = new QLineEdit(path);
  path_->setObjectName("video_path");
  path_->setToolTip(tr("The AVI file to write (Motion JPEG, 8-bit grey as shown)"));
  auto* browse = new QPushButton(tr("Browse..."));
  auto* row = new QHBoxLayout;
  row->addWidget(path_, 1);
  row->addWidget(browse);
  form->addRow(tr("File"), row);

  slow_down_ = new QComboBox;
  slow_down_->setObjectName("slow_down");
  slow_down_->setToolTip(
      tr("How slowly the video plays: 1/100x real time shows 1 ms of the recording in 0.1 s"));
  double best = 1e300;
  for (int n : {1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000}) {
    const double fps = recording_fps / n;
    if (fps < kMinPlaybackFps || fps > kMaxPlaybackFps) continue;
    slow_down_->addItem(tr("%1 (%2 frames/s)").arg(realTimeFraction(n)).arg(fps, 0, 'g', 4), n);
    const double miss = std::abs(std::log(fps / kPreferredFps));
    if (miss < best) {
      best = miss;
      slow_down_->setCurrentIndex(slow_down_->count() - 1);
    }
  }
  form->addRow(tr("Play at"), slow_down_);
  summary_ = new QLabel;
  summary_->setObjectName("video_summary");
  summary_->setWordWrap(true);
  form->addRow(summary_);

  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel);
  ok_ = buttons->button(QDialogButtonBox::Ok);
  ok_->setText(tr("Export"));
  form->addRow(buttons);
  connect(buttons, &QDialogButtonBox::accepted, this, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  connect(browse, &QPushButton::clicked, this, &VideoExportDialog::browse);
  connect(slow_down_, &QComboBox::currentIndexChanged, this, &VideoExportDialog::updateSummary);
  connect(path_, &QLineEdit::textChanged, this, &VideoExportDialog::updateSummary);
  updateSummary();
}

QString VideoExportDialog::path() const {
  QString p = path_->text().trimmed();
  if (!p.isEmpty() && !p.endsWith(".avi", Qt::CaseInsensitive)) p += ".avi";
  return p;
}

int VideoExportDialog::slowDown() const {
  return slow_down_->count() ? slow_down_->currentData().toInt() : 0;
}

double VideoExportDialog::playbackFps() const {
  return slowDown() > 0 ? recording_fps_ / slowDown() : 0.0;
}

void VideoExportDialog::updateSummary() {
  const bool can = slowDown() > 0 && !path_->text().trimmed().isEmpty();
  ok_->setEnabled(can);
  if (slowDown() == 0)
    return summary_->setText(
        tr("No slow-down gives 1 to 120 frames/s for a recording at %1 frames/s: export PNG "
           "frames instead")
            .arg(recording_fps_));
  const double recorded_ms = frames_ * 1e3 / recording_fps_;
  summary_->setText(tr("%1 frames (%2 ms recorded at %3 frames/s) play for %4 s at %5 frames/s, "
                       "%6.")
                        .arg(frames_)
                        .arg(recorded_ms, 0, 'g', 4)
                        .arg(recording_fps_, 0, 'g', 6)
                        .arg(frames_ / playbackFps(), 0, 'g', 3)
                        .arg(playbackFps(), 0, 'g', 4)
                        .arg(realTimeFraction(slowDown())));
}

void VideoExportDialog::browse() {
  const QString file =
      QFileDialog::getSaveFileName(this, tr("Video file"), path_->text(), tr("AVI video (*.avi)"));
  if (!file.isEmpty()) path_->setText(file);
}

}  // namespace collide::gui
