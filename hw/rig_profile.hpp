#pragma once
// The rig profile (config/*.toml): which backend plays each device role and
// with what settings, the tube geometry, the spheres, the launch calibration,
// the burst, the sequencer's tolerances, the safety limits and the simulation
// knobs. config/sim.toml documents every field and is compiled in as the
// default. Parsing checks every value and reports the first problem as
// "<file>:<line>: <section>.<field> = <value>: <what is wrong>".
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/air_drag.hpp"
#include "analysis/calibration.hpp"
#include "analysis/camera_model.hpp"
#include "analysis/result.hpp"
#include "analysis/types.hpp"
#include "analysis/walton.hpp"
#include "hw/camera.hpp"
#include "hw/pressure_regulator.hpp"
#include "hw/settings.hpp"
#include "hw/valve_bank.hpp"

namespace collide::hw {

/// A device role as the profile names it.
struct DeviceProfile {
  std::string backend;  ///< "sim", "replay", "aravis", ...
  std::string device;   ///< "device" key: id, address or path (default: the backend name)
  /// The device's whole table, including the backend's own settings.
  SettingsTable table;
  /// Keys of `table` the profile itself reads (role settings, not the backend's).
  std::vector<std::string> role_keys;

  /// A reader over `table` with the role keys already marked read: a backend
  /// reads its own keys and then calls finish() to refuse unknown ones.
  /// The reader borrows `table`: keep this DeviceProfile alive while using it.
  SettingsReader backendSettings() const;
};

struct LauncherProfile {
  std::string name;                ///< e.g. "left"
  int valve = 0;                   ///< valve-bank output that fires this tube
  int regulator_channel = 0;       ///< regulator output that feeds this tube
  Vec3 exit_m = Vec3::Zero();      ///< where the sphere's centre leaves the muzzle, world frame
  Vec3 direction = Vec3::UnitX();  ///< unit tube axis, out of the muzzle
  /// How far the launcher's vertical slide can move exit_m down (<= 0) and up
  /// (>= 0), m; none: not limited (`collide plan` then cannot check travel).
  std::optional<std::array<double, 2>> slide_travel_m;
};

struct GeometryProfile {
  double pixel_size_m = 0.0;  ///< object-plane size of one pixel
  double origin_u_px = 0.0;   ///< image pixel (u right, v down) of the world origin
  double origin_v_px = 0.0;
  std::optional<Vec3> meet_point_m;  ///< where the spheres should meet; none: image centre
};

/// [camera.calibration]: the camera's lens as `collide calibrate-camera`
/// measured it from chessboard pictures (vision/camera_calibration.hpp), each
/// value with its standard uncertainty (_sigma). OpenCV's distortion model
/// (analysis/camera_model.hpp), square pixels.
struct CameraCalibrationProfile {
  std::array<int, 2> image_px{0, 0};  ///< size of the pictures: camera.roi's
  double focal_px = 0, focal_px_sigma = 0;
  std::array<double, 2> principal_px{0, 0}, principal_px_sigma{0, 0};
  std::array<double, 4> distortion{0, 0, 0, 0};  ///< k1, k2, p1, p2
  std::array<double, 4> distortion_sigma{0, 0, 0, 0};
  /// Optical centre to the collision plane along the axis, from a picture of
  /// the board lying in it; none: not measured (geometry.pixel_size_m x
  /// focal_px stands in).
  std::optional<double> plane_distance_m, plane_distance_m_sigma;
  /// Metres per pixel at the collision plane on the axis (distance / focal).
  std::optional<double> plane_pixel_size_m, plane_pixel_size_m_sigma;
  double rms_px = 0;  ///< reprojection error of the fit
  int views = 0;      ///< pictures the fit used

