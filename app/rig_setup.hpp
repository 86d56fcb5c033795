#pragma once
// Building a rig from a profile the way every program does it: the backends
// the profile names, plus what app lends them (the replay camera reads shot
// files through app's reader; hw cannot).
#include <string>

#include "analysis/result.hpp"
#include "hw/rig.hpp"
#include "vision/frame.hpp"

namespace collide::app {

/// The burst a replay camera plays: a shot file (.h5), a folder of images or a
/// video file. Errors name the source and what is wrong with it.
Result<vision::Burst> loadReplaySource(const std::string& source);

/// The hooks app lends the backends (replay through loadReplaySource).
hw::RigHooks standardRigHooks();

/// makeRig with the standard hooks; devices closed.
Result<hw::Rig> buildRig(const hw::RigProfile& profile);

}  // namespace collide::app
