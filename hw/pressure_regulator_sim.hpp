#pragma once
// PressureRegulatorSim ("sim"): a regulator whose outputs are the simulated
// world's air lines, each answering a new setpoint with a first-order response
// (time constant), read back with Gaussian noise. Fault knobs: a leak that
// never lets the pressure settle, a link that fails after the first setpoint
// (a failure, not silence: it refuses at once), and a device that goes silent
// after a number of setpoints (fault = "silent", silent_after_setpoints =
// N, counted across every regulator of that label in the process, see
// sim_silence.hpp): each request then waits silent_timeout_ms, as a real link
// waits out its timeout, fails, and marks the regulator lost.
#include <memory>

#include "hw/pressure_line.hpp"
#include "hw/pressure_regulator.hpp"
#include "hw/settings.hpp"
#include "hw/sim_silence.hpp"
#include "hw/sim_world.hpp"

namespace collide::hw {

struct RegulatorSimSettings {
  enum class Fault { None, NeverSettles, Error, Silent };
  /// A real regulator holds its setpoint to a fraction of a percent of its range.
  static constexpr double kDefaultHoldBandKPa = 1.0;
  int channels = 2;
  double time_constant_s = 0.01;
  double noise_kPa = 0.0;  ///< read-back noise, std dev
  /// Within this of the goal the regulator holds the line at it (LineModel).
  double hold_band_kPa = kDefaultHoldBandKPa;
  Fault fault = Fault::None;
  /// Fault::Silent: setpoints answered (in this process) before it goes silent.
  int silent_after_setpoints = 0;
  /// Fault::Silent: how long an unanswered request waits before it fails, ms.
  double silent_timeout_ms = 100.0;
  /// What the simulated hardware can regulate.
  double device_min_kPa = 0.0;
  double device_max_kPa = 1000.0;

  /// From the [regulator] table (channels, time_constant_ms, hold_band_kpa,
  /// noise_kpa, fault, silent_after_setpoints, silent_timeout_ms); refuses
  /// unknown keys.
  static Result<RegulatorSimSettings> read(SettingsReader& r);
  /// How each line answers a setpoint (the leak of NeverSettles included).
  LineModel lineModel() const;
};

class PressureRegulatorSim final : public PressureRegulator {
 public:
  PressureRegulatorSim(std::shared_ptr<SimWorld> world, RegulatorSimSettings settings,
                       std::string device = "sim");
  RegulatorInfo info() const override;

 protected:
  Status onOpen() override;
  Status onConfigure(const RegulatorConfig& config) override;
  Status onStart() override { return Ok{}; }
  Status onStop() override { return Ok{}; }
  Status onClose() override { return Ok{}; }
  Status onSetPressureKPa(int channel, double kPa) override;
  Result<double> onReadPressureKPa(int channel) override;

 private:
  Status linkUp() const;
  // Fault::Silent: one request to the device; an Error (and the regulator
  // lost) once it has gone silent, after waiting its timeout.
  Status heard(bool setpoint);

  std::shared_ptr<SimWorld> world_;
  RegulatorSimSettings settings_;
  std::string device_;
  bool link_failed_ = false;
  std::shared_ptr<SimSilence> silence_;  ///< Fault::Silent only
};

}  // namespace collide::hw