  /// The lens as the analysis' camera model, placed as geometry says: the
  /// world origin (on the collision plane) at geometry.origin_px.
  PinholeCamera lens(const GeometryProfile& geometry) const;
};

struct SpheresProfile {
  std::string material_name;  ///< e.g. "nylon-6/6"
  Material material;          ///< Walton's e, mu, beta0 (simulation only)
  std::array<double, 2> diameter_m{0.0, 0.0};
  std::array<double, 2> mass_kg{0.0, 0.0};
};

struct CalibrationProfile {
  /// v(p) = c0 + c1 x + c2 x^2 + c3 x^3, x = p / 100, v in m/s, p gauge kPa.
  std::array<double, 4> coefficients{0.143, 6.6, -5.0, 3.38};
  double min_kPa = 0.0;  ///< working range (v(p) increases on it)
  double max_kPa = 0.0;
  double exit_delay_s = 0.0;  ///< valve opening to the sphere leaving the tube

  /// The curve on the working range (always valid in a parsed profile).
  Result<LaunchCalibration> curve() const {
    return LaunchCalibration::create(coefficients, min_kPa, max_kPa);
  }
};

struct BurstProfile {
  int pre_trigger_frames = 0;
  int post_trigger_frames = 0;
};

struct SequencerProfile {
  double settle_tolerance_kPa = 0.5;
  double settle_hold_s = 0.005;
  double settle_timeout_s = 2.0;
  double poll_interval_s = 0.001;
  std::int64_t pulse_us = 15000;
  /// The longest wait for a frame once the burst should be over: the shot
  /// fails when none has come for this long after the burst's end (while frames
  /// keep coming, e.g. from a simulated camera slower than real time, it waits on).
  double collect_timeout_s = 1.0;
  int max_dropped_frames = 0;
};

struct SafetyProfile {
  double max_pressure_kPa = 0.0;
  std::int64_t max_valve_pulse_us = 0;
  bool vent_on_failure = true;
};

enum class RestitutionLaw { Constant, Power, Viscoelastic };

struct SimulationProfile {
  std::uint64_t seed = 1;
  double speed_scatter = 0.0;                          ///< relative std dev of the exit speed
  double direction_scatter_rad = 0.0;                  ///< std dev of the exit direction, per axis
  std::array<double, 2> spin_at_exit_rad_s{0.0, 0.0};  ///< magnitude range, random axis
  /// Misalignment the rig does not know about: the second sphere leaves its
  /// muzzle D sin(tilt) nearer the camera (z) than the profile says, so the
  /// line of centres at contact leans this far out of the image plane.
  double contact_tilt_rad = 0.0;
  /// Both tubes point out of the image plane: each exit velocity gains a z
  /// component of this fraction of its speed (towards the camera if > 0).
  double out_of_plane_drift = 0.0;
  RestitutionLaw restitution = RestitutionLaw::Constant;
  double restitution_ref_speed_m_s = 1.0;
  double restitution_exponent = 0.0;
  /// The air the simulated spheres fly through (kg/m^3; analysis/air_drag.hpp);
  /// 0: a vacuum.
  double air_density_kg_m3 = kAirDensity_kg_m3;
};

/// What the user states about their rig's alignment ([analysis], optional):
/// the analysis' priors for what the images cannot show, combined with what
/// they can (the apparent sizes, when the camera's distance is known).
struct AnalysisProfile {
  /// How far the line of centres at contact may lean out of the image plane
  /// (standard deviation, degrees): the launchers' height difference over the
  /// contact distance. 0.57 deg = a z part of 0.01.
  double line_of_centres_tilt_deg = 0.573;
  /// Each launch's velocity out of the image plane (standard deviation, as a
  /// fraction of its speed): the tubes' alignment with the plane.
  double launch_out_of_plane_fraction = 0.005;
  /// The launchers' spin (standard deviation per axis, rad/s): the prior of a
  /// spin no dot shows (a bare silhouette, dots out of view), taken as zero
  /// with this spread. Measure it from dotted shots (the RMS of their spins'
  /// components); the default is wide enough for any launch.
  double launch_spin_rad_s = 50.0;
  /// How far apart, beyond the diameters, the measured centres of two
  /// touching spheres may lie (standard deviation, pixels): the detector's
  /// radius bias under this rig's light, e.g. a shaded limb under one-sided
  /// front light. At grazing incidence it moves the contact instant and so
  /// the line of centres; 0: no such bias (even or back light).
  double contact_distance_sigma_px = 0.0;
  /// How much the detector's radius bias may differ between the two spheres
  /// and change along a track (standard deviation, pixels): it bounds what
  /// the apparent sizes can say about depth (the line of centres' z part,
  /// v_z) and widens the contact instants' agreement. 0.1 px suits shaded
  /// front-lit spheres; a bare backlit silhouette's sharp edge is good to
  /// about 0.01 px.
  double radius_systematic_px = 0.1;
  /// How far a detected centre may sit from the true one by an amount that
  /// holds over a track and differs from one track to the next (standard
  /// deviation per image axis, pixels): the dots' and the shaded limb's pull
  /// on the outline, averaged over the track. It moves each fit's position
  /// at the contact, so the instant found where a sphere's two fits meet, and
  /// at grazing incidence the line of centres and e. Measure it with
  /// accuracy_bench --detector-bias ("per track" line); 0: only the dots'
  /// pull on evenly lit spheres (vision/shot_fits.hpp, dotBiasPx).
  double centre_offset_px = 0.0;
  /// The same offset from motion blur, which grows once a sphere's smear
  /// over the exposure (its speed times the exposure, px) passes
  /// `blur_offset_onset_px`: blur_offset_per_px2 (smear - onset)^2 px per
  /// axis, combined with centre_offset_px. Under one-sided light the
  /// detector's edge window (+-2.5 px about the limb) then cuts the smeared,
  /// shaded limb. Measure both with accuracy_bench --detector-bias at several
  /// exposures ("centre offset per track by smear"); 0: no such term.
  double blur_offset_onset_px = 0.0;
  double blur_offset_per_px2 = 0.0;
  /// The air the spheres fly through (kg/m^3): 1.204 for dry air at 20
  /// degrees C and 101.325 kPa (1.16 at 30 degrees C, 1.06 at 1000 m). The
  /// trajectory fits take its drag out (analysis/air_drag.hpp): unmodelled, it
  /// would take ~0.0006 off e at 1.5 m/s over 30 ms tracks. 0: a vacuum.
  double air_density_kg_m3 = kAirDensity_kg_m3;
};

struct RigProfile {
  std::string name;    ///< rig name
  std::string source;  ///< file name the profile came from (for messages)
  std::string text;    ///< the TOML text exactly as read

