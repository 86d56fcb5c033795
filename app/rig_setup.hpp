#pragma once
// Building a rig from a profile the way every program does it: the backends
// the profile names, plus what app lends them (the replay camera reads shot
// files through app's reader; hw cannot).
#include <memory>
#include <stop_token>
#include <string>

#include "analysis/result.hpp"
#include "hw/rig.hpp"
#include "hw/sequencer.hpp"
#include "vision/frame.hpp"

namespace collide::app {

/// The burst a replay camera plays: a shot file (.h5), a folder of images or a
/// video file. Errors name the source and what is wrong with it.
Result<vision::Burst> loadReplaySource(const std::string& source);

/// The hooks app lends the backends (replay through loadReplaySource).
hw::RigHooks standardRigHooks();

/// makeRig with the standard hooks; devices closed. `health`: where the
/// devices' health is kept (null: the rig's own; see hw::RigHooks::health).
Result<hw::Rig> buildRig(const hw::RigProfile& profile,
                         std::shared_ptr<hw::DeviceHealth> health = nullptr);
/// One shot on a rig built from `profile` for it (then shut down): the
/// sequencer's record with `id` and this program's version filled in. A shot
/// that fails on the rig comes back with status Failed and the reason; the
/// error is only for a rig that cannot be built (the message says why).
/// `health` is kept across calls by a caller firing shot after shot (a
/// campaign): while it says a device is lost the shot is refused at once.
Result<hw::Shot> fireShot(const hw::RigProfile& profile, const hw::ShotRequest& request,
                          const std::string& id, std::stop_token cancel = {},
                          std::shared_ptr<hw::DeviceHealth> health = nullptr);

}  // namespace collide::app
