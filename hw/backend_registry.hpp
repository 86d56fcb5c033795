#pragma once
// Backends register themselves here, by name, from their own .cpp:
//
//   const bool registered =
//       BackendRegistry<Camera>::instance().add("aravis", &makeCameraAravis);
//
// makeRig() (rig.hpp) looks the profile's `backend = "..."` up in the registry
// of the role, so adding a backend never edits the factory (ros2_control's
// plugin lookup, libcamera's pipeline-handler registration).
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "hw/camera.hpp"
#include "hw/clock.hpp"
#include "hw/pressure_regulator.hpp"
#include "hw/rig_profile.hpp"
#include "hw/valve_bank.hpp"

namespace collide::hw {

struct RigHooks;
class SimWorld;

/// What a backend factory gets to build its device. Valid only during the call.
class BackendContext {
 public:
  BackendContext(const RigProfile& profile, const DeviceProfile& device, const RigHooks& hooks,
                 std::shared_ptr<Clock> clock, std::shared_ptr<SimWorld>& world)
      : profile(profile), device(device), hooks(hooks), clock(std::move(clock)), world_(world) {}

  const RigProfile& profile;
  const DeviceProfile& device;  ///< this role's section of the profile
  const RigHooks& hooks;
  std::shared_ptr<Clock> clock;

  /// The one simulated world all simulated devices of the rig share (pressures
  /// and valve firings feed what the simulated camera sees); made on first use.
  Result<std::shared_ptr<SimWorld>> simWorld();

 private:
  std::shared_ptr<SimWorld>& world_;
};

template <class RoleT>
class BackendRegistry {
 public:
  using Factory = std::function<Result<std::unique_ptr<RoleT>>(BackendContext&)>;

  /// The registry of this role (one per process). Any thread.
  static BackendRegistry& instance() {
    static BackendRegistry registry;
    return registry;
  }

  /// Registers `factory` under `name` (replacing an earlier one). Returns true
  /// so it can initialise a static. Any thread.
  bool add(const std::string& name, Factory factory) {
    std::lock_guard lock(mutex_);
    factories_[name] = std::move(factory);
    return true;
  }

  /// The factory registered under `name`, or an empty function.
  Factory find(const std::string& name) const {
    std::lock_guard lock(mutex_);
    const auto it = factories_.find(name);
    return it == factories_.end() ? Factory{} : it->second;
  }

  /// Registered names, sorted.
  std::vector<std::string> names() const {
    std::lock_guard lock(mutex_);
    std::vector<std::string> out;
    for (const auto& [name, factory] : factories_) out.push_back(name);
    return out;
  }

 private:
  BackendRegistry() = default;
  mutable std::mutex mutex_;
  std::map<std::string, Factory> factories_;
};

/// Ok if `device.backend` is registered for the role; otherwise an Error
/// "<file>:<line>: <section>.backend = "x": unknown backend (known: "sim", ...)".
template <class RoleT>
Status checkBackendKnown(const DeviceProfile& device) {
  if (BackendRegistry<RoleT>::instance().find(device.backend)) return Ok{};
  std::string known;
  for (const auto& n : BackendRegistry<RoleT>::instance().names())
    known += (known.empty() ? "\"" : ", \"") + n + "\"";
  // The value in use, which a profile edited by code may have changed since it was read.
  return fail(SettingsReader(device.table).where("backend") + " = \"" + device.backend +
              "\": unknown backend (known: " + (known.empty() ? "none" : known) + ")");
}

}  // namespace collide::hw
