#include "app/rig_setup.hpp"

#include <filesystem>

#include "app/store/shot_file.hpp"
#include "app/version.hpp"
#include "vision/frame_io.hpp"

namespace collide::app {

Result<vision::Burst> loadReplaySource(const std::string& source) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(source, ec)) {
    // A folder of imported frames has no frame rate of its own: the replay
    // camera's configured fps applies; 1000 frames/s is only the timestamps' scale.
    return vision::loadFrameFolder(source, 1000.0);
  }
  if (fs::path(source).extension() == ".h5") {
    auto shot = readShot(source);
    if (!shot) return shot.error();
    return std::move(shot->burst);
  }
  return vision::loadVideo(source, 0.0);
}

hw::RigHooks standardRigHooks() {
  hw::RigHooks hooks;
  hooks.load_burst = loadReplaySource;
  return hooks;
}

Result<hw::Rig> buildRig(const hw::RigProfile& profile, std::shared_ptr<hw::DeviceHealth> health) {
  hw::RigHooks hooks = standardRigHooks();
  hooks.health = std::move(health);
  return hw::makeRig(profile, hooks);
}

Result<hw::Shot> fireShot(const hw::RigProfile& profile, const hw::ShotRequest& request,
                          const std::string& id, std::stop_token cancel,
                          std::shared_ptr<hw::DeviceHealth> health) {
  auto rig = buildRig(profile, std::move(health));
  if (!rig) return rig.error();
  hw::Shot shot = hw::Sequencer(*rig).fire(request, {}, cancel);
  (void)hw::shutDown(*rig);  // the shot already records any device error
  shot.id = id;
  shot.program_version = kVersion;
  return shot;
}

}  // namespace collide::app
