#pragma once
// What a Modbus pressure regulator looks like on the wire, as its rig profile
// describes it: how to reach it (TCP or RTU, address, serial settings, unit
// id, timeout) and its register map (where each channel's setpoint and
// measured pressure live, in which table, as which type, word order, scale,
// offset and unit). Pure data and arithmetic, no libmodbus: the client
// backend (PressureRegulatorModbus) and the simulated server
// (ModbusRegulatorServer) both read the same map from the same profile keys,
// so they cannot disagree about the encoding.
//
// Conventions (written down once, here):
// - Addresses are Modbus protocol addresses, 0-based: holding register
//   "40001" of the old 1-based notation is address 0 in table "holding".
// - A 32-bit value takes two consecutive registers. word_order names its
//   bytes A (most significant) to D as they appear on the wire: "ABCD" is
//   big-endian (high word first, the Modbus default), "CDAB" low word first,
//   "BADC" and "DCBA" the same with the bytes of each register swapped. A
//   16-bit value is one register, so only the byte swap ("BADC", "DCBA")
//   matters for it.
// - A register's raw value r means  value = r * scale + offset  in `unit`,
//   and that value is converted to kPa (gauge) with the unit's factor.
#include <cstdint>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "hw/rig_profile.hpp"
#include "hw/settings.hpp"

namespace collide::hw {

enum class ModbusTable { Holding, Input };
enum class ModbusValueType { U16, I16, U32, I32, Float32 };
enum class ModbusTransport { Tcp, Rtu };

/// "holding register", "input register".
const char* toString(ModbusTable t);
/// "u16", "i16", "u32", "i32", "float32".
const char* toString(ModbusValueType t);

/// Pressure units a device may use, with their size in kPa.
struct PressureUnit {
  std::string name;  ///< "kPa", "bar", "mbar", "Pa", "MPa", "psi"
  double kPa = 1.0;  ///< one of this unit in kPa
};

/// One pressure per channel in a run of registers.
struct ModbusPressureRegisters {
  ModbusTable table = ModbusTable::Holding;
  std::vector<int> addresses;  ///< first register of each channel's value
  ModbusValueType type = ModbusValueType::U16;
  std::string word_order = "ABCD";
  double scale = 1.0;  ///< value in `unit` per count (ignored for float32: 1 unless given)
  double offset = 0.0;
  PressureUnit unit;

  /// Registers one value takes: 1 or 2.
  int width() const;
  /// The raw registers for `kPa`, rounded to the nearest count, or an Error
  /// if it does not fit the type (the message says which limit).
  Result<std::vector<std::uint16_t>> encode(double kPa) const;
  /// As encode(), but never above `kPa` when rounding (for upper limits).
  Result<std::vector<std::uint16_t>> encodeAtMost(double kPa) const;
  /// kPa from `width()` raw registers.
  double decode(const std::uint16_t* words) const;
  /// The raw value as a person reads it in the device's manual: "5000",
  /// "-12", "2.5" (float32).
  std::string rawText(const std::uint16_t* words) const;
  /// The smallest step, kPa (0 for float32).
  double resolutionKPa() const;
};

/// True if `kPa` (decoded from registers) is above `limit_kPa` by more than
/// floating-point noise (1e-9 relative).
bool exceedsKPa(double kPa, double limit_kPa);

/// How to reach the device.
struct ModbusLinkSettings {
  ModbusTransport transport = ModbusTransport::Tcp;
  std::string host = "127.0.0.1";  ///< TCP
  int port = 502;                  ///< TCP
  std::string serial_port;         ///< RTU, e.g. "/dev/ttyUSB0"
  int baud = 19200;                ///< RTU
  char parity = 'N';               ///< RTU: 'N', 'E', 'O'
  int data_bits = 8;               ///< RTU
  int stop_bits = 1;               ///< RTU
  int unit_id = 1;                 ///< the device's unit id (RTU: slave address)
  int timeout_ms = 200;            ///< response timeout per request
  int retries = 1;                 ///< after a failed exchange: reconnect and try again this often

  /// "127.0.0.1:1502" or "/dev/ttyUSB0".
  std::string endpoint() const;
  /// "Modbus TCP 127.0.0.1:1502, unit 1" / "Modbus RTU /dev/ttyUSB0 19200 8N1, unit 1".
  std::string describe() const;
};

/// A regulator's whole Modbus description: the [regulator] table of a rig
/// profile whose backend is "modbus".
struct ModbusRegulatorMap {
  ModbusLinkSettings link;
  int channels = 2;
  double device_min_kPa = 0.0;  ///< what the device can regulate
  double device_max_kPa = 1000.0;
  ModbusPressureRegisters setpoint;  ///< always holding registers (written)
  ModbusPressureRegisters readback;  ///< the measured pressure: holding or input

  /// Reads the backend keys of [regulator] (transport, unit_id, timeout_ms,
  /// retries, baud, parity, data_bits, stop_bits, channels, range_kpa and the
  /// [regulator.setpoint] / [regulator.readback] tables) from `r` and refuses
  /// unknown keys; `device` is the table's "device" key: "host[:port]" (TCP,
  /// port 502 by default) or a serial port path (RTU). Errors name file, line
  /// and field: a bad value, an address list that does not give every channel
  /// one, registers that overlap, a range the registers cannot hold.
  static Result<ModbusRegulatorMap> read(SettingsReader& r, const std::string& device);

  /// The map of a profile's [regulator]. Errors: its backend is not
  /// "modbus", or read() refuses it.
  static Result<ModbusRegulatorMap> fromProfile(const RigProfile& profile);

  /// A generic 0-10 bar regulator with scaled 16-bit registers, exactly as
  /// config/regulator-generic-10bar.toml describes it (a test keeps the two
  /// equal): what `collide sim-regulator` serves without --map.
  static ModbusRegulatorMap generic10Bar();
};

bool operator==(const PressureUnit& a, const PressureUnit& b);
bool operator==(const ModbusPressureRegisters& a, const ModbusPressureRegisters& b);
bool operator==(const ModbusLinkSettings& a, const ModbusLinkSettings& b);
bool operator==(const ModbusRegulatorMap& a, const ModbusRegulatorMap& b);

}  // namespace collide::hw
