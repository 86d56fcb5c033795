#pragma once
// Replaying a recorded shot offline: the rig profile the shot was recorded
// with, with its camera replaced by the replay camera playing `source` and its
// regulator and valves by the simulated ones (config/sim.toml's). Geometry,
// spheres, calibration, burst and sequencer settings stay as recorded, so the
// replayed shot goes through the sequencer and analysis exactly as the live
// one did, on a machine with no hardware.
#include <string>

#include "analysis/result.hpp"
#include "hw/rig_profile.hpp"

namespace collide::hw {

/// `recorded`: the profile text stored with the shot (Shot::rig_profile_toml),
/// `recorded_name` names it in messages; `source`: what the replay camera
/// plays (a shot file, a folder of images or a video); realtime: play at the
/// original pace (false: as fast as possible). Errors: the recorded text does
/// not parse, or the edited profile is refused (the message says which field).
Result<RigProfile> replayProfile(const std::string& recorded, const std::string& recorded_name,
                                 const std::string& source, bool realtime = false);

}  // namespace collide::hw
