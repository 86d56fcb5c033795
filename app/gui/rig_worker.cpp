#include "app/gui/rig_worker.hpp"

#include <QDir>
#include <QStringList>
#include <cmath>
#include <future>

#include "app/profile_edit.hpp"
#include "app/rig_setup.hpp"
#include "app/store/save.hpp"
#include "app/store/shot_id.hpp"
#include "app/version.hpp"
#include "hw/sequencer.hpp"

namespace collide::gui {
namespace {

QString qs(const std::string& s) {
  return QString::fromStdString(s);
}

}  // namespace

RigWorker::RigWorker() {
  qRegisterMetaType<ProfilePtr>();
  qRegisterMetaType<CameraPtr>();
  qRegisterMetaType<RigStatus>();
  qRegisterMetaType<ShotPtr>();
  qRegisterMetaType<AdaptiveStepPtr>();
  outbox_ = std::make_unique<Mailbox>();
  // Children move to the control thread with the worker; everything here is
  // set before that thread starts.
  inbox_ = new Mailbox(this);
  poll_timer_ = new QTimer(this);
  poll_timer_->setInterval(50);
  connect(poll_timer_, &QTimer::timeout, this, &RigWorker::poll);
  thread_.setObjectName("rig control");
  moveToThread(&thread_);
  thread_.start();
}

RigWorker::~RigWorker() {
  requestCancel();
  std::promise<void> shut_down;
  inbox_->post([this, &shut_down] {
    delete poll_timer_;
    poll_timer_ = nullptr;
    shutDownRig();
    shut_down.set_value();
  });
  shut_down.get_future().wait();
  thread_.quit();
  thread_.wait();
}

void RigWorker::requestLoadProfile(QString path) {
  inbox_->post([this, path] { loadProfile(path); });
}
void RigWorker::requestArm(std::array<double, 2> v) {
  inbox_->post([this, v] { arm(v); });
}
void RigWorker::requestDisarm() {
  inbox_->post([this] { disarm(); });
}
void RigWorker::requestFire(std::array<double, 2> v, QString out_dir) {
  inbox_->post([this, v, out_dir] { fire(v, out_dir); });
}
void RigWorker::requestCampaign(app::CampaignOptions options) {
  inbox_->post([this, options] { campaign(options); });
}
void RigWorker::requestAdaptiveCampaign(app::CampaignOptions options, AdaptiveOptions design) {
  inbox_->post([this, options, design] { adaptiveCampaign(options, design); });
}
void RigWorker::requestBurstSettings(int pre, int post, double fps, double exposure_us) {
  inbox_->post([this, pre, post, fps, exposure_us] { burstSettings(pre, post, fps, exposure_us); });
}

void RigWorker::requestCameraSettings(double fps, double exposure_us, double gain_db) {
  inbox_->post([this, fps, exposure_us, gain_db] { cameraSettings(fps, exposure_us, gain_db); });
}

void RigWorker::requestReconnect() {
  inbox_->post([this] { reconnect(); });
}

void RigWorker::requestCancel() {
  std::lock_guard lock(cancel_mutex_);
  cancel_.request_stop();
}

std::stop_token RigWorker::newCancelToken() {
  std::lock_guard lock(cancel_mutex_);
  cancel_ = std::stop_source();
  return cancel_.get_token();
}

void RigWorker::shutDownRig() {
  if (!rig_) return;
  rig_->camera->setLiveView(false);
  if (rig_->regulator && rig_->regulator->state() != hw::DeviceState::Closed)
    (void)rig_->regulator->vent();
  (void)hw::shutDown(*rig_);
  status_.armed = status_.settled = false;
}

void RigWorker::loadProfile(const QString& path) {
  Result<hw::RigProfile> profile =
      path.isEmpty() ? hw::defaultRigProfile() : hw::loadRigProfile(path.toStdString());
  if (!profile) {
    send(&RigWorker::error,
         tr("Rig profile not loaded: %1. Fix the file and open it again (File > Open rig "
            "profile).")
             .arg(qs(profile.error().message)));
    return;
  }
  useProfile(std::move(profile).value());
}

void RigWorker::burstSettings(int pre, int post, double fps, double exposure_us) {
  if (refusedWhileArmed(tr("Burst settings"))) return;
  applyProfileEdits({{"burst", "pre_trigger_frames", QString::number(pre)},
                     {"burst", "post_trigger_frames", QString::number(post)},
                     {"camera", "fps", QString::number(fps, 'g', 10)},
                     {"camera", "exposure_us", QString::number(exposure_us, 'g', 10)}},
                    tr("Burst settings"));
}

bool RigWorker::refusedWhileArmed(const QString& what) {
  if (!status_.armed && !status_.busy) return false;
  send(&RigWorker::error, tr("%1 not applied: the rig is %2; disarm first.")
                              .arg(what, status_.busy ? tr("firing") : tr("armed")));
  return true;
}

void RigWorker::cameraSettings(double fps, double exposure_us, double gain_db) {
  if (refusedWhileArmed(tr("Camera settings"))) return;
  applyProfileEdits({{"camera", "fps", QString::number(fps, 'g', 10)},
                     {"camera", "exposure_us", QString::number(exposure_us, 'g', 10)},
                     {"camera", "gain_db", QString::number(gain_db, 'g', 10)}},
                    tr("Camera settings"));
}

void RigWorker::applyProfileEdits(const std::vector<ProfileEdit>& edits, const QString& what) {
  if (!profile_) {
    send(&RigWorker::error, tr("No rig: open a rig profile first."));
    return;
  }
  Result<std::string> text = profile_->text;
  for (const ProfileEdit& e : edits) {
    if (!text) break;
    text = app::setProfileValue(*text, e.section, e.key, e.value.toStdString());
  }
  if (!text) {
    send(&RigWorker::error, tr("%1 not applied: %2").arg(what, qs(text.error().message)));
    return;
  }
  Result<hw::RigProfile> edited = hw::parseRigProfile(*text, profile_->source);
  if (!edited) {
    send(&RigWorker::error, tr("%1 not applied: %2").arg(what, qs(edited.error().message)));
    return;
  }
  // A setting the profile allows but the device refuses (a camera's own
  // exposure steps or limits) must not leave the rig down: the rig goes back
  // to the settings it ran with, and the message says what was refused.
  const hw::RigProfile previous = *profile_;
  const Status started = startRig(std::move(edited).value());
  if (started) return;
  send(&RigWorker::error, tr("%1 not applied: %2. Back to the settings the rig had.")
                              .arg(what, qs(started.error().message)));
  useProfile(previous);
}

void RigWorker::useProfile(hw::RigProfile profile) {
  const Status started = startRig(std::move(profile));
  if (started) return;
  const QString why = qs(started.error().message);
  send(&RigWorker::error,
       rig_ ? tr("The rig did not start: %1. Check the device's connection and power, then "
                 "reload the profile.")
                  .arg(why)
            : tr("The rig could not be built: %1").arg(why));
}

Status RigWorker::startRig(hw::RigProfile profile) {
  if (poll_timer_) poll_timer_->stop();
  shutDownRig();
  rig_.reset();
  profile_ = std::make_shared<const hw::RigProfile>(std::move(profile));
  Result<hw::Rig> rig = app::buildRig(*profile_);
  if (!rig) {
    send(&RigWorker::profileLoaded, profile_, nullptr);
    emitStatus();
    return rig.error();
  }
  rig_ = std::make_shared<hw::Rig>(std::move(rig).value());
  const Status up = hw::bringUp(*rig_);
  rig_->camera->setLiveView(true);
  // The camera shares the rig's lifetime: the live view may hold it past a reload.
  send(&RigWorker::profileLoaded, profile_, CameraPtr(rig_, rig_->camera.get()));
  poll_timer_->start();
  emitStatus();
  return up;
}

void RigWorker::arm(std::array<double, 2> speed) {
  if (!rig_ || !profile_) {
    send(&RigWorker::error, tr("No rig: open a rig profile first."));
    return;
  }
  auto curve = profile_->calibration.curve();
  if (!curve) {
    send(&RigWorker::error, qs(curve.error().message));
    return;
  }
  // A lost device is refused every call: say so before touching any line.
  if (Status ready = rig_->health->ready(); !ready) {
    send(&RigWorker::error, tr("Cannot arm: %1").arg(qs(ready.error().message)));
    emitStatus();
    return;
  }
  if (Status up = hw::bringUp(*rig_); !up) {
    send(&RigWorker::error, tr("Cannot arm: %1").arg(qs(up.error().message)));
    return;
  }
  for (int i = 0; i < 2; ++i) {
    Result<double> p = curve->pressure_kPa(speed[i]);
    if (!p) {
      send(&RigWorker::error,
           tr("Launcher %1: %2").arg(qs(profile_->launchers[i].name), qs(p.error().message)));
      return;
    }
    if (Status s = rig_->regulator->setPressureKPa(profile_->launchers[i].regulator_channel, *p);
        !s) {
      send(&RigWorker::error, tr("Cannot arm: %1").arg(qs(s.error().message)));
      (void)rig_->regulator->vent();
      status_.armed = false;
      emitStatus();
      return;
    }
  }
  status_.armed = true;
  status_.settled = false;
  armed_since_.start();
  poll();
}

void RigWorker::disarm() {
  status_.armed = status_.settled = false;
  armed_since_.invalidate();
  if (rig_) {
    if (rig_->regulator->state() != hw::DeviceState::Closed)
      if (Status s = rig_->regulator->vent(); !s) send(&RigWorker::error, qs(s.error().message));
    if (rig_->valves->state() != hw::DeviceState::Closed)
      if (Status s = rig_->valves->closeAll(); !s) send(&RigWorker::error, qs(s.error().message));
  }
  poll();
}

void RigWorker::reconnect() {
  if (!rig_) {
    send(&RigWorker::reconnectFinished, false, tr("No rig: open a rig profile first."));
    return;
  }
  const std::vector<hw::DeviceLoss> lost = rig_->health->lost();
  if (lost.empty()) {
    send(&RigWorker::reconnectFinished, true, tr("Nothing to reconnect: every device answers."));
    emitStatus();
    return;
  }
  // A reopened regulator's setpoints are not the armed ones any more.
  if (rig_->regulator->loss()) status_.armed = status_.settled = false;
  QStringList names;
  for (const hw::DeviceLoss& l : lost) names << qs(l.device);
  const Status found = hw::recheck(*rig_);
  if (found) {
    // Reopened devices run again; the camera feeds the live view again.
    if (Status up = hw::bringUp(*rig_); !up)
      send(&RigWorker::error,
           tr("The rig did not start after the reconnect: %1").arg(qs(up.error().message)));
    rig_->camera->setLiveView(true);
    send(&RigWorker::reconnectFinished, true,
         tr("Reconnected: %1 answer%2 again. Arm when ready.")
             .arg(names.join(", "), names.size() == 1 ? QStringLiteral("s") : QString()));
  } else {
    send(&RigWorker::reconnectFinished, false,
         tr("Still lost after Reconnect: %1").arg(qs(found.error().message)));
  }
  poll();
}

void RigWorker::poll() {
  if (!rig_ || !profile_) return;
  bool settled = status_.armed;
  if (rig_->regulator->state() == hw::DeviceState::Running) {
    for (int i = 0; i < 2; ++i) {
      const int ch = profile_->launchers[i].regulator_channel;
      Result<double> rb = rig_->regulator->readPressureKPa(ch);
      Result<double> sp = rig_->regulator->setpointKPa(ch);
      if (!rb || !sp) {
        settled = false;
        continue;
      }
      status_.readback_kPa[i] = *rb;
      status_.setpoint_kPa[i] = *sp;
      if (std::abs(*rb - *sp) > profile_->sequencer.settle_tolerance_kPa) settled = false;
    }
  } else {
    settled = false;
  }
  status_.settled = settled;
  // Unsettled since when (a line that settled and then leaks counts too).
  if (settled || !status_.armed)
    armed_since_.invalidate();
  else if (!armed_since_.isValid())
    armed_since_.start();
  // The sequencer gives up on a line that does not settle in time; armed and
  // idle the rig must too, or a leaking line stays pressurised with no alarm.
  if (status_.armed && !settled && !status_.busy && armed_since_.isValid() &&
      armed_since_.elapsed() > profile_->sequencer.settle_timeout_s * 1000.0) {
    QStringList lines;
    for (int i = 0; i < 2; ++i)
      if (std::abs(status_.readback_kPa[i] - status_.setpoint_kPa[i]) >
          profile_->sequencer.settle_tolerance_kPa)
        lines << tr("launcher %1 (%2) at %3 kPa of %4 kPa")
                     .arg(i + 1)
                     .arg(qs(profile_->launchers[i].name))
                     .arg(status_.readback_kPa[i], 0, 'f', 2)
                     .arg(status_.setpoint_kPa[i], 0, 'f', 2);
    if (lines.isEmpty()) lines << tr("the regulator stopped answering");
    armed_since_.invalidate();
    disarm();  // vents and closes the valves, then polls and reports the state
    send(&RigWorker::error,
         tr("Pressure did not settle within %1 s (tolerance %2 kPa): %3. The lines were "
            "vented and the rig disarmed. Check the line for a leak and the supply "
            "pressure, then arm again.")
             .arg(profile_->sequencer.settle_timeout_s)
             .arg(profile_->sequencer.settle_tolerance_kPa)
             .arg(lines.join("; ")));
    return;
  }
  emitStatus();
}

void RigWorker::emitStatus() {
  if (rig_) {
    status_.backend = {qs(rig_->profile.regulator.backend), qs(rig_->profile.valves.backend),
                       qs(rig_->profile.camera.backend)};
    status_.device = {qs(rig_->profile.regulator.device), qs(rig_->profile.valves.device),
                      qs(rig_->profile.camera.device)};
    status_.state = {hw::toString(rig_->regulator->state()), hw::toString(rig_->valves->state()),
                     hw::toString(rig_->camera->state())};
    status_.lost = {rig_->regulator->loss(), rig_->valves->loss(), rig_->camera->loss()};
  } else {
    status_.state = {"none", "none", "none"};
    status_.lost = {};
  }
  send(&RigWorker::status, status_);
}

void RigWorker::fire(std::array<double, 2> speed, const QString& out_dir) {
  if (!rig_) {
    send(&RigWorker::error, tr("No rig: open a rig profile first."));
    return;
  }
  if (!status_.armed || !status_.settled) {
    send(&RigWorker::error,
         tr("Not ready to fire: arm first and wait until both pressures have settled."));
    return;
  }
  status_.busy = true;
  emitStatus();
  const std::stop_token cancel = newCancelToken();
  hw::Sequencer sequencer(*rig_);
  hw::Shot shot = sequencer.fire(
      hw::ShotRequest::atSpeeds(speed[0], speed[1]),
      [this](const hw::StepStamp& step) {
        send(&RigWorker::shotStep,
             qs(step.detail.empty() ? step.name : step.name + ": " + step.detail));
      },
      cancel);
  shot.id = app::makeShotId(app::wallTimeUnixNs(), shot_counter_++);
  shot.program_version = kVersion;
  QString file, save_error;
  if (auto saved = app::saveShot(out_dir.toStdString(), shot); saved) {
    shot.id = *saved;
    file = QDir(out_dir).filePath(qs(app::shotFileName(shot.id)));
  } else
    save_error = qs(saved.error().message);
  if (shot.status == hw::ShotStatus::Failed && profile_->safety.vent_on_failure)
    status_.armed = false;  // the sequencer vented the lines
  // The sequencer stops the camera after the burst: restart it for the live view.
  if (Status up = hw::bringUp(*rig_); !up)
    send(&RigWorker::error,
         tr("After the shot the rig did not restart: %1").arg(qs(up.error().message)));
  status_.busy = false;
  // The state first (not busy: Disarm and Arm enabled again), then the shot:
  // when the window shows the shot its buttons already answer.
  poll();
  auto shared = std::make_shared<const hw::Shot>(std::move(shot));
  send(&RigWorker::shotFired, shared, file, save_error);
}

bool RigWorker::beginCampaign() {
  if (!profile_) {
    // Said once, by campaignFinished (the window shows it and unlocks the view).
    send(&RigWorker::campaignFinished,
         tr("Campaign not started: no rig profile is loaded. Open one (File > "
            "Open rig profile), then run the campaign again."),
         false, false);
    return false;
  }
  // The campaign builds a rig per shot (each aimed for its angle): free the
  // devices for it (lines vented, valves closed), and take them back afterwards.
  poll_timer_->stop();
  shutDownRig();
  status_.busy = true;
  emitStatus();
  return true;
}

void RigWorker::endCampaign() {
  status_.busy = false;
  if (rig_) {
    if (Status up = hw::bringUp(*rig_); !up)
      send(&RigWorker::error,
           tr("After the campaign the rig did not restart: %1").arg(qs(up.error().message)));
    rig_->camera->setLiveView(true);
  }
  poll_timer_->start();
  emitStatus();
}

void RigWorker::campaign(const app::CampaignOptions& options) {
  if (!beginCampaign()) return;
  const std::stop_token cancel = newCancelToken();
  Result<app::CampaignReport> report = app::runCampaign(
      *profile_, options,
      [this](int done, int total, const hw::Shot& shot) {
        send(&RigWorker::campaignProgress, done, total, std::make_shared<const hw::Shot>(shot));
      },
      cancel);
  endCampaign();
  if (!report) {
    send(&RigWorker::campaignFinished, tr("Campaign stopped: %1").arg(qs(report.error().message)),
         false, false);
    return;
  }
  send(&RigWorker::campaignFinished, campaignSummary(options, *report), report->cancelled,
       report->fired == options.shots && report->failed == 0 &&
           static_cast<int>(report->files.size()) == options.shots);
}

void RigWorker::adaptiveCampaign(const app::CampaignOptions& options,
                                 const AdaptiveOptions& design) {
  if (!beginCampaign()) return;
  const std::stop_token cancel = newCancelToken();
  // The CLI's engine (app/adaptive_campaign.hpp), here on the control thread.
  Result<app::AdaptiveCampaignReport> report = app::runAdaptiveCampaign(
      *profile_, options, design,
      [this, &design](int done, int budget, const app::AdaptiveShot& shot,
                      const AdaptiveStatus& st) {
        auto step = std::make_shared<AdaptiveStep>();
        step->done = done;
        step->budget = budget;
        step->shot = shot;
        step->status = st;
        step->sigmas = qs(app::adaptiveSigmasText(st, design));
        send(&RigWorker::adaptiveProgress, step);
      },
      cancel);
  endCampaign();
  if (!report) {
    send(&RigWorker::campaignFinished,
         tr("Adaptive campaign stopped: %1").arg(qs(report.error().message)), false, false);
    return;
  }
  // Complete: stopped at the targets with every shot fired saved and ok.
  const app::CampaignReport& c = report->campaign;
  send(&RigWorker::campaignFinished, adaptiveCampaignSummary(options, design, *report), c.cancelled,
       report->targets_met && c.failed == 0 && static_cast<int>(c.files.size()) == c.fired);
}

namespace {

// ". Failed: <reason> (<ids>); ..." with shots that failed alike listed once.
QString failuresText(const app::CampaignReport& report) {
  if (report.failures.empty()) return {};
  QStringList reasons;
  QList<QStringList> ids;
  for (const std::string& x : report.failures) {
    const QString f = qs(x);
    const qsizetype colon = f.indexOf(": ");
    const QString id = colon < 0 ? QString() : f.left(colon);
    const QString reason = colon < 0 ? f : f.mid(colon + 2);
    qsizetype k = reasons.indexOf(reason);
    if (k < 0) {
      reasons << reason;
      ids << QStringList();
      k = reasons.size() - 1;
    }
    if (!id.isEmpty()) ids[k] << id;
  }
  QStringList parts;
  for (qsizetype k = 0; k < reasons.size(); ++k)
    parts << QObject::tr("%1 (%2)").arg(reasons[k], ids[k].join(", "));
  return QObject::tr(". Failed: %1").arg(parts.join("; "));
}

}  // namespace

QString adaptiveCampaignSummary(const app::CampaignOptions& options, const AdaptiveOptions& design,
                                const app::AdaptiveCampaignReport& report) {
  const app::CampaignReport& c = report.campaign;
  QString s = QObject::tr(
                  "Adaptive campaign: %1. %2 fired (%3 ok, %4 failed on the rig), %5 saved "
                  "into %6")
                  .arg(qs(app::adaptiveStopText(report, options, design)))
                  .arg(c.fired)
                  .arg(c.ok)
                  .arg(c.fired - c.ok)
                  .arg(c.files.size())
                  .arg(qs(options.out_dir));
  return s + failuresText(c) + ".";
}

QString campaignSummary(const app::CampaignOptions& options, const app::CampaignReport& report) {
  // Every planned shot is accounted for: fired (ok or failed on the rig), or
  // not fired, and why.
  const int saved = static_cast<int>(report.files.size());
  QString s = QObject::tr(
                  "Campaign: %1 planned, %2 fired (%3 ok, %4 failed on the rig), %5 saved "
                  "into %6")
                  .arg(options.shots)
                  .arg(report.fired)
                  .arg(report.ok)
                  .arg(report.fired - report.ok)
                  .arg(saved)
                  .arg(qs(options.out_dir));
  const int missing = options.shots - report.fired;
  if (missing > 0) {
    QStringList why;
    if (report.cancelled) why << QObject::tr("%1 after the cancel").arg(report.not_fired);
    if (!report.stopped_because.empty())
      why << QObject::tr("%1 because the campaign stopped: %2")
                 .arg(report.not_fired)
                 .arg(qs(report.stopped_because));
    // Shots that never reached the rig (e.g. no aim for their angle): their
    // reasons are among the failures.
    const int unaimed = missing - report.not_fired;
    if (unaimed > 0) why << QObject::tr("%1 could not be set up (see the failures)").arg(unaimed);
    s +=
        QObject::tr(". %1 of %2 not fired: %3").arg(missing).arg(options.shots).arg(why.join("; "));
  }
  s += failuresText(report);
  return s + ".";
}

}  // namespace collide::gui
