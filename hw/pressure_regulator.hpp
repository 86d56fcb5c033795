#pragma once
// Role: the electronic pressure regulator that sets each launcher's supply
// pressure (Micro-Manager style: named by role, units in the names). One
// device, one channel per launcher line. Backends: PressureRegulatorSim
// ("sim"); later PressureRegulatorModbus.
//
// Threads: every call from the rig's control thread (the one running the
// sequencer), one at a time; state() from any thread.
// Errors: wrong lifecycle state, out-of-range values and device failures come
// back as Error values whose message names the device and what to do.
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "hw/lifecycle.hpp"

namespace collide::hw {

struct RegulatorInfo {
  std::string backend;          ///< "sim", "modbus", ...
  std::string device;           ///< device id / address, as in the profile
  int channels = 0;             ///< independent outputs (one per launcher line)
  double device_min_kPa = 0.0;  ///< what the hardware can regulate, gauge kPa
  double device_max_kPa = 0.0;
};

/// Working limits (gauge kPa), inside the device's range; setPressureKPa()
/// refuses anything outside them.
struct RegulatorConfig {
  double min_kPa = 0.0;
  double max_kPa = 0.0;
};

class PressureRegulator {
 public:
  virtual ~PressureRegulator() = default;
  PressureRegulator(const PressureRegulator&) = delete;
  PressureRegulator& operator=(const PressureRegulator&) = delete;

  /// Identity and range; backend/device always, the rest once open.
  virtual RegulatorInfo info() const = 0;
  /// e.g. `regulator "sim"`: how messages name this device.
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

  // Lifecycle (see lifecycle.hpp). configure() refuses limits outside the
  // device's range or min > max.
  Status open();
  Status configure(const RegulatorConfig& config);
  Status start();
  Status stop();
  Status close();
  const RegulatorConfig& config() const { return config_; }

  /// Commands `kPa` (gauge) on `channel` (0-based). Running. Refuses a
  /// channel that does not exist or a pressure outside config() limits.
  Status setPressureKPa(int channel, double kPa);
  /// The pressure the device measures now on `channel`, gauge kPa. Running.
  Result<double> readPressureKPa(int channel);
  /// The last pressure commanded on `channel` (0 before any), kPa. Running.
  Result<double> setpointKPa(int channel) const;
  /// One reading within `tolerance_kPa` of the setpoint. Running.
  Result<bool> settled(int channel, double tolerance_kPa);
  /// Every channel to 0 kPa: the safe state after a failure. Allowed whenever
  /// the device is open (open, configured or running); ignores the limits.
  Status vent();

 protected:
  explicit PressureRegulator(std::string label) : lifecycle_(std::move(label)) {}

  // Backend hooks, called only in the right state with validated arguments.
  virtual Status onOpen() = 0;
  virtual Status onConfigure(const RegulatorConfig& config) = 0;
  virtual Status onStart() = 0;
  virtual Status onStop() = 0;
  virtual Status onClose() = 0;
  virtual Status onSetPressureKPa(int channel, double kPa) = 0;
  virtual Result<double> onReadPressureKPa(int channel) = 0;

 private:
  Status checkChannel(const char* call, int channel) const;

  Lifecycle lifecycle_;
  RegulatorConfig config_;
  std::vector<double> setpoints_kPa_;
};

}  // namespace collide::hw
