#pragma once
// The shot sequencer: one shot, start to finish, on a brought-up rig.
//
//   set both launch pressures (from wanted exit speeds through the launch
//   calibration, or directly) -> wait until the regulator has settled ->
//   arm the camera -> trigger it at the predicted contact -> fire the valves
//   with the delay that makes the spheres meet in view -> collect the burst ->
//   stop the camera
//
// Every step is timestamped on the rig's clock (CLOCK_MONOTONIC). Any failure
// (regulator never settles, camera short of frames, a device error, cancel)
// stops safely: valves closed, pressure vented to 0 kPa if safety.vent_on_failure,
// camera stopped; the Shot comes back with status Failed, the reason, and the
// frames that did arrive. A device that stopped answering (a call timed out,
// the connection failed, the camera delivered no frame after the trigger) is marked lost
// in the rig's DeviceHealth; while any device is lost, fire() refuses at once
// (status Failed, reason "refused: <device> is lost ...", step "refused"),
// before asking anything of any device, until recheck() finds it again.
#include <array>
#include <functional>
#include <limits>
#include <stop_token>

#include "hw/rig.hpp"
#include "hw/shot.hpp"

namespace collide::hw {

/// What to shoot: per launcher either a wanted exit speed or a pressure.
struct ShotRequest {
  /// Wanted exit speed per launcher, m/s; NaN: use pressure_kPa instead.
  std::array<double, 2> speed_m_s{std::numeric_limits<double>::quiet_NaN(),
                                  std::numeric_limits<double>::quiet_NaN()};
  /// Launch pressure per launcher, gauge kPa; used where speed_m_s is NaN.
  std::array<double, 2> pressure_kPa{std::numeric_limits<double>::quiet_NaN(),
                                     std::numeric_limits<double>::quiet_NaN()};

  static ShotRequest atSpeeds(double v1_m_s, double v2_m_s) {
    ShotRequest r;
    r.speed_m_s = {v1_m_s, v2_m_s};
    return r;
  }
  static ShotRequest atPressures(double p1_kPa, double p2_kPa) {
    ShotRequest r;
    r.pressure_kPa = {p1_kPa, p2_kPa};
    return r;
  }
};

/// Called on the firing thread with each step as it is recorded.
using ShotProgress = std::function<void(const StepStamp&)>;

class Sequencer {
 public:
  /// Borrows `rig` (it must outlive the sequencer).
  explicit Sequencer(Rig& rig) : rig_(rig) {}

  /// Runs one shot and returns its record: status, reason if it failed,
  /// launcher records (commanded and read-back pressure, achieved valve
  /// opening and pulse), steps, camera and scene records, the burst, and the
  /// ground truth when the camera is simulated. Fills wall_time_unix_ns,
  /// rig_name and rig_profile_toml; id and program_version are the caller's.
  /// Devices not running are brought up first (bringUp). Blocks the calling
  /// thread for the shot (call it from a worker, never a GUI thread);
  /// `cancel` is honoured between steps and while waiting (not during the
  /// valve pulse itself). Never throws.
  Shot fire(const ShotRequest& request, const ShotProgress& progress = {},
            std::stop_token cancel = {});

 private:
  Rig& rig_;
};

}  // namespace collide::hw
