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
#include <string>
#include <string_view>

#include "analysis/result.hpp"

namespace collide::hw {

enum class DeviceState { Closed, Open, Configured, Running };

/// "closed", "open", "configured", "running".
const char* toString(DeviceState s);

class Lifecycle {
 public:
  /// `device` names the device in messages, e.g. `camera "sim"`.
  explicit Lifecycle(std::string device) : device_(std::move(device)) {}

  const std::string& device() const { return device_; }
  /// Current state. Any thread.
  DeviceState state() const { return state_.load(); }

  /// Ok when the device is in one of `allowed`; otherwise an Error naming the
  /// device, the call, the current state and the call to make first, e.g.
  /// `camera "sim": arm() refused: the device is configured; call start() first`.
  Status require(std::string_view call, std::initializer_list<DeviceState> allowed) const;

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
};

}  // namespace collide::hw
