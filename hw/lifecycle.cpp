#include "hw/lifecycle.hpp"

#include <algorithm>

namespace collide::hw {

const char* toString(DeviceState s) {
  switch (s) {
    case DeviceState::Closed: return "closed";
    case DeviceState::Open: return "open";
    case DeviceState::Configured: return "configured";
    case DeviceState::Running: return "running";
  }
  return "closed";
}

namespace {

// The call that moves a device from `from` one step towards `to`.
const char* nextCall(DeviceState from, DeviceState to) {
  if (from < to) {
    switch (from) {
      case DeviceState::Closed: return "open()";
      case DeviceState::Open: return "configure()";
      default: return "start()";
    }
  }
  return to == DeviceState::Closed      ? "close()"
         : from == DeviceState::Running ? "stop()"
                                        : "close()";
}

}  // namespace

Status Lifecycle::require(std::string_view call, std::initializer_list<DeviceState> allowed) const {
  if (std::optional<DeviceLoss> lost = loss()) return fail(lostMessage(*lost));
  return requireState(call, allowed);
}

Error Lifecycle::markLost(std::string what_happened, std::string what_to_check) const {
  DeviceLoss lost{device_, std::move(what_happened), std::move(what_to_check)};
  health_->markLost(lost);
  return fail(lostMessage(health_->loss(device_).value_or(lost)));
}

Status Lifecycle::requireState(std::string_view call,
                               std::initializer_list<DeviceState> allowed) const {
  const DeviceState now = state();
  if (std::find(allowed.begin(), allowed.end(), now) != allowed.end()) return Ok{};
  // Point at the nearest allowed state: the lowest one above us, or else the
  // highest one below us.
  DeviceState target = *std::max_element(allowed.begin(), allowed.end());
  for (DeviceState s : allowed)
    if (s > now && s < target) target = s;
  if (target < now) target = *std::max_element(allowed.begin(), allowed.end());
  return fail(device_ + ": " + std::string(call) + " refused: the device is " + toString(now) +
              "; call " + nextCall(now, target) + " first");
}

Status Lifecycle::transition(std::string_view call, std::initializer_list<DeviceState> from,
                             DeviceState to, const std::function<Status()>& hook) {
  if (Status s = requireState(call, from); !s) return s;
  if (Status s = hook(); !s) return s;
  state_ = to;
  return Ok{};
}

Status Lifecycle::open(const std::function<Status()>& hook) {
  Status s = transition("open()", {DeviceState::Closed}, DeviceState::Open, hook);
  if (s) health_->clear(device_);  // reopened: it answers again
  return s;
}

Status Lifecycle::configure(const std::function<Status()>& hook) {
  if (std::optional<DeviceLoss> lost = loss()) return fail(lostMessage(*lost));
  return transition("configure()", {DeviceState::Open, DeviceState::Configured},
                    DeviceState::Configured, hook);
}

Status Lifecycle::start(const std::function<Status()>& hook) {
  if (std::optional<DeviceLoss> lost = loss()) return fail(lostMessage(*lost));
  return transition("start()", {DeviceState::Configured}, DeviceState::Running, hook);
}

Status Lifecycle::stop(const std::function<Status()>& hook) {
  return transition("stop()", {DeviceState::Running}, DeviceState::Configured, hook);
}

Status Lifecycle::close(const std::function<Status()>& stop_hook,
                        const std::function<Status()>& close_hook) {
  if (Status s = requireState("close()",
                              {DeviceState::Open, DeviceState::Configured, DeviceState::Running});
      !s)
    return s;
  Status stopped = state() == DeviceState::Running ? stop_hook() : Status(Ok{});
  Status closed = close_hook();
  state_ = DeviceState::Closed;
  if (!stopped) return stopped;
  return closed;
}

}  // namespace collide::hw
