#pragma once
// The rig's control thread. One RigWorker lives on its own QThread and is the
// only code that calls the devices (hw's threading rule): loading a profile,
// bringing the rig up, setting and watching pressures, arming, firing through
// hw::Sequencer, running a campaign through app::runCampaign or
// app::runAdaptiveCampaign. The GUI talks to
// it only through queued calls (the public request* methods may be called from
// any thread) and hears back through signals, so no device call ever blocks
// the GUI. Long work (a shot, a campaign) can be cancelled from any thread.
// Requests and signals cross between the threads through two Mailboxes (a
// std::mutex, which ThreadSanitizer sees): the signals are emitted on the
// thread that created the worker, from what the control thread posted.
#include <QElapsedTimer>
#include <QObject>
#include <QString>
#include <QThread>
#include <QTimer>
#include <array>
#include <memory>
#include <mutex>
#include <optional>
#include <stop_token>
#include <vector>

#include "app/adaptive_campaign.hpp"
#include "app/campaign.hpp"
#include "app/gui/mailbox.hpp"
#include "app/gui/shot_analysis_service.hpp"
#include "hw/rig.hpp"
#include "hw/rig_profile.hpp"

namespace collide::gui {

using ProfilePtr = std::shared_ptr<const hw::RigProfile>;
using CameraPtr = std::shared_ptr<hw::Camera>;

/// What the rig panel shows about the devices (one snapshot).
struct RigStatus {
  std::array<QString, 3> backend;  ///< regulator, valves, camera
  std::array<QString, 3> device;
  std::array<QString, 3> state;  ///< "closed", "running", ...
  std::array<double, 2> setpoint_kPa{0, 0};
  std::array<double, 2> readback_kPa{0, 0};
  bool armed = false;
  bool settled = false;  ///< armed and both lines within the profile's tolerance
  bool busy = false;     ///< a shot or campaign is running
  /// Per device (regulator, valves, camera): why it is lost (it stopped
  /// answering: hw/device_health.hpp), or none. A lost device is refused
  /// every call until Reconnect (RigWorker::requestReconnect) finds it again.
  std::array<std::optional<hw::DeviceLoss>, 3> lost;
  bool anyLost() const {
    for (const auto& l : lost)
      if (l) return true;
    return false;
  }
};

/// What a campaign did, for the user: planned, fired (ok / failed), saved, and
/// why each planned shot that was not fired was not.
QString campaignSummary(const app::CampaignOptions& options, const app::CampaignReport& report);

/// The same for an adaptive campaign: why it ended (targets reached, budget
/// spent, stopped), with the sigmas against the targets, then what was fired
/// and saved and why any shot failed.
QString adaptiveCampaignSummary(const app::CampaignOptions& options, const AdaptiveOptions& design,
                                const app::AdaptiveCampaignReport& report);

/// One shot of an adaptive campaign, fired, saved and analysed: what it was,
/// why it was chosen, and the fit after it.
struct AdaptiveStep {
  int done = 0, budget = 0;
  app::AdaptiveShot shot;
  AdaptiveStatus status;
  QString sigmas;  ///< app::adaptiveSigmasText(status, design)
};
using AdaptiveStepPtr = std::shared_ptr<const AdaptiveStep>;

class RigWorker : public QObject {
  Q_OBJECT
 public:
  /// Starts the control thread; the worker lives there from now on.
  RigWorker();
  /// Shuts the rig down (valves closed, pressure vented) and joins the thread.
  ~RigWorker() override;

  // ---- any thread: each queues the work on the control thread -------------
  void requestLoadProfile(QString path);
  /// Pressures for these exit speeds (m/s) through the profile's calibration,
  /// then watch them settle.
  void requestArm(std::array<double, 2> speed_m_s);
  /// Vent to 0 kPa and close the valves.
  void requestDisarm();
  /// One shot at these speeds; saved into `out_dir` (file first, then catalog row).
  void requestFire(std::array<double, 2> speed_m_s, QString out_dir);
  void requestCampaign(app::CampaignOptions options);
  /// An adaptive campaign (options.shots is the budget): each shot is analysed
  /// here (results into its file and the catalog) before the next is chosen.
  void requestAdaptiveCampaign(app::CampaignOptions options, AdaptiveOptions design);
  /// Burst and camera timing: edits the profile's text (so every shot records
  /// the settings it was really taken with) and rebuilds the rig from it.
  /// Refused with an error while armed or busy.
  void requestBurstSettings(int pre_trigger_frames, int post_trigger_frames, double fps,
                            double exposure_us);
  /// Camera exposure, gain and frame rate, as requestBurstSettings applies
  /// its settings (the profile's [camera] table edited, the rig rebuilt).
  /// Refused with an error while armed or busy: the rig is not torn down
  /// under pressure.
  void requestCameraSettings(double fps, double exposure_us, double gain_db);
  /// Cancels the running shot or campaign (between steps / shots).
  void requestCancel();
  /// Looks for the lost devices again (hw::recheck: each is closed, reopened
  /// and probed, which can take half a second plus the link's timeouts, here
  /// on the control thread); reconnectFinished says how it went.
  void requestReconnect();

