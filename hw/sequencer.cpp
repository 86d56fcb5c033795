#include "hw/sequencer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "hw/format.hpp"
#include "hw/launch_plan.hpp"
#include "hw/try.hpp"

namespace collide::hw {

namespace {

std::string kPa(double p) {
  return num(std::round(p * 100.0) / 100.0) + " kPa";
}

std::string ms(std::int64_t ns) {
  return num(std::round(ns * 1e-4) / 100.0) + " ms";
}

// The state of one shot in progress; Sequencer::fire() runs one of these.
class ShotRun {
 public:
  ShotRun(Rig& rig, const ShotProgress& progress, std::stop_token cancel)
      : rig_(rig), p_(rig.profile), progress_(progress), cancel_(std::move(cancel)) {}

  Shot run(const ShotRequest& request) {
    shot_.wall_time_unix_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                                  std::chrono::system_clock::now().time_since_epoch())
                                  .count();
    shot_.rig_name = p_.name;
    shot_.rig_profile_toml = p_.text;
    fillRecords();
    stamp("start");
    // A lost device: refused before anything is asked of any device (no valve
    // opened, no timeout waited out again).
    if (Status ready = devicesReady(); !ready) {
      shot_.status = ShotStatus::Failed;
      shot_.failure_reason = "refused: " + ready.error().message;
      stamp("refused", "a device is lost: nothing was fired");
      return std::move(shot_);
    }
    if (Status s = steps(request); !s) stopSafely(s.error().message);
    return std::move(shot_);
  }

 private:
  void stamp(std::string name, std::string detail = {}) {
    shot_.steps.push_back({std::move(name), rig_.clock->nowNs(), std::move(detail)});
    if (progress_) progress_(shot_.steps.back());
  }

  // Ok unless a device is lost: the rig's health, or (a rig put together by
  // hand) a device's own.
  Status devicesReady() const {
    if (rig_.health)
      if (Status s = rig_.health->ready(); !s) return s;
    for (const std::optional<DeviceLoss>& loss :
         {rig_.regulator ? rig_.regulator->loss() : std::nullopt,
          rig_.valves ? rig_.valves->loss() : std::nullopt,
          rig_.camera ? rig_.camera->loss() : std::nullopt})
      if (loss) return fail(lostMessage(*loss));
    return Ok{};
  }

  Status checkCancel(const char* when) const {
    if (cancel_.stop_requested()) return fail(std::string("cancelled ") + when);
    return Ok{};
  }

  int channel(int i) const { return p_.launchers[i].regulator_channel; }
  const std::string& name(int i) const { return p_.launchers[i].name; }

  void fillRecords() {
    CameraRecord& c = shot_.camera;
    if (rig_.camera) {
      const CameraInfo info = rig_.camera->info();
      c.backend = info.backend;
      c.device = info.device;
    }
    const CameraConfig& cc = p_.camera_config;
    c.roi_x = cc.roi_x;
    c.roi_y = cc.roi_y;
    c.width = cc.width;
    c.height = cc.height;
    c.format = cc.format;
    c.fps = cc.fps;
    c.exposure_us = cc.exposure_us;
    c.gain_db = cc.gain_db;
    c.pre_trigger_frames = p_.burst.pre_trigger_frames;
    c.post_trigger_frames = p_.burst.post_trigger_frames;
    SceneRecord& s = shot_.scene;
    s.pixel_size_m = p_.geometry.pixel_size_m;
    s.diameter_m = p_.spheres.diameter_m;
    s.mass_kg = p_.spheres.mass_kg;
    s.material_name = p_.spheres.material_name;
    s.origin_u_px = p_.geometry.origin_u_px;
    s.origin_v_px = p_.geometry.origin_v_px;
  }

  // Pressures to set and the exit speeds they should give.
  Status resolve(const ShotRequest& request, std::array<double, 2>& pressure,
                 std::array<double, 2>& speed) {
    COLLIDE_ASSIGN_OR_RETURN(const LaunchCalibration curve, p_.calibration.curve());
    for (int i = 0; i < 2; ++i) {
      LauncherRecord& l = shot_.launchers[i];
      l.wanted_speed_m_s = request.speed_m_s[i];
      if (std::isfinite(request.speed_m_s[i])) {
        Result<double> p = curve.pressure_kPa(request.speed_m_s[i]);
        if (!p) return fail("launcher " + name(i) + ": " + p.error().message);
        pressure[i] = *p;
        speed[i] = request.speed_m_s[i];
      } else if (std::isfinite(request.pressure_kPa[i])) {
        pressure[i] = request.pressure_kPa[i];
        speed[i] = curve.speed_m_s(pressure[i]);
      } else {
        return fail("launcher " + name(i) + ": give an exit speed (m/s) or a pressure (kPa)");
      }
    }
    return Ok{};
  }

