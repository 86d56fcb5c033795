#pragma once
// A rig: the three devices a profile names, each built by the backend its
// section names (`backend = "sim"`), looked up in the backend registry — one
// line of configuration, never #ifdef. makeRig() builds them; bringUp()
// takes them to running with the profile's settings; shutDown() leaves the
// rig safe (valves closed) and closed. A device that stops answering is
// marked lost in the rig's DeviceHealth (device_health.hpp); recheck() is how
// it is found again.
#include <functional>
#include <memory>
#include <string>

#include "analysis/result.hpp"
#include "hw/camera.hpp"
#include "hw/clock.hpp"
#include "hw/device_health.hpp"
#include "hw/pressure_regulator.hpp"
#include "hw/rig_profile.hpp"
#include "hw/valve_bank.hpp"
#include "vision/frame.hpp"

namespace collide::hw {

/// What the caller (app) lends the backends.
struct RigHooks {
  /// Loads the burst the replay camera plays back: `source` is [camera]
  /// source = "..." (a shot file, a folder of images: the caller decides).
  /// hw cannot read shot files itself; without this hook the replay camera
  /// reads only folders of images and video files.
  std::function<Result<vision::Burst>(const std::string& source)> load_burst;
  /// The devices' and sequencer's clock; null: CLOCK_MONOTONIC. Tests inject
  /// a ManualClock (the simulated camera always runs on CLOCK_MONOTONIC).
  std::shared_ptr<Clock> clock;
  /// Where the devices' health is kept; null: a new one for this rig. A
  /// caller that builds one rig after another for the same devices (a
  /// campaign: one rig per shot) passes the same one, so a device lost in
  /// one shot is still lost for the next.
  std::shared_ptr<DeviceHealth> health;
};

struct Rig {
  RigProfile profile;
  std::shared_ptr<Clock> clock;
  /// Which devices are lost; makeRig shares it with the three devices (a rig
  /// put together by hand leaves each device its own; the sequencer asks both).
  std::shared_ptr<DeviceHealth> health = std::make_shared<DeviceHealth>();
  std::unique_ptr<PressureRegulator> regulator;
  std::unique_ptr<ValveBank> valves;
  std::unique_ptr<Camera> camera;
};

/// Builds every device the profile names, closed. Errors: an unknown backend
/// ("<file>:<line>: camera.backend = "x": unknown backend (known: ...)"), a
/// backend's own settings rejected (file, line, field), a backend that needs
/// a hook it was not given. Control thread.
Result<Rig> makeRig(const RigProfile& profile, const RigHooks& hooks = {});

/// Opens, configures (from the profile) and starts every device not yet
/// running. Stops at the first error, naming the device. Control thread.
Status bringUp(Rig& rig);

/// Finds lost devices again: each device of the rig that is lost is closed,
/// brought up again and probed (the regulator: every launcher's channel read
/// once; the camera: a two-frame burst, its trigger 50 ms ahead, within half a
/// second of it); each that answers is
/// no longer lost. Errors: the first device that still does not answer (it
/// stays lost, with the new reason). Nothing is done when none is lost.
/// Control thread.
Status recheck(Rig& rig);

/// Closes every valve, stops and closes every device (tries all, returns the
/// first error). Pressure is left as it is. Control thread.
Status shutDown(Rig& rig);

}  // namespace collide::hw