  /// The rig's control thread (tests check that devices are driven from it).
  QThread* controlThread() { return &thread_; }

 signals:
  void profileLoaded(collide::gui::ProfilePtr profile, collide::gui::CameraPtr camera);
  void status(collide::gui::RigStatus status);
  /// A device or input error: what happened and what to do (one line).
  void error(QString message);
  void shotStep(QString step);
  /// A shot finished (ok or failed) and was saved as `file` (empty and
  /// `save_error` set if saving failed: the shot is still in memory).
  void shotFired(collide::gui::ShotPtr shot, QString file, QString save_error);
  void campaignProgress(int done, int total, collide::gui::ShotPtr shot);
  /// An adaptive campaign's shot is done (fired, saved and analysed).
  void adaptiveProgress(collide::gui::AdaptiveStepPtr step);
  /// Every requested campaign ends with this, also one refused before its
  /// first shot. `complete`: every planned shot was fired, saved and ok;
  /// otherwise `summary` says how many were planned, fired and saved and why
  /// each missing one was not.
  void campaignFinished(QString summary, bool cancelled, bool complete);
  /// A Reconnect finished: `ok` when no device is lost any more; `message`
  /// says which devices answer again, or which is still lost and why.
  void reconnectFinished(bool ok, QString message);

 private:
  void loadProfile(const QString& path);
  /// startRig, its error (if any) emitted with what to do.
  void useProfile(hw::RigProfile profile);
  /// Shuts the rig down and builds and brings up one from `profile`, which is
  /// the profile from then on (profileLoaded is emitted either way, with the
  /// camera when one was built); the device's error otherwise (rig_ is null
  /// when the rig could not even be built).
  Status startRig(hw::RigProfile profile);
  void burstSettings(int pre, int post, double fps, double exposure_us);
  void cameraSettings(double fps, double exposure_us, double gain_db);
  /// True (and an error naming `what` emitted) while armed or firing: the
  /// rig is not rebuilt under pressure.
  bool refusedWhileArmed(const QString& what);
  struct ProfileEdit {
    const char* section;
    const char* key;
    QString value;
  };
  /// The profile's text with these values set, used as the profile from now
  /// on; `what` names the settings in the error if the edit is refused. When
  /// the rig does not start with them (a device refuses a value its profile
  /// allows, e.g. a camera's exposure steps), the error says so and the rig
  /// is started again with the profile it had.
  void applyProfileEdits(const std::vector<ProfileEdit>& edits, const QString& what);
  void arm(std::array<double, 2> speed_m_s);
  void disarm();
  void fire(std::array<double, 2> speed_m_s, const QString& out_dir);
  void campaign(const app::CampaignOptions& options);
  void adaptiveCampaign(const app::CampaignOptions& options, const AdaptiveOptions& design);
  /// Frees the devices for a campaign (it builds a rig per shot, each aimed
  /// for its angle); false (campaignFinished said why) without a profile.
  bool beginCampaign();
  /// Takes the devices back after a campaign.
  void endCampaign();
  void reconnect();
  void poll();
  void shutDownRig();
  void emitStatus();
  std::stop_token newCancelToken();
  /// Any thread: emits `signal` with these arguments (copied now) on the
  /// thread that created the worker.
  template <class... Params, class... Args>
  void send(void (RigWorker::*signal)(Params...), Args&&... args) {
    outbox_->post([this, signal, ... values = std::decay_t<Params>(std::forward<Args>(args))] {
      (this->*signal)(values...);
    });
  }

  QThread thread_;
  Mailbox* inbox_ = nullptr;         ///< requests; lives on the control thread
  std::unique_ptr<Mailbox> outbox_;  ///< signals; lives on the creating thread
  QTimer* poll_timer_ = nullptr;     // lives on the control thread
  std::shared_ptr<hw::Rig> rig_;
  ProfilePtr profile_;
  RigStatus status_;
  int shot_counter_ = 0;
  QElapsedTimer armed_since_;  ///< since the last setpoint while armed and not settled
  std::mutex cancel_mutex_;
  std::stop_source cancel_;
};

}  // namespace collide::gui

Q_DECLARE_METATYPE(collide::gui::ProfilePtr)
Q_DECLARE_METATYPE(collide::gui::CameraPtr)
Q_DECLARE_METATYPE(collide::gui::RigStatus)
Q_DECLARE_METATYPE(collide::gui::AdaptiveStepPtr)
