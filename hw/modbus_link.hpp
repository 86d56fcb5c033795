#pragma once
// A thin wrapper over one libmodbus client context (libcamera keeps its OS
// wrappers apart from the class playing the role; so do we): connect, read
// and write registers, and turn every libmodbus failure into a message that
// names the register, the device and what to check. A failed exchange that
// was not a Modbus exception (a timeout, a reset connection, a garbled
// answer) closes the link; the next attempt reconnects, so a dropped link
// heals by itself and a late answer to an old request can never be taken for
// the answer to a new one.
//
// Threads: one thread at a time (the rig's control thread).
#include <cstdint>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "hw/modbus_map.hpp"

struct _modbus;  // libmodbus' modbus_t, kept out of this header

namespace collide::hw {

/// Which registers an exchange is about, for messages.
struct ModbusRegisterRef {
  ModbusTable table = ModbusTable::Holding;
  int address = 0;
  int count = 1;
  std::string what;  ///< e.g. "setpoint, channel 0"
  std::string key;   ///< the profile field that says where they are, e.g. "regulator.setpoint"
};

struct ModbusLinkStats {
  std::int64_t requests = 0;    ///< exchanges asked for
  std::int64_t failures = 0;    ///< attempts that failed (timeouts, resets, exceptions...)
  std::int64_t reconnects = 0;  ///< times the link was opened again after a failure
};

class ModbusLink {
 public:
  explicit ModbusLink(ModbusLinkSettings settings);
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  /// Opens the link (TCP connect, or opens and sets up the serial port).
  /// Errors: the device unreachable or the port missing, with what to check.
  Status connect();
  void close();
  bool connected() const { return connected_; }

  /// Reads `ref.count` registers. Errors: see the class comment; a Modbus
  /// exception is reported at once (the device answered: trying again would
  /// get the same answer); other failures after `retries` reconnections.
  Result<std::vector<std::uint16_t>> read(const ModbusRegisterRef& ref);
  /// Writes `words` to holding registers from `ref.address` (function 6 for
  /// one register, 16 for more). Errors as read().
  Status write(const ModbusRegisterRef& ref, const std::vector<std::uint16_t>& words);

  const ModbusLinkSettings& settings() const { return settings_; }
  const ModbusLinkStats& stats() const { return stats_; }
  /// Whether the last failed connect(), read() or write() was silence (no
  /// answer in time, no connection, a reset link), not an answer the device
  /// gave (a Modbus exception) or a garbled one: the device is then lost.
  bool lastFailureWasSilence() const { return last_silent_; }

 private:
  template <class Op>
  Status exchange(const char* verb, const ModbusRegisterRef& ref, Op op);
  std::string failure(int err, const char* verb, const ModbusRegisterRef& ref) const;
  Status open();

  ModbusLinkSettings settings_;
  _modbus* ctx_ = nullptr;
  bool connected_ = false;
  ModbusLinkStats stats_;
  bool last_silent_ = false;
};

}  // namespace collide::hw
