#pragma once
// Device health: which devices of a rig have stopped answering ("lost").
//
// A device whose call timed out or whose connection failed is marked lost,
// with what happened and what to check. From then on every call to it is
// refused at once (Lifecycle::require), and the sequencer refuses a new shot
// before it opens a valve or waits on anything: a silent device does not make
// every later shot wait out its timeouts again. Only an explicit reconnect
// clears it: closing and opening the device again, or recheck() in rig.hpp
// (reopen and probe it), or a new rig with a new DeviceHealth (a new program
// run). The sequencer never reopens a lost device by itself.
//
// One DeviceHealth may be shared by several rigs built in turn for the same
// physical devices (a campaign builds one rig per shot): a device lost in one
// shot stays lost for the next. Devices are known by their label, e.g.
// `regulator "lab-regulator"`.
//
// Threads: any thread (a GUI may show it while the rig's thread fires).
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"

namespace collide::hw {

struct DeviceLoss {
  std::string device;         ///< its label, e.g. `regulator "sim"`
  std::string what_happened;  ///< e.g. "no answer to reading ... within 200 ms (tried 3 times)"
  std::string what_to_check;  ///< e.g. "the regulator's power and cable, regulator.device"
};

/// The one sentence every refusal of a lost device uses: the device, what
/// happened, that retrying will not help until it answers again, what to
/// check and how to clear it.
std::string lostMessage(const DeviceLoss& loss);

class DeviceHealth {
 public:
  /// Marks `loss.device` lost; a device already lost keeps its first reason.
  void markLost(DeviceLoss loss);
  /// The device answers again (a re-check succeeded).
  void clear(const std::string& device);
  /// Why `device` is lost, or none.
  std::optional<DeviceLoss> loss(const std::string& device) const;
  /// Every lost device, in the order they were lost.
  std::vector<DeviceLoss> lost() const;
  /// Ok when no device is lost; otherwise an Error with lostMessage() of the
  /// first one lost (and how many others are).
  Status ready() const;

 private:
  mutable std::mutex mutex_;
  std::vector<DeviceLoss> lost_;
};

}  // namespace collide::hw
