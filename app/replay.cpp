#include "app/replay.hpp"

#include <cmath>
#include <filesystem>

#include "app/rig_setup.hpp"
#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"
#include "app/store/shot_id.hpp"
#include "hw/replay_profile.hpp"

namespace collide::app {

Result<ReplayedShot> replayShotFile(const std::string& path, const ReplayOptions& options,
                                    std::stop_token cancel) {
  auto recorded = readShot(path, ReadOptions{.frames = false});
  if (!recorded) return recorded.error();
  auto profile = hw::replayProfile(recorded->rig_profile_toml, path + " (its recorded rig profile)",
                                   path, options.realtime);
  if (!profile) return profile.error();
  hw::ShotRequest request;
  for (int i = 0; i < 2; ++i) {
    const auto& l = recorded->launchers[i];
    if (std::isfinite(l.wanted_speed_m_s)) {
      request.speed_m_s[i] = l.wanted_speed_m_s;
    } else {
      request.pressure_kPa[i] = l.commanded_kPa;
    }
  }
  auto shot = fireShot(*profile, request, makeShotId(wallTimeUnixNs(), options.sequence), cancel);
  if (!shot) return shot.error();
  auto saved = saveShot(options.out_dir, *shot);
  if (!saved) return saved.error();
  shot->id = *saved;
  ReplayedShot out;
  out.source = path;
  out.file = (std::filesystem::path(options.out_dir) / shotFileName(shot->id)).string();
  out.shot = std::move(*shot);
  return out;
}

}  // namespace collide::app
