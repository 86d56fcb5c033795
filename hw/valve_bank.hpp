#pragma once
// Role: the solenoid valves that fire the launchers (one GPIO line each).
// A shot fires a pattern: per valve an opening instant and a pulse width, on
// CLOCK_MONOTONIC; the bank reports when each valve actually opened and closed.
// Backends: ValveBankSim ("sim"), ValveBankGpiod ("gpiod", GPIO lines).
//
// Threads: every call from the rig's control thread, one at a time; state()
// from any thread.
// Errors: wrong lifecycle state, a bad pattern, and driver failures come back
// as Error values naming the device and what to do. After a failed fire() the
// bank has closed every valve.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "hw/lifecycle.hpp"

namespace collide::hw {

struct ValveInfo {
  std::string backend;  ///< "sim", "gpiod", ...
  std::string device;   ///< chip / device id, as in the profile
  int valves = 0;       ///< outputs, numbered 0 .. valves-1
};

struct ValveConfig {
  /// Longest pulse fire() accepts, microseconds (safety.max_valve_pulse_us).
  std::int64_t max_pulse_us = 0;
};

/// One valve's part of a firing pattern.
struct ValvePulse {
  int valve = 0;
  std::int64_t open_at_ns = 0;  ///< CLOCK_MONOTONIC instant to open
  std::int64_t pulse_us = 0;    ///< how long to keep it open, microseconds
};

/// What a valve actually did.
struct ValveEvent {
  int valve = 0;
  std::int64_t opened_ns = 0;  ///< CLOCK_MONOTONIC
  std::int64_t closed_ns = 0;  ///< CLOCK_MONOTONIC
  std::int64_t pulseUs() const { return (closed_ns - opened_ns) / 1000; }
};

class ValveBank {
 public:
  virtual ~ValveBank() = default;
  ValveBank(const ValveBank&) = delete;
  ValveBank& operator=(const ValveBank&) = delete;

  virtual ValveInfo info() const = 0;
  const std::string& label() const { return lifecycle_.device(); }
  DeviceState state() const { return lifecycle_.state(); }
  /// Where this device's health is kept (device_health.hpp): makeRig gives
  /// every device of a rig the rig's. Control thread, before use.
  void setHealth(std::shared_ptr<DeviceHealth> health) { lifecycle_.setHealth(std::move(health)); }
  /// Why the device is lost (it stopped answering), or none. Any thread.
  std::optional<DeviceLoss> loss() const { return lifecycle_.loss(); }
  /// Marks the device lost: every later call is refused at once until a
  /// re-check (recheck() in rig.hpp) clears it. Called by a backend whose
  /// device timed out or whose connection failed, or by the sequencer when
  /// a wait on the device ran out. Returns the Error those calls get.
  Error markLost(std::string what_happened, std::string what_to_check) {
    return lifecycle_.markLost(std::move(what_happened), std::move(what_to_check));
  }

  // Lifecycle (see lifecycle.hpp). configure() refuses max_pulse_us <= 0.
  Status open();
  Status configure(const ValveConfig& config);
  Status start();
  Status stop();
  Status close();
  const ValveConfig& config() const { return config_; }

  /// Fires `pattern` and blocks until every valve in it has closed again
  /// (about the latest open_at_ns plus its pulse). Running. Refuses an empty
  /// pattern, an unknown valve, a valve named twice, a pulse <= 0 or longer
  /// than config().max_pulse_us, an opening more than 10 s away. An opening
  /// already past happens at once. Returns one event per pulse, in pattern order.
  Result<std::vector<ValveEvent>> fire(const std::vector<ValvePulse>& pattern);
  /// Closes every valve now (the safe state). Allowed whenever open, even
  /// when the bank is lost (what it can still drive, it drives inactive).
  Status closeAll();

 protected:
  explicit ValveBank(std::string label) : lifecycle_(std::move(label)) {}

  virtual Status onOpen() = 0;
  virtual Status onConfigure(const ValveConfig& config) = 0;
  virtual Status onStart() = 0;
  virtual Status onStop() = 0;
  virtual Status onClose() = 0;
  /// Pattern already validated; return events in pattern order.
  virtual Result<std::vector<ValveEvent>> onFire(const std::vector<ValvePulse>& pattern) = 0;
  virtual Status onCloseAll() = 0;
  /// CLOCK_MONOTONIC now for validation; backends with an injected clock override.
  virtual std::int64_t nowNs() const;

 private:
  Lifecycle lifecycle_;
  ValveConfig config_;
};

}  // namespace collide::hw