  Status settle() {
    const SequencerProfile& sp = p_.sequencer;
    Clock& clock = *rig_.clock;
    PressureRegulator& reg = *rig_.regulator;
    const std::int64_t start = clock.nowNs();
    const auto timeout = start + std::llround(sp.settle_timeout_s * 1e9);
    const auto hold = std::llround(sp.settle_hold_s * 1e9);
    const auto poll = std::max<std::int64_t>(1, std::llround(sp.poll_interval_s * 1e9));
    std::optional<std::int64_t> settled_since;
    for (;;) {
      COLLIDE_RETURN_IF_ERROR(checkCancel("while the pressure settled"));
      bool all = true;
      for (int i = 0; i < 2; ++i) {
        COLLIDE_ASSIGN_OR_RETURN(const bool ok, reg.settled(channel(i), sp.settle_tolerance_kPa));
        all = all && ok;
      }
      const std::int64_t now = clock.nowNs();
      if (!all) {
        settled_since.reset();
      } else if (!settled_since) {
        settled_since = now;
      }
      if (settled_since && now - *settled_since >= hold) {
        stamp("settled", "after " + ms(now - start));
        return Ok{};
      }
      if (now >= timeout) {
        std::string readings;
        for (int i = 0; i < 2; ++i) {
          Result<double> r = reg.readPressureKPa(channel(i));
          readings += (i ? ", " : "") + name(i) + " reads " +
                      (r ? kPa(*r) : std::string("nothing")) + " for " +
                      kPa(shot_.launchers[i].commanded_kPa);
        }
        return fail("the regulator did not settle within " + num(sp.settle_timeout_s) + " s (" +
                    readings + ", tolerance " + num(sp.settle_tolerance_kPa) +
                    " kPa): check the air supply and lines, or raise sequencer.settle_timeout_s "
                    "(retrying can help if the supply was only slow this once)");
      }
      clock.sleepUntilNs(now + poll);
    }
  }

  // Waits for the burst until `deadline_ns`, in slices so a cancel is seen.
  // While frames keep arriving the deadline moves to `silence_ns` after the
  // newest: a camera slower than real time (a simulated one on a loaded
  // machine or under a sanitizer) still delivers its burst; one that falls
  // silent is given up on as before.
  Status collect(std::int64_t deadline_ns, std::int64_t silence_ns) {
    Clock& clock = *rig_.clock;
    constexpr std::int64_t kSliceNs = 20'000'000;
    std::uint64_t arrived = rig_.camera->burstArrivals();
    for (;;) {
      COLLIDE_RETURN_IF_ERROR(checkCancel("while collecting frames"));
      const std::int64_t until = std::min(deadline_ns, clock.nowNs() + kSliceNs);
      COLLIDE_ASSIGN_OR_RETURN(const bool done, rig_.camera->waitBurst(until));
      if (done) return Ok{};
      if (const std::uint64_t now_arrived = rig_.camera->burstArrivals(); now_arrived != arrived) {
        arrived = now_arrived;
        deadline_ns = std::max(deadline_ns, clock.nowNs() + silence_ns);
      }
      if (clock.nowNs() >= deadline_ns) return Ok{};
      clock.sleepUntilNs(until);  // an injected clock moves on here; the real one has already
    }
  }

  Status takeBurst() {
    COLLIDE_ASSIGN_OR_RETURN(shot_.burst, rig_.camera->takeBurst());
    armed_ = false;
    return Ok{};
  }

