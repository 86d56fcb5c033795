#pragma once
// PressureRegulatorSim ("sim"): a regulator whose outputs are the simulated
// world's air lines, each answering a new setpoint with a first-order response
// (time constant), read back with Gaussian noise. Fault knobs: a leak that
// never lets the pressure settle, and a link that fails after the first setpoint.
#include <memory>

#include "hw/pressure_line.hpp"
#include "hw/pressure_regulator.hpp"
#include "hw/settings.hpp"
#include "hw/sim_world.hpp"

namespace collide::hw {

struct RegulatorSimSettings {
  enum class Fault { None, NeverSettles, Error };
  int channels = 2;
  double time_constant_s = 0.01;
  double noise_kPa = 0.0;  ///< read-back noise, std dev
  Fault fault = Fault::None;
  /// What the simulated hardware can regulate.
  double device_min_kPa = 0.0;
  double device_max_kPa = 1000.0;

  /// From the [regulator] table (channels, time_constant_ms, noise_kpa, fault);
  /// refuses unknown keys.
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

  std::shared_ptr<SimWorld> world_;
  RegulatorSimSettings settings_;
  std::string device_;
  bool link_failed_ = false;
};

}  // namespace collide::hw
