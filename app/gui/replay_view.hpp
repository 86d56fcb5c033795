#pragma once
// Post-shot replay: the burst frame by frame (step, play, slider), with the
// analysis drawn over it (detected spheres and dots, the fitted trajectories
// before and after impact, the collision point and instant) and, for a
// simulated shot, optionally the ground truth; the result card beside it.
#include <QTimer>
#include <QWidget>

#include "app/gui/image_view.hpp"
#include "app/gui/result_card.hpp"
#include "app/gui/shot_analysis_service.hpp"

class QSlider;
class QLabel;
class QCheckBox;
class QPushButton;

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

  void setShot(ShotPtr shot);
  void setAnalysis(AnalysisPtr analysis);
  ShotPtr shot() const { return shot_; }
  AnalysisPtr analysis() const { return analysis_; }

  void showFrame(int index);
  int frameIndex() const { return index_; }
  int frameCount() const;
  ResultCard* resultCard() const { return card_; }
  ImageView* imageView() const { return view_; }

 signals:
  void reanalyseRequested(collide::gui::ShotPtr shot);

 private:
  void redraw();

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
  QTimer play_timer_;
};

}  // namespace collide::gui
