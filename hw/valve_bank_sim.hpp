#pragma once
// ValveBankSim ("sim"): valves that open on the rig's clock (with a little
// timing jitter) and tell the simulated world, which launches the spheres.
// It keeps a log of every opening. Fault knob: a driver that refuses to fire.
#include <memory>
#include <vector>

#include "hw/clock.hpp"
#include "hw/settings.hpp"
#include "hw/sim_world.hpp"
#include "hw/valve_bank.hpp"

namespace collide::hw {

struct ValveSimSettings {
  enum class Fault { None, Error };
  int count = 2;
  double jitter_us = 0.0;  ///< std dev of the opening instant around the commanded one
  Fault fault = Fault::None;

  /// From the [valves] table (count, jitter_us, fault); refuses unknown keys.
  static Result<ValveSimSettings> read(SettingsReader& r);
};

class ValveBankSim final : public ValveBank {
 public:
  ValveBankSim(std::shared_ptr<SimWorld> world, std::shared_ptr<Clock> clock,
               ValveSimSettings settings, std::string device = "sim");
  ValveInfo info() const override;

  /// Every valve opening so far, oldest first (control thread).
  const std::vector<ValveEvent>& log() const { return log_; }
  /// How many times closeAll() reached the hardware (control thread).
  int closeAllCount() const { return close_all_count_; }

 protected:
  Status onOpen() override { return Ok{}; }
  Status onConfigure(const ValveConfig&) override { return Ok{}; }
  Status onStart() override { return Ok{}; }
  Status onStop() override { return Ok{}; }
  Status onClose() override { return Ok{}; }
  Result<std::vector<ValveEvent>> onFire(const std::vector<ValvePulse>& pattern) override;
  Status onCloseAll() override;
  std::int64_t nowNs() const override { return clock_->nowNs(); }

 private:
  std::shared_ptr<SimWorld> world_;
  std::shared_ptr<Clock> clock_;
  ValveSimSettings settings_;
  std::string device_;
  std::vector<ValveEvent> log_;
  int close_all_count_ = 0;
};

}  // namespace collide::hw
