#include "app/wall_analyze.hpp"

#include "app/analyze.hpp"
#include "app/report/wall_results_json.hpp"
#include "hw/camera_sim.hpp"
#include "hw/rig_profile.hpp"

namespace collide::app {

std::optional<vision::WallAnalysisSettings> wallAnalysisSettingsFor(const hw::Shot& shot) {
  auto profile = hw::parseRigProfile(shot.rig_profile_toml, shot.id + " (recorded profile)");
  if (!profile || !profile->wall) return std::nullopt;
  const auto line = hw::wallInImage(*profile);
  if (!line) return std::nullopt;
  vision::WallAnalysisSettings s;
  s.pixel_size_m = shot.scene.pixel_size_m;
  s.diameter_m = shot.scene.diameter_m[0];
  s.mass_kg = shot.scene.mass_kg[0];
  s.origin_u_px = shot.scene.origin_u_px;
  s.origin_v_px = shot.scene.origin_v_px;
  s.fps = shot.burst.fps > 0 ? shot.burst.fps : shot.camera.fps;
  s.wall_line = *line;
  // The alignment the profile states ([analysis]): the prior of the launch's v_z.
  s.out_of_plane_speed_fraction = profile->analysis.launch_out_of_plane_fraction;
  s.unknown_spin_sigma_rad_s = profile->analysis.launch_spin_rad_s;
  s.radius_systematic_px = profile->analysis.radius_systematic_px;
  s.air_density_kg_m3 = profile->analysis.air_density_kg_m3;
  // The lens, as the two-sphere analysis takes it.
  s.camera = recordedLens(*profile);
  return s;
}

std::optional<Result<WallShotResults>> analyzeWallShotInFull(const hw::Shot& shot) {
  const auto settings = wallAnalysisSettingsFor(shot);
  if (!settings) return std::nullopt;
  auto a = vision::analyzeWallBurst(shot.burst, *settings);
  if (!a) return Result<WallShotResults>(a.error());
  // Built in place (a temporary Result moved into the optional made GCC 12
  // warn, falsely, -Wmaybe-uninitialized).
  std::optional<Result<WallShotResults>> out;
  std::string json = wallResultsToJson(*a);
  out.emplace(WallShotResults{std::move(*a), std::move(json)});
  return out;
}

std::optional<Result<std::string>> analyzeWallShot(const hw::Shot& shot) {
  auto full = analyzeWallShotInFull(shot);
  if (!full) return std::nullopt;
  if (!*full) return Result<std::string>(full->error());
  return Result<std::string>(std::move((*full)->results_json));
}

}  // namespace collide::app
