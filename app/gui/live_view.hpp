#pragma once
// The live camera view: polls the camera's newest published frame at screen
// rate (the acquisition thread only swaps a pointer to publish, so the view
// can never stall acquisition; frames in between are simply not shown) and
// draws it. Detection overlays come from an optional detector run on a worker
// thread for the shown frames only, never on the acquisition thread. Beside
// the image, as in a vendor viewer: the camera's exposure, gain, frame rate,
// region of interest and format, and the frame's histogram with a saturation
// warning; a crosshair over the image. Exposure, gain and frame rate are
// edited beside the image while the rig is not armed (applied through the rig
// worker: the profile's [camera] table is edited and the rig rebuilt); armed
// or firing they are locked, and a setting the camera's backend cannot change
// is disabled with a tooltip saying why.
#include <QElapsedTimer>
#include <QFutureWatcher>
#include <QTimer>
#include <QWidget>
#include <functional>

#include "app/gui/guarded_spin_box.hpp"
#include "app/gui/histogram_view.hpp"
#include "app/gui/image_view.hpp"
#include "app/gui/rig_worker.hpp"

class QLabel;
class QCheckBox;
class QTimer;

namespace collide::gui {

/// The live view's overlay: spheres (vision::SphereDetector) and their dots
/// (vision::findDots) on one frame. Thread-safe.
Overlay detectSpheresAndDots(const vision::Frame& frame, vision::PixelFormat format);

class LiveView : public QWidget {
  Q_OBJECT
 public:
  /// Draws what a detector found on a frame (worker thread; must be thread-safe).
  using Detector = std::function<Overlay(const vision::Frame&, vision::PixelFormat)>;

  explicit LiveView(QWidget* parent = nullptr);
  ~LiveView() override;

  /// The camera to watch (null: none). Shared with the rig, which outlives it
  /// while the view holds it.
  void setCamera(CameraPtr camera);
  void setDetector(Detector detector) { detector_ = std::move(detector); }
  /// How often the screen is refreshed (Hz).
  void setRefreshRate(double hz);

  /// Frames drawn so far (tests) and the camera's published count when the
  /// last one was drawn.
  std::uint64_t framesShown() const { return shown_; }
  ImageView* imageView() const { return view_; }
  HistogramView* histogramView() const { return histogram_; }
  /// The saturation warning under the histogram (empty when nothing saturates).
  QString saturationWarning() const;
  /// The camera settings shown beside the image.
  QString cameraSettingsText() const;
  CameraPtr camera() const { return camera_; }
  /// Locks the camera controls while the rig is armed or firing.
  void setRigStatus(const RigStatus& status);
  /// True while the camera controls are locked (armed or firing).
  bool cameraControlsLocked() const { return locked_; }
  /// The controls show what the camera runs with again (a refused edit).
  void revertCameraControls() { syncCameraControls(); }

 signals:
  /// The user changed exposure, gain or frame rate (not armed): apply them.
  void cameraSettingsRequested(double fps, double exposure_us, double gain_db);
  /// A typed value was refused: what, the allowed range, the value kept.
  void inputRefused(QString message);

 private:
  void refresh();
  void showCameraSettings();
  QWidget* makeCameraControls();
  void syncCameraControls();
  void updateCameraControlState();
  void requestCameraSettings();

  CameraPtr camera_;
  Detector detector_;
  ImageView* view_ = nullptr;
  QLabel* info_ = nullptr;
  QCheckBox* overlays_ = nullptr;
  QCheckBox* crosshair_ = nullptr;
  HistogramView* histogram_ = nullptr;
  QLabel* saturation_ = nullptr;
  QLabel* settings_ = nullptr;
  GuardedDoubleSpinBox* exposure_ = nullptr;
  GuardedDoubleSpinBox* gain_ = nullptr;
  GuardedDoubleSpinBox* fps_ = nullptr;
  QLabel* controls_note_ = nullptr;
  QTimer* apply_timer_ = nullptr;  ///< one request for several wheel notches
  bool locked_ = false;            ///< armed, firing or a device lost: camera controls off
  bool lost_ = false;              ///< a device is lost (the controls say so)
  hw::CameraInfo camera_info_;
  QTimer timer_;
  std::uint64_t last_published_ = 0;
  std::uint64_t shown_ = 0;
  QElapsedTimer clock_;
  double display_fps_ = 0;
  QFutureWatcher<Overlay> detection_;
};

}  // namespace collide::gui
