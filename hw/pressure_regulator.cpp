#include "hw/pressure_regulator.hpp"

#include <cmath>

#include "hw/format.hpp"

namespace collide::hw {

Status PressureRegulator::open() {
  return lifecycle_.open([&] { return prefixed(label(), onOpen()); });
}

Status PressureRegulator::configure(const RegulatorConfig& config) {
  return lifecycle_.configure([&]() -> Status {
    const RegulatorInfo i = info();
    if (!(config.min_kPa <= config.max_kPa) || !std::isfinite(config.min_kPa) ||
        !std::isfinite(config.max_kPa))
      return fail(label() + ": limits " + num(config.min_kPa) + ".." + num(config.max_kPa) +
                  " kPa are not a range: check regulator.min_kpa/max_kpa");
    if (config.min_kPa < i.device_min_kPa || config.max_kPa > i.device_max_kPa)
      return fail(label() + ": limits " + num(config.min_kPa) + ".." + num(config.max_kPa) +
                  " kPa exceed the device's range " + num(i.device_min_kPa) + ".." +
                  num(i.device_max_kPa) + " kPa");
    if (Status s = prefixed(label(), onConfigure(config)); !s) return s;
    config_ = config;
    setpoints_kPa_.assign(static_cast<std::size_t>(std::max(0, i.channels)), 0.0);
    return Ok{};
  });
}

Status PressureRegulator::start() {
  return lifecycle_.start([&] { return prefixed(label(), onStart()); });
}

Status PressureRegulator::stop() {
  return lifecycle_.stop([&] { return prefixed(label(), onStop()); });
}

Status PressureRegulator::close() {
  return lifecycle_.close([&] { return prefixed(label(), onStop()); },
                          [&] { return prefixed(label(), onClose()); });
}

Status PressureRegulator::checkChannel(const char* call, int channel) const {
  if (Status s = lifecycle_.require(call, {DeviceState::Running}); !s) return s;
  if (channel < 0 || channel >= static_cast<int>(setpoints_kPa_.size()))
    return fail(label() + ": " + call + ": no channel " + std::to_string(channel) +
                " (the device has " + std::to_string(setpoints_kPa_.size()) +
                "): check launcher.regulator_channel");
  return Ok{};
}

Status PressureRegulator::setPressureKPa(int channel, double kPa) {
  if (Status s = checkChannel("setPressureKPa()", channel); !s) return s;
  if (!(kPa >= config_.min_kPa && kPa <= config_.max_kPa))
    return fail(label() + ": " + num(kPa) + " kPa on channel " + std::to_string(channel) +
                " is outside the limits " + num(config_.min_kPa) + ".." + num(config_.max_kPa) +
                " kPa (regulator.min_kpa/max_kpa, safety.max_pressure_kpa)");
  if (Status s = prefixed(label(), onSetPressureKPa(channel, kPa)); !s) return s;
  setpoints_kPa_[static_cast<std::size_t>(channel)] = kPa;
  return Ok{};
}

Result<double> PressureRegulator::readPressureKPa(int channel) {
  if (Status s = checkChannel("readPressureKPa()", channel); !s) return s.error();
  Result<double> r = onReadPressureKPa(channel);
  if (!r) return prefixed(label(), Status(r.error())).error();
  return r;
}

Result<double> PressureRegulator::setpointKPa(int channel) const {
  if (Status s = checkChannel("setpointKPa()", channel); !s) return s.error();
  return setpoints_kPa_[static_cast<std::size_t>(channel)];
}

Result<bool> PressureRegulator::settled(int channel, double tolerance_kPa) {
  Result<double> p = readPressureKPa(channel);
  if (!p) return p.error();
  return std::abs(*p - setpoints_kPa_[static_cast<std::size_t>(channel)]) <= tolerance_kPa;
}

Status PressureRegulator::vent() {
  if (Status s = lifecycle_.require(
          "vent()", {DeviceState::Open, DeviceState::Configured, DeviceState::Running});
      !s)
    return s;
  Status result = Ok{};
  for (int ch = 0; ch < info().channels; ++ch) {
    // Try every channel even if one fails: venting is the safe state.
    if (Status s = prefixed(label(), onSetPressureKPa(ch, 0.0)); !s)
      result = s;
    else if (ch < static_cast<int>(setpoints_kPa_.size()))
      setpoints_kPa_[static_cast<std::size_t>(ch)] = 0.0;
  }
  return result;
}

}  // namespace collide::hw
