#include "hw/rig.hpp"

#include <algorithm>

#include "hw/backend_registry.hpp"
#include "hw/format.hpp"
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
  rig.health = hooks.health ? hooks.health : std::make_shared<DeviceHealth>();
  // Shared by every simulated device, made only if one needs it.
  std::shared_ptr<SimWorld> world;
  COLLIDE_ASSIGN_OR_RETURN(
      rig.regulator,
      build<PressureRegulator>(rig.profile, rig.profile.regulator, hooks, rig.clock, world));
  COLLIDE_ASSIGN_OR_RETURN(
      rig.valves, build<ValveBank>(rig.profile, rig.profile.valves, hooks, rig.clock, world));
  COLLIDE_ASSIGN_OR_RETURN(rig.camera,
                           build<Camera>(rig.profile, rig.profile.camera, hooks, rig.clock, world));
  rig.regulator->setHealth(rig.health);
  rig.valves->setHealth(rig.health);
  rig.camera->setHealth(rig.health);
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

namespace {

Status probeRegulator(Rig& rig) {
  for (const LauncherProfile& l : rig.profile.launchers)
    if (Result<double> p = rig.regulator->readPressureKPa(l.regulator_channel); !p)
      return p.error();
  return Ok{};
}

Status probeCamera(Camera& camera, Clock& clock) {
  // A small burst as a shot takes one: a frame before the trigger, one after.
  const std::int64_t period = camera.config().framePeriodNs();
  COLLIDE_RETURN_IF_ERROR(camera.arm(1, 1));
  const std::int64_t now = clock.nowNs();
  // The trigger well ahead, as the sequencer does, so the stream is running by then.
  const std::int64_t trigger = now + std::max<std::int64_t>(50'000'000, 4 * period);
  COLLIDE_RETURN_IF_ERROR(camera.trigger(trigger));
  constexpr std::int64_t kProbeNs = 500'000'000;
  const std::int64_t deadline = trigger + std::max(kProbeNs, 10 * period);
  COLLIDE_RETURN_IF_ERROR(camera.waitBurst(deadline));  // a frame, or the deadline passed
  COLLIDE_ASSIGN_OR_RETURN(const vision::Burst burst, camera.takeBurst());
  if (burst.frames.empty())
    return camera.markLost("it delivered no frame within " + num(kProbeNs * 1e-9) +
                               " s of the trigger when probed (" + burst.note + ")",
                           "the camera's power and cable (camera.device)");
  return Ok{};
}

// Closes a lost device, so that bring-up opens it again (which forgets that
// it was lost) and the probe may ask it; whether it is lost is for them to say.
template <class Device>
bool closeIfLost(Device& d) {
  if (!d.loss()) return false;
  (void)closeOne(d);
  return true;
}

// The device that failed `s` is lost again with that reason (unless it was
// marked lost already, with a more precise one).
template <class Device>
Status stillLost(Device& d, Status s) {
  if (!s && !d.loss()) (void)d.markLost(s.error().message, "its power and cable");
  return s;
}

}  // namespace

Status recheck(Rig& rig) {
  const bool regulator = closeIfLost(*rig.regulator);
  const bool valves = closeIfLost(*rig.valves);
  const bool camera = closeIfLost(*rig.camera);
  if (!regulator && !valves && !camera) return Ok{};
  if (regulator) {
    COLLIDE_RETURN_IF_ERROR(
        stillLost(*rig.regulator, bringUpOne(*rig.regulator, rig.profile.regulator_config)));
    COLLIDE_RETURN_IF_ERROR(stillLost(*rig.regulator, probeRegulator(rig)));
  }
  if (valves)
    COLLIDE_RETURN_IF_ERROR(
        stillLost(*rig.valves, bringUpOne(*rig.valves, rig.profile.valve_config)));
  if (camera) {
    COLLIDE_RETURN_IF_ERROR(
        stillLost(*rig.camera, bringUpOne(*rig.camera, rig.profile.camera_config)));
    COLLIDE_RETURN_IF_ERROR(stillLost(*rig.camera, probeCamera(*rig.camera, *rig.clock)));
  }
  return Ok{};
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