  Status steps(const ShotRequest& request) {
    std::array<double, 2> pressure{}, speed{};
    COLLIDE_RETURN_IF_ERROR(resolve(request, pressure, speed));
    COLLIDE_ASSIGN_OR_RETURN(const LaunchPlan plan, planLaunch(p_, speed));
    COLLIDE_RETURN_IF_ERROR(checkCancel("before the shot started"));

    if (rig_.regulator->state() != DeviceState::Running ||
        rig_.valves->state() != DeviceState::Running ||
        rig_.camera->state() != DeviceState::Running) {
      COLLIDE_RETURN_IF_ERROR(bringUp(rig_));
      stamp("bring_up", "devices opened, configured and started from the profile");
    }

    // A wall rig fires launcher 1 only: launcher 2 is held at 0 kPa and its
    // valve stays shut.
    const int fired_launchers = p_.wall ? 1 : 2;
    if (p_.wall) pressure[1] = 0.0;
    for (int i = 0; i < 2; ++i) {
      COLLIDE_RETURN_IF_ERROR(rig_.regulator->setPressureKPa(channel(i), pressure[i]));
      shot_.launchers[i].commanded_kPa = pressure[i];
    }
    stamp("set_pressure",
          name(0) + " " + kPa(pressure[0]) + ", " + name(1) + " " + kPa(pressure[1]));
    COLLIDE_RETURN_IF_ERROR(settle());
    for (int i = 0; i < 2; ++i) {
      COLLIDE_ASSIGN_OR_RETURN(shot_.launchers[i].readback_kPa,
                               rig_.regulator->readPressureKPa(channel(i)));
    }
    COLLIDE_RETURN_IF_ERROR(checkCancel("before arming the camera"));

    const int pre = p_.burst.pre_trigger_frames, post = p_.burst.post_trigger_frames;
    COLLIDE_RETURN_IF_ERROR(rig_.camera->arm(pre, post));
    armed_ = true;
    stamp("arm",
          std::to_string(pre) + " pre- and " + std::to_string(post) + " post-trigger frames");

    // Open the valves soon, but late enough that the ring holds its
    // pre-trigger frames by the predicted contact, which is frame 0.
    const std::int64_t period = rig_.camera->config().framePeriodNs();
    const auto contact_ns = std::llround(plan.contact_s * 1e9);
    const std::int64_t lead =
        std::max<std::int64_t>(2'000'000, (pre + 2) * period - contact_ns + 1'000'000);
    const std::int64_t t0 = rig_.clock->nowNs() + lead;
    const std::int64_t t_contact = t0 + contact_ns;
    COLLIDE_RETURN_IF_ERROR(rig_.camera->trigger(t_contact));
    stamp("trigger", "frame 0 at the predicted contact, " + ms(t_contact - rig_.clock->nowNs()) +
                         " ahead, near pixel (" + num(std::round(plan.contact_px.x())) + ", " +
                         num(std::round(plan.contact_px.y())) + ")");

    std::vector<ValvePulse> pattern;
    std::string planned;
    for (int i = 0; i < fired_launchers; ++i) {
      const auto open = t0 + std::llround(plan.valve_open_s[i] * 1e9);
      pattern.push_back({p_.launchers[i].valve, open, p_.sequencer.pulse_us});
      planned += (i ? ", " : "") + name(i) + " opens at +" + ms(open - t0);
    }
    COLLIDE_RETURN_IF_ERROR(checkCancel("before firing"));
    if (p_.wall) planned += "; " + name(1) + " stays shut (a wall rig)";
    stamp("fire", planned + ", " + std::to_string(p_.sequencer.pulse_us) + " us each");
    COLLIDE_ASSIGN_OR_RETURN(const std::vector<ValveEvent> events, rig_.valves->fire(pattern));
    std::string achieved;
    for (const ValveEvent& e : events) {
      for (int i = 0; i < fired_launchers; ++i) {
        if (p_.launchers[i].valve != e.valve) continue;
        shot_.launchers[i].valve_open_ns = e.opened_ns;
        shot_.launchers[i].pulse_us = e.pulseUs();
        achieved += (achieved.empty() ? "" : ", ") + name(i) + " opened at plan " +
                    (e.opened_ns >= pattern[i].open_at_ns ? "+" : "-") +
                    ms(std::abs(e.opened_ns - pattern[i].open_at_ns)) + " for " +
                    std::to_string(e.pulseUs()) + " us";
      }
    }
    stamp("fired", achieved);

    const std::int64_t silence = std::llround(p_.sequencer.collect_timeout_s * 1e9);
    const std::int64_t deadline =
        t_contact + post * period + std::llround(rig_.camera->config().exposure_us * 1e3) + silence;
    COLLIDE_RETURN_IF_ERROR(collect(deadline, silence));
    COLLIDE_RETURN_IF_ERROR(takeBurst());
    // The camera's backend found it gone during the burst (the frames that
    // arrived are kept in the shot): retrying will not help.
    if (std::optional<DeviceLoss> lost = rig_.camera->loss()) return fail(lostMessage(*lost));
    // Nothing after the trigger within the whole collect window (its slack
    // included): the camera has stopped answering, whatever its ring held
    // from before the trigger.
    const bool none_after_trigger =
        std::none_of(shot_.burst.frames.begin(), shot_.burst.frames.end(),
                     [](const vision::Frame& f) { return f.id >= 0; });
    if (none_after_trigger && !shot_.burst.complete)
      return rig_.camera->markLost(
          "it delivered no frame after the trigger, by " +
              ms(std::max<std::int64_t>(0, rig_.clock->nowNs() - t_contact)) + " after the trigger",
          "the camera's power and cable, and that camera.device still names it");
    const vision::BurstStats& st = shot_.burst.stats;
    stamp("collected", std::to_string(shot_.burst.frames.size()) + " frames, " +
                           std::to_string(st.dropped) + " dropped, " + std::to_string(st.failed) +
                           " failed");
    if (!shot_.burst.complete)
      return fail("the camera fell short of frames: " + shot_.burst.note +
                  "; check the camera link, or raise sequencer.collect_timeout_s (retrying can "
                  "help if frames were lost only this once)");
    if (st.dropped > static_cast<std::uint64_t>(p_.sequencer.max_dropped_frames))
      return fail("the camera dropped " + std::to_string(st.dropped) +
                  " frames, more than sequencer.max_dropped_frames = " +
                  std::to_string(p_.sequencer.max_dropped_frames) +
                  ": check the camera link and bandwidth (retrying can help if the link was "
                  "busy only this once)");

    COLLIDE_RETURN_IF_ERROR(rig_.camera->stop());
    stamp("stop", "camera stopped");
    addTruth();
    shot_.status = ShotStatus::Ok;
    return Ok{};
  }