  DeviceProfile regulator;
  DeviceProfile valves;
  DeviceProfile camera;
  /// [regulator] min_kpa..max_kpa, the maximum capped at safety.max_pressure_kpa.
  RegulatorConfig regulator_config;
  /// The pulse limit from safety.max_valve_pulse_us.
  ValveConfig valve_config;
  CameraConfig camera_config;  ///< ROI, format, fps, exposure, gain from [camera]
  /// [camera.calibration], when the camera has been calibrated.
  std::optional<CameraCalibrationProfile> camera_calibration;
  BurstProfile burst;
  GeometryProfile geometry;
  std::array<LauncherProfile, 2> launchers;
  SpheresProfile spheres;
  CalibrationProfile calibration;
  SequencerProfile sequencer;
  SafetyProfile safety;
  SimulationProfile simulation;
  AnalysisProfile analysis;
  /// [wall], optional: a fixed plate in view that launcher 1's sphere strikes
  /// (a sphere-on-wall rig: launcher 2 is then never fired). point_m is any
  /// point of the plate's face, normal (unit on load) points out of the face
  /// towards launcher 1's exit.
  std::optional<Wall> wall;
  /// [wall] level: the plate's brightness in simulated frames, fraction of full scale.
  double wall_level = 0.0;
};

/// Parses profile `text`; `source_name` names it in messages (a file name).
/// Errors: TOML syntax, a missing or unknown section or field, a value of the
/// wrong type or out of range, inconsistent values (e.g. a pulse above the
/// safety limit) — each with file, line and field.
Result<RigProfile> parseRigProfile(std::string_view text, const std::string& source_name);

/// Reads and parses the file at `path`. Errors as parseRigProfile, plus an
/// unreadable file.
Result<RigProfile> loadRigProfile(const std::filesystem::path& path);

/// config/sim.toml as compiled into the library.
std::string_view defaultRigProfileText();
/// parseRigProfile(defaultRigProfileText(), "config/sim.toml (built in)").
Result<RigProfile> defaultRigProfile();

}  // namespace collide::hw
