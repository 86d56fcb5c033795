#pragma once
// The one simulated world behind a rig's simulated devices: the air lines the
// regulator feeds, the spheres the valves launch, and the flight the camera
// films. PressureRegulatorSim writes setpoints into it, ValveBankSim tells it
// when valves opened (the exit speed follows from the line pressure at that
// instant through the launch calibration, with the profile's scatter), and
// CameraSim renders what it sees at each frame's exposure. The ground truth of
// the last launch is kept for the Shot's TruthRecord.
//
// Threads: every method may be called from any thread (one mutex inside);
// scenes are handed out as immutable snapshots.
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <vector>

#include "analysis/calibration.hpp"
#include "analysis/flight.hpp"
#include "hw/clock.hpp"
#include "hw/pressure_line.hpp"
#include "hw/rig_profile.hpp"
#include "hw/truth_source.hpp"
#include "hw/valve_bank.hpp"
#include "vision/render.hpp"

namespace collide::hw {

/// One launch: both spheres' flight from the instant the valves opened.
struct SimLaunch {
  Flight flight;
  std::int64_t epoch_ns = 0;  ///< CLOCK_MONOTONIC instant of flight time 0
  std::array<bool, 2> launched{false, false};
  std::array<std::int64_t, 2> launch_ns{0, 0};   ///< when each sphere left its tube
  std::array<double, 2> pressure_kPa{0.0, 0.0};  ///< line pressure when its valve opened
  std::array<double, 2> exit_speed_m_s{0.0, 0.0};
  std::array<vision::DotPattern, 2> dots;

  double flightTimeS(std::int64_t t_ns) const { return (t_ns - epoch_ns) * 1e-9; }
  std::array<SphereState, 2> at(std::int64_t t_ns) const { return flight.at(flightTimeS(t_ns)); }
  /// A sphere is in view only once it has left its tube.
  bool visible(int sphere, std::int64_t t_ns) const {
    return launched[sphere] && t_ns >= launch_ns[sphere];
  }
};

class SimWorld : public TruthSource {
 public:
  /// Errors: a profile whose calibration cannot be built (not from a parsed profile).
  static Result<std::shared_ptr<SimWorld>> create(const RigProfile& profile,
                                                  std::shared_ptr<Clock> clock);

  const RigProfile& profile() const { return profile_; }
  Clock& clock() const { return *clock_; }

  // ---- air lines (PressureRegulatorSim) ------------------------------------
  void setLineModel(int channel, LineModel model);
  /// A new setpoint on `channel`, from the clock's now on.
  void commandPressureKPa(int channel, double kPa);
  /// The line's true pressure at `t_ns` (no read-back noise), gauge kPa.
  double linePressureKPa(int channel, std::int64_t t_ns) const;

  /// Where launches take their line pressure from when the rig's regulator is
  /// not simulated (a real or Modbus regulator on an otherwise simulated rig):
  /// `source(channel)` is the pressure the regulator measures now, gauge kPa.
  /// launch() calls it on the firing thread, outside the world's lock, once
  /// per launcher that fires. Null (the default): the world's own lines.
  void setPressureSource(std::function<Result<double>(int channel)> source);

  /// The devices whose noise the world draws, each from its own stream.
  enum class Noise { Regulator, Valves };
  /// A draw from `device`'s random stream, seeded from the profile's seed:
  /// normal, std dev `sigma`. Each device has its own stream, apart from the
  /// launches': how often the sequencer reads the regulator follows the
  /// host's timing, and must not change what the next shot draws.
  double gaussian(Noise device, double sigma);

  // ---- valves (ValveBankSim) -----------------------------------------------
  /// Valves opened as `events` say: each launcher whose valve is among them
  /// launches its sphere one exit delay later, at the speed the calibration
  /// gives for its line pressure at the opening. Replaces the previous launch.
  /// Errors: the resulting flight is impossible (e.g. tubes that overlap).
  Status launch(const std::vector<ValveEvent>& events);

  // ---- camera (CameraSim) --------------------------------------------------
  /// The latest launch, or null before the first.
  std::shared_ptr<const SimLaunch> currentLaunch() const;
  /// A new burst is armed: until the next launch, the scene is known only up
  /// to now (no one knows when the valves will fire).
  void beginBurst();
  /// Up to when (CLOCK_MONOTONIC ns) the scene is certain: after a launch in
  /// this burst, forever (the sequencer fires once per burst); before, now.
  /// Lets a camera render a burst ahead of real time.
  std::int64_t knownUntilNs() const;
  /// `callback` runs (on the launching thread) after every launch().
  void onLaunch(std::function<void()> callback);

  // ---- truth ---------------------------------------------------------------
  std::optional<TruthRecord> truthFor(const vision::Burst& burst) const override;

 private:
  SimWorld(const RigProfile& profile, std::shared_ptr<Clock> clock, LaunchCalibration curve);

  std::function<double(double)> restitutionLaw() const;

  const RigProfile profile_;
  const std::shared_ptr<Clock> clock_;
  const LaunchCalibration curve_;
  mutable std::mutex mutex_;
  std::mt19937_64 rng_;  // launches: orientations, dots, speed and aim scatter, spins
  std::mt19937_64 regulator_rng_, valves_rng_;
  std::map<int, PressureLine> lines_;
  std::shared_ptr<const SimLaunch> launch_;
  bool launched_in_burst_ = false;
  std::vector<std::function<void()>> launch_callbacks_;
  std::function<Result<double>(int)> pressure_source_;
};

}  // namespace collide::hw
