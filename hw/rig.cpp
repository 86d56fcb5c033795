#include "hw/rig.hpp"

#include "hw/backend_registry.hpp"
#include "hw/sim_world.hpp"
#include "hw/try.hpp"

namespace collide::hw {

Result<std::shared_ptr<SimWorld>> BackendContext::simWorld() {
  if (!world_) {
    COLLIDE_ASSIGN_OR_RETURN(world_, SimWorld::create(profile, clock));
  }
  return world_;
}

namespace {

template <class RoleT>
Result<std::unique_ptr<RoleT>> build(const RigProfile& profile, const DeviceProfile& device,
                                     const RigHooks& hooks, const std::shared_ptr<Clock>& clock,
                                     std::shared_ptr<SimWorld>& world) {
  COLLIDE_RETURN_IF_ERROR(checkBackendKnown<RoleT>(device));
  BackendContext ctx(profile, device, hooks, clock, world);
  return BackendRegistry<RoleT>::instance().find(device.backend)(ctx);
}

// One step of bring-up for any role: they share the lifecycle.
template <class Device, class Config>
Status bringUpOne(Device& d, const Config& config) {
  if (d.state() == DeviceState::Closed) COLLIDE_RETURN_IF_ERROR(d.open());
  if (d.state() == DeviceState::Open) COLLIDE_RETURN_IF_ERROR(d.configure(config));
  if (d.state() == DeviceState::Configured) COLLIDE_RETURN_IF_ERROR(d.start());
  return Ok{};
}

template <class Device>
Status closeOne(Device& d) {
  return d.state() == DeviceState::Closed ? Status(Ok{}) : d.close();
}

}  // namespace

Result<Rig> makeRig(const RigProfile& profile, const RigHooks& hooks) {
  Rig rig;
  rig.profile = profile;
  rig.clock = hooks.clock ? hooks.clock : monotonicClock();
  // Shared by every simulated device, made only if one needs it.
  std::shared_ptr<SimWorld> world;
  COLLIDE_ASSIGN_OR_RETURN(
      rig.regulator,
      build<PressureRegulator>(rig.profile, rig.profile.regulator, hooks, rig.clock, world));
  COLLIDE_ASSIGN_OR_RETURN(
      rig.valves, build<ValveBank>(rig.profile, rig.profile.valves, hooks, rig.clock, world));
  COLLIDE_ASSIGN_OR_RETURN(rig.camera,
                           build<Camera>(rig.profile, rig.profile.camera, hooks, rig.clock, world));
  // A real (or Modbus-simulated) regulator on an otherwise simulated rig: the
  // simulated launches take their pressure from what it measures. The
  // regulator lives as long as the rig, and launches happen on the rig's
  // control thread, the regulator's own.
  if (world && rig.regulator->info().backend != "sim") {
    PressureRegulator* regulator = rig.regulator.get();
    world->setPressureSource(
        [regulator](int channel) { return regulator->readPressureKPa(channel); });
  }
  return rig;
}

Status bringUp(Rig& rig) {
  COLLIDE_RETURN_IF_ERROR(bringUpOne(*rig.regulator, rig.profile.regulator_config));
  COLLIDE_RETURN_IF_ERROR(bringUpOne(*rig.valves, rig.profile.valve_config));
  return bringUpOne(*rig.camera, rig.profile.camera_config);
}

Status shutDown(Rig& rig) {
  Status first = Ok{};
  auto keep = [&](Status s) {
    if (first && !s) first = s;
  };
  if (rig.valves && rig.valves->state() != DeviceState::Closed) keep(rig.valves->closeAll());
  if (rig.camera) keep(closeOne(*rig.camera));
  if (rig.valves) keep(closeOne(*rig.valves));
  if (rig.regulator) keep(closeOne(*rig.regulator));
  return first;
}

}  // namespace collide::hw
