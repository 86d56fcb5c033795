#pragma once
// Post-shot replay: the burst frame by frame (step, play, slider), with the
// analysis drawn over it (detected spheres and dots, the fitted trajectories
// before and after impact, the collision point and instant) and, for a
// simulated shot, optionally the ground truth; the result card beside it.
// Keys as in a vendor viewer: Left/Right one frame (Shift: 10), Home/End,
// Space play/pause, I/O mark the first/last frame to export; playback speed,
// loop and reverse; the image zooms, pans and measures (ImageView).
#include <QFutureWatcher>
#include <QTimer>
#include <QWidget>

#include "app/gui/image_view.hpp"
#include "app/gui/result_card.hpp"
#include "app/gui/shot_analysis_service.hpp"

class QSlider;
class QLabel;
class QCheckBox;
class QPushButton;
class QComboBox;
class QHBoxLayout;

namespace collide::gui {

/// What the analysis shows on frame `index` of the shot's burst (pixels).
Overlay analysisOverlay(const hw::Shot& shot, const vision::ShotAnalysis& analysis,
                        std::size_t index);
/// The ground truth's spheres on frame `index` (simulated shots).
Overlay truthOverlay(const hw::Shot& shot, std::size_t index);
/// The analysed contact instant in seconds from the trigger (frame 0), the
/// clock the replay's frame times use (NaN if there is none).
double contactFromTrigger_s(const hw::Shot& shot, const vision::ShotAnalysis& analysis);

class ReplayView : public QWidget {
  Q_OBJECT
 public:
  explicit ReplayView(QWidget* parent = nullptr);
  ~ReplayView() override;

  void setShot(ShotPtr shot);
  void setAnalysis(AnalysisPtr analysis);
  ShotPtr shot() const { return shot_; }
  AnalysisPtr analysis() const { return analysis_; }

  void showFrame(int index);
  int frameIndex() const { return index_; }
  int frameCount() const;
  ResultCard* resultCard() const { return card_; }
  ImageView* imageView() const { return view_; }

  bool playing() const { return play_timer_.isActive(); }
  /// Display rate while playing, frames per second of screen time.
  double playbackRate() const;
  /// The same as a fraction of real time: playbackRate() / the recording's
  /// frames per second (1/40 for 25 frames/s of a 1000 frames/s burst; NaN
  /// without a shot or frame rate).
  double playbackRealTimeFraction() const;
  /// First and last frame (positions in the burst) that "Export frames" writes.
  int markIn() const { return mark_in_; }
  int markOut() const { return mark_out_; }
  /// Writes frames markIn()..markOut() as PNG files into `dir` (Mono12 shown
  /// stretched to 16 bits). Returns an error message, or empty on success.
  QString exportMarkedFrames(const QString& dir);
  /// Writes frames markIn()..markOut() as an AVI video (Motion JPEG, 8-bit
  /// grey scaled as shown) playing at `playback_fps`. Returns an error message
  /// (naming the file and what to do; no partial file is left), or empty.
  /// (*Export video...* does the same on a worker thread; its outcome shows
  /// in the label named "export_status".)
  QString exportMarkedVideo(const QString& path, double playback_fps);

 signals:
  void reanalyseRequested(collide::gui::ShotPtr shot);

 private:
  QHBoxLayout* makeTransportRow();
  QHBoxLayout* makeDisplayRow();
  QHBoxLayout* makeExportRow();
  void addKeys();
  void redraw();
  void togglePlay();
  void playStep();
  void setMark(bool in);
  void updateMarkLabel();
  void chooseExportFolder();
  void chooseVideoFile();
  void startVideoExport(const QString& path, double playback_fps, int slow_down);
  void finishVideoExport();
  void relabelSpeeds();
  void showExportResult(const QString& done, const QString& error);
  vision::Burst markedFrames() const;

  ShotPtr shot_;
  AnalysisPtr analysis_;
  int index_ = 0;
  ImageView* view_ = nullptr;
  ResultCard* card_ = nullptr;
  QSlider* slider_ = nullptr;
  QLabel* frame_label_ = nullptr;
  QCheckBox* show_analysis_ = nullptr;
  QCheckBox* show_truth_ = nullptr;
  QPushButton* play_ = nullptr;
  QPushButton* reanalyse_ = nullptr;
  QComboBox* speed_ = nullptr;
  QCheckBox* loop_ = nullptr;
  QCheckBox* reverse_ = nullptr;
  QCheckBox* crosshair_ = nullptr;
  QLabel* marks_ = nullptr;
  QLabel* export_status_ = nullptr;
  QPushButton* export_video_ = nullptr;
  QFutureWatcher<QString> video_export_;
  QString video_done_;  ///< what the running export says when it succeeds
  int mark_in_ = 0, mark_out_ = 0;
  QTimer play_timer_;
};

}  // namespace collide::gui
