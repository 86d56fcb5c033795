#pragma once
// PressureRegulatorModbus ("modbus"): an electronic pressure regulator spoken
// to over Modbus TCP or RTU, its register map taken from the rig profile
// (modbus_map.hpp). What it guarantees on top of the role's checks:
// - the profile's safety.max_pressure_kpa is enforced here too, before any
//   register is written, including the rounding of the value to the
//   register's counts;
// - every setpoint written is read back from the device and must match, or
//   the call fails (a device in local mode or write-protected is caught);
// - the measured pressure comes from the read-back registers, so settled()
//   is decided by what the device measures, not by what was asked;
// - timeouts, Modbus exceptions, garbled answers name the device, the
//   register and what to check; a dropped link is reopened and the request
//   sent again (regulator.retries);
// - a device still silent after those retries (no answer in time, no
//   connection) is marked lost (device_health.hpp): later calls are refused
//   at once instead of waiting out the timeouts again.
#include <memory>

#include "hw/modbus_link.hpp"
#include "hw/modbus_map.hpp"
#include "hw/pressure_regulator.hpp"

namespace collide::hw {

class PressureRegulatorModbus final : public PressureRegulator {
 public:
  /// `max_pressure_kPa`: the profile's safety.max_pressure_kpa; no setpoint
  /// above it is ever written. `device` names the device in messages.
  PressureRegulatorModbus(ModbusRegulatorMap map, double max_pressure_kPa, std::string device);
  ~PressureRegulatorModbus() override;

  RegulatorInfo info() const override;
  const ModbusRegulatorMap& map() const { return map_; }
  /// Requests, failed attempts and reconnections so far (control thread).
  ModbusLinkStats linkStats() const { return link_.stats(); }

 protected:
  /// Connects and reads every channel's setpoint and read-back once, so a
  /// wrong address, unit id or register map fails here, not mid-shot.
  Status onOpen() override;
  /// Refuses limits above safety.max_pressure_kpa.
  Status onConfigure(const RegulatorConfig& config) override;
  Status onStart() override { return Ok{}; }
  Status onStop() override { return Ok{}; }
  Status onClose() override;
  Status onSetPressureKPa(int channel, double kPa) override;
  Result<double> onReadPressureKPa(int channel) override;

 private:
  ModbusRegisterRef setpointRef(int channel) const;
  ModbusRegisterRef readbackRef(int channel) const;
  /// `s` unchanged, or, when it failed because the device was silent, the
  /// regulator marked lost and the lost message.
  Status lostIfSilent(Status s);

  ModbusRegulatorMap map_;
  double max_pressure_kPa_;
  std::string device_;
  ModbusLink link_;
};

}  // namespace collide::hw
