#pragma once
// `collide analyze` on a sphere-on-wall shot: a shot whose recorded rig
// profile has a [wall] table is analysed by vision::analyzeWallBurst, the
// plate's face line taken from the profile, and stored as wall results
// (app/report/wall_results_json.hpp).
#include <optional>
#include <string>

#include "analysis/result.hpp"
#include "hw/shot.hpp"
#include "vision/wall_shot_analysis.hpp"

namespace collide::app {

/// The wall analysis settings a recorded wall shot implies; none when its
/// profile has no [wall] (a sphere-sphere shot) or cannot be read.
std::optional<vision::WallAnalysisSettings> wallAnalysisSettingsFor(const hw::Shot& shot);

/// None: not a wall shot. Otherwise the results JSON, or why the analysis failed.
std::optional<Result<std::string>> analyzeWallShot(const hw::Shot& shot);

/// The same with the analysis itself (its trajectory fits, the face line it
/// used), for the GUI to draw.
struct WallShotResults {
  vision::WallShotAnalysis analysis;
  std::string results_json;
};
std::optional<Result<WallShotResults>> analyzeWallShotInFull(const hw::Shot& shot);

}  // namespace collide::app
