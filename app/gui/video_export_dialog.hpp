#pragma once
// "Export video" from Replay: where to write the AVI and how slowly it plays,
// as a fraction of real time (the recording's frame rate times the chosen
// slow-down gives the video's frames per second), said in full in the dialog.
#include <QDialog>

class QComboBox;
class QLabel;
class QLineEdit;
class QPushButton;

namespace collide::gui {

class VideoExportDialog : public QDialog {
  Q_OBJECT
 public:
  /// Frames `first`..`last` (1-based positions, for the text) of a burst
  /// recorded at `recording_fps` > 0; `path` is the suggested file.
  VideoExportDialog(double recording_fps, int first, int last, const QString& path,
                    QWidget* parent = nullptr);

  QString path() const;
  /// Frames per second of the video: the recording rate / slowDown().
  double playbackFps() const;
  /// N in "1/N of real time".
  int slowDown() const;

 private:
  void updateSummary();
  void browse();

  double recording_fps_;
  int frames_;
  QLineEdit* path_ = nullptr;
  QComboBox* slow_down_ = nullptr;
  QLabel* summary_ = nullptr;
  QPushButton* ok_ = nullptr;
};

/// "1/N x real time" (or "real time" for N = 1).
QString realTimeFraction(double slow_down);

}  // namespace collide::gui