  void addTruth() {
    if (std::shared_ptr<const TruthSource> truth = rig_.camera->groundTruth())
      shot_.truth = truth->truthFor(shot_.burst);
  }

  // Valves closed, pressure vented if the profile says so, the camera's frames
  // kept and the camera stopped. Tries every step even if one fails.
  void stopSafely(const std::string& reason) {
    std::vector<std::string> done, problems;
    auto attempt = [&](Status s, const std::string& what) {
      if (s)
        done.push_back(what);
      else
        problems.push_back(s.error().message);
    };
    if (rig_.valves && rig_.valves->state() != DeviceState::Closed)
      attempt(rig_.valves->closeAll(), "valves closed");
    if (p_.safety.vent_on_failure && rig_.regulator &&
        rig_.regulator->state() != DeviceState::Closed) {
      if (rig_.regulator->loss())  // asking would only wait out its timeouts again
        problems.push_back(
            "the pressure was not vented (the regulator does not answer): vent "
            "the lines by hand before touching the launchers");
      else
        attempt(rig_.regulator->vent(), "pressure vented to 0 kPa");
    }
    if (rig_.camera && armed_) attempt(takeBurst(), "frames kept");
    if (rig_.camera && rig_.camera->state() == DeviceState::Running)
      attempt(rig_.camera->stop(), "camera stopped");
    if (rig_.camera && !shot_.burst.frames.empty()) addTruth();

    shot_.status = ShotStatus::Failed;
    shot_.failure_reason = reason;
    std::string detail;
    for (const auto& d : done) detail += (detail.empty() ? "" : "; ") + d;
    for (const auto& p : problems) {
      detail += (detail.empty() ? "" : "; ") + p;
      shot_.failure_reason +=
          p == reason ? "; stopping safely hit the same error" : "; while stopping safely: " + p;
    }
    stamp("safe_stop", detail.empty() ? "nothing was running" : detail);
  }

  Rig& rig_;
  const RigProfile& p_;
  const ShotProgress& progress_;
  std::stop_token cancel_;
  Shot shot_;
  bool armed_ = false;
};

}  // namespace

Shot Sequencer::fire(const ShotRequest& request, const ShotProgress& progress,
                     std::stop_token cancel) {
  return ShotRun(rig_, progress, std::move(cancel)).run(request);
}

}  // namespace collide::hw
