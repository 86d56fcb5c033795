#pragma once
// Everything recorded about one shot: what was commanded, what the devices did,
// the burst, the ground truth when simulated, and (after analysis) the results.
// The sequencer (hw) fills it; app/ stores it as one HDF5 file plus a catalog row
// (layout in docs/shot-format.md).
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "analysis/flight.hpp"
#include "analysis/types.hpp"
#include "vision/frame.hpp"

namespace collide::hw {

/// One sequencer step, timestamped on the host's CLOCK_MONOTONIC.
struct StepStamp {
  std::string
      name;  ///< e.g. "set_pressure", "settled", "arm", "fire", "trigger", "collected", "stop"
  std::int64_t t_ns = 0;
  std::string detail;
};

struct LauncherRecord {
  double wanted_speed_m_s = 0.0;   ///< asked for (NaN if pressure was set directly)
  double commanded_kPa = 0.0;      ///< setpoint written to the regulator
  double readback_kPa = 0.0;       ///< regulator read-back when the valve fired
  std::int64_t valve_open_ns = 0;  ///< achieved valve opening, CLOCK_MONOTONIC
  std::int64_t pulse_us = 0;       ///< achieved pulse width
};

/// Camera settings used for the burst.
struct CameraRecord {
  std::string backend;  ///< "sim", "replay", "aravis", "v4l2"
  std::string device;   ///< device id / path / address, as in the profile
  int roi_x = 0, roi_y = 0, width = 0, height = 0;
  vision::PixelFormat format = vision::PixelFormat::Mono8;
  double fps = 0.0;
  double exposure_us = 0.0;
  double gain_db = 0.0;
  int pre_trigger_frames = 0;
  int post_trigger_frames = 0;
};

/// The scene geometry analysis needs to turn pixels into metres.
struct SceneRecord {
  double pixel_size_m = 0.0;  ///< metres per pixel in the object plane
  std::array<double, 2> diameter_m{0.0, 0.0};
  std::array<double, 2> mass_kg{0.0, 0.0};
  std::string material_name;  ///< e.g. "nylon-6/6"
  /// Image coordinates (u right, v down) of the world origin; world y is up.
  double origin_u_px = 0.0, origin_v_px = 0.0;
};

/// Ground truth of a simulated shot, one sample per frame.
struct TruthRecord {
  Material material;           ///< material used at the collision (e after any |v_n| law)
  double t_collision_s = 0.0;  ///< on the burst's clock: seconds after frame 0's mid-exposure
  std::vector<std::int64_t> frame_id;
  std::vector<double> t_s;  ///< per frame, same clock as t_collision_s
  /// [frame][sphere]
  std::vector<std::array<SphereState, 2>> states;
  std::array<std::vector<Vec3>, 2> dot_centres;  ///< each sphere's dot pattern (body frame, unit)
  double dot_angular_radius_rad = 0.0;
};

enum class ShotStatus { Ok, Failed };
const char* toString(ShotStatus s);  ///< "ok" / "failed"

struct Shot {
  std::string id;  ///< unique, sortable: "YYYYMMDD-HHMMSS-NNNN"
  std::int64_t wall_time_unix_ns = 0;
  std::string program_version;
  std::string rig_name;
  std::string rig_profile_toml;  ///< the profile exactly as used
  ShotStatus status = ShotStatus::Ok;
  std::string failure_reason;  ///< why, if Failed (what happened and what to do)

  std::array<LauncherRecord, 2> launchers;
  std::vector<StepStamp> steps;
  CameraRecord camera;
  SceneRecord scene;
  vision::Burst burst;
  std::optional<TruthRecord> truth;
  std::string results_json;  ///< analysis results (JSON text); empty until analysed
  std::string note;          ///< the experimenter's note on the shot (UTF-8); empty if none
};

}  // namespace collide::hw
