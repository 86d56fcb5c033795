#pragma once
// A sphere-on-wall shot's results as JSON: the layout of results_json.hpp
// (same schema, same "collision" and "uncertainty" keys, so `collide fit`,
// `collide shots` and the GUI read it unchanged) with "target": "wall", the
// one sphere as "sphere1" (no "sphere2"), and a "wall" object:
//   "wall": {"point_m": [x,y,z], "normal": [x,y,z] (unit, towards the sphere),
//            "t_separation_s": the post-impact fit leaving the face}.
// docs/results-format.md documents it.
#include <string>

#include "vision/wall_shot_analysis.hpp"

namespace collide::app {

std::string wallResultsToJson(const vision::WallShotAnalysis& analysis, int indent = 2);

}  // namespace collide::app
