#pragma once
// The one state machine every device role shares (libcamera's Camera,
// ros2_control's lifecycle nodes):
//
//   closed --open()--> open --configure()--> configured --start()--> running
//   running --stop()--> configured;  configured --configure()--> configured
//   open | configured | running --close()--> closed   (close() stops first)
//
// Each role class (Camera, ValveBank, PressureRegulator) owns one Lifecycle and
// routes its public calls through it, so every backend refuses a call made in
// the wrong state with the same clear message, and no backend re-implements
// the checks.
#include <atomic>
#include <functional>
#include <initializer_list>
#include <memory>
#include <string>
#include <string_view>

#include "analysis/result.hpp"
#include "hw/device_health.hpp"

namespace collide::hw {

enum class DeviceState { Closed, Open, Configured, Running };

/// "closed", "open", "configured", "running".
const char* toString(DeviceState s);

class Lifecycle {
 public:
  /// `device` names the device in messages, e.g. `camera "sim"`.
  explicit Lifecycle(std::string device)
      : device_(std::move(device)), health_(std::make_shared<DeviceHealth>()) {}

  const std::string& device() const { return device_; }
  /// Current state. Any thread.
  DeviceState state() const { return state_.load(); }

  /// Ok when the device is in one of `allowed` and not lost; otherwise an
  /// Error naming the device, the call, the current state and the call to
  /// make first, e.g. `camera "sim": arm() refused: the device is configured;
  /// call start() first`, or for a lost device lostMessage() (refused at once,
  /// nothing is asked of the device). Of the transitions, configure() and
  /// start() refuse a lost device the same way (each would ask it and wait);
  /// stop() and close() never refuse it, and open() is how a lost device is
  /// re-checked.
  Status require(std::string_view call, std::initializer_list<DeviceState> allowed) const;
  /// The state check of require() alone, for the few calls that still make
  /// sense on a lost device because they ask it nothing that could wait:
  /// handing back the frames that arrived before it was lost, driving valve
  /// lines inactive.
  Status requireState(std::string_view call, std::initializer_list<DeviceState> allowed) const;

  /// Where this device's health is kept (a rig shares one among its devices
  /// and, in a campaign, across the rigs built for it). Control thread, before
  /// the device is used. Default: its own.
  void setHealth(std::shared_ptr<DeviceHealth> health) { health_ = std::move(health); }
  const std::shared_ptr<DeviceHealth>& health() const { return health_; }
  /// Marks the device lost (it stopped answering) and returns the Error every
  /// later call gets: lostMessage(). A successful open() (the device closed
  /// and opened again) clears it.
  Error markLost(std::string what_happened, std::string what_to_check) const;
  /// Why the device is lost, or none. Any thread.
  std::optional<DeviceLoss> loss() const { return health_->loss(device_); }

  // The transitions. Each checks the state, runs the backend's hook and moves
  // to the new state only if the hook succeeded (a failed start() leaves the
  // device configured). Call from the device's control thread.
  Status open(const std::function<Status()>& hook);
  Status configure(const std::function<Status()>& hook);
  Status start(const std::function<Status()>& hook);
  Status stop(const std::function<Status()>& hook);
  /// From running, runs `stop_hook` first. The device ends closed even when a
  /// hook fails (the error is still returned): a device that failed to close
  /// cleanly must be opened again before use.
  Status close(const std::function<Status()>& stop_hook, const std::function<Status()>& close_hook);

 private:
  Status transition(std::string_view call, std::initializer_list<DeviceState> from, DeviceState to,
                    const std::function<Status()>& hook);

  std::string device_;
  std::atomic<DeviceState> state_{DeviceState::Closed};
  std::shared_ptr<DeviceHealth> health_;
};

}  // namespace collide::hw
