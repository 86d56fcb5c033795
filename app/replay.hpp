#pragma once
// Replaying recorded shots offline: each shot file's burst goes through the
// replay camera, the sequencer and the simulated regulator and valves, with
// the profile it was recorded with (hw/replay_profile.hpp), and the new shot
// is saved like any other. The same path a live shot takes, with no hardware:
// how CI checks recorded shots end to end, and how a lab re-runs old footage.
#include <stop_token>
#include <string>

#include "analysis/result.hpp"
#include "hw/shot.hpp"

namespace collide::app {

struct ReplayOptions {
  std::string out_dir;    ///< where the replayed shots are saved (created if missing)
  bool realtime = false;  ///< play at the recorded pace (false: as fast as possible)
  int sequence = 0;       ///< shot-id sequence number: distinct per replay in one second
};

struct ReplayedShot {
  std::string source;  ///< the recorded shot file
  std::string file;    ///< the replayed shot's file in out_dir
  hw::Shot shot;       ///< the replayed shot (frames included)
};

/// Replays one recorded shot file at its recorded launch request (wanted
/// speeds, or pressures when it was fired by pressure). A replay that fails on
/// the rig is saved as a failed shot with the reason, like a live one. Errors:
/// the file cannot be read, its recorded profile cannot drive a replay (the
/// message says which field), out_dir cannot be written.
Result<ReplayedShot> replayShotFile(const std::string& path, const ReplayOptions& options,
                                    std::stop_token cancel = {});

}  // namespace collide::app
