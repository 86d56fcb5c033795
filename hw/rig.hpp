#pragma once
// A rig: the three devices a profile names, each built by the backend its
// section names (`backend = "sim"`), looked up in the backend registry — one
// line of configuration, never #ifdef. makeRig() builds them; bringUp()
// takes them to running with the profile's settings; shutDown() leaves the
// rig safe (valves closed) and closed.
#include <functional>
#include <memory>
#include <string>

#include "analysis/result.hpp"
#include "hw/camera.hpp"
#include "hw/clock.hpp"
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
};

struct Rig {
  RigProfile profile;
  std::shared_ptr<Clock> clock;
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

/// Closes every valve, stops and closes every device (tries all, returns the
/// first error). Pressure is left as it is. Control thread.
Status shutDown(Rig& rig);

}  // namespace collide::hw
