#include "hw/pressure_regulator_sim.hpp"

#include "hw/backend_registry.hpp"
#include "hw/try.hpp"

namespace collide::hw {

Result<RegulatorSimSettings> RegulatorSimSettings::read(SettingsReader& r) {
  RegulatorSimSettings s;
  COLLIDE_ASSIGN_OR_RETURN(s.channels, r.integer("channels", 2, {.ge = 1, .le = 64}));
  COLLIDE_ASSIGN_OR_RETURN(const double tau_ms,
                           r.number("time_constant_ms", 10.0, {.gt = 0.0, .le = 60000.0}));
  s.time_constant_s = tau_ms * 1e-3;
  COLLIDE_ASSIGN_OR_RETURN(s.noise_kPa, r.number("noise_kpa", 0.0, {.ge = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(const std::string fault,
                           r.text("fault", "none", {"none", "never_settles", "error"}));
  s.fault = fault == "never_settles" ? Fault::NeverSettles
            : fault == "error"       ? Fault::Error
                                     : Fault::None;
  COLLIDE_RETURN_IF_ERROR(r.finish("the sim regulator backend"));
  return s;
}

LineModel RegulatorSimSettings::lineModel() const {
  // A leak lets the line reach only part of any rise: it never settles.
  return {time_constant_s, fault == Fault::NeverSettles ? kLeakReach : 1.0};
}

PressureRegulatorSim::PressureRegulatorSim(std::shared_ptr<SimWorld> world,
                                           RegulatorSimSettings settings, std::string device)
    : PressureRegulator("regulator \"" + device + "\""),
      world_(std::move(world)),
      settings_(settings),
      device_(std::move(device)) {}

RegulatorInfo PressureRegulatorSim::info() const {
  return {"sim", device_, settings_.channels, settings_.device_min_kPa, settings_.device_max_kPa};
}

Status PressureRegulatorSim::onOpen() {
  link_failed_ = false;
  return Ok{};
}

Status PressureRegulatorSim::onConfigure(const RegulatorConfig&) {
  for (int ch = 0; ch < settings_.channels; ++ch) world_->setLineModel(ch, settings_.lineModel());
  return Ok{};
}

Status PressureRegulatorSim::linkUp() const {
  if (link_failed_)
    return fail(
        "no reply on the link (simulated fault regulator.fault = \"error\"): check the "
        "regulator's cable and power");
  return Ok{};
}

Status PressureRegulatorSim::onSetPressureKPa(int channel, double kPa) {
  if (Status s = linkUp(); !s) return s;
  world_->commandPressureKPa(channel, kPa);
  // The simulated link dies right after delivering its first setpoint.
  if (settings_.fault == RegulatorSimSettings::Fault::Error) link_failed_ = true;
  return Ok{};
}

Result<double> PressureRegulatorSim::onReadPressureKPa(int channel) {
  if (Status s = linkUp(); !s) return s.error();
  return world_->linePressureKPa(channel, world_->clock().nowNs()) +
         (settings_.noise_kPa > 0 ? world_->gaussian(settings_.noise_kPa) : 0.0);
}

namespace {

Result<std::unique_ptr<PressureRegulator>> makeSim(BackendContext& ctx) {
  SettingsReader r = ctx.device.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(const RegulatorSimSettings settings, RegulatorSimSettings::read(r));
  COLLIDE_ASSIGN_OR_RETURN(const std::shared_ptr<SimWorld> world, ctx.simWorld());
  return std::unique_ptr<PressureRegulator>(
      std::make_unique<PressureRegulatorSim>(world, settings, ctx.device.device));
}

const bool registered = BackendRegistry<PressureRegulator>::instance().add("sim", &makeSim);

}  // namespace

}  // namespace collide::hw
