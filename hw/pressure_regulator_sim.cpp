#include "hw/pressure_regulator_sim.hpp"

#include <cmath>

#include "hw/backend_registry.hpp"
#include "hw/format.hpp"
#include "hw/try.hpp"

namespace collide::hw {

Result<RegulatorSimSettings> RegulatorSimSettings::read(SettingsReader& r) {
  RegulatorSimSettings s;
  COLLIDE_ASSIGN_OR_RETURN(s.channels, r.integer("channels", 2, {.ge = 1, .le = 64}));
  COLLIDE_ASSIGN_OR_RETURN(const double tau_ms,
                           r.number("time_constant_ms", 10.0, {.gt = 0.0, .le = 60000.0}));
  s.time_constant_s = tau_ms * 1e-3;
  COLLIDE_ASSIGN_OR_RETURN(s.hold_band_kPa,
                           r.number("hold_band_kpa", kDefaultHoldBandKPa, {.ge = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(s.noise_kPa, r.number("noise_kpa", 0.0, {.ge = 0.0}));
  COLLIDE_ASSIGN_OR_RETURN(const std::string fault,
                           r.text("fault", "none", {"none", "never_settles", "error", "silent"}));
  s.fault = fault == "never_settles" ? Fault::NeverSettles
            : fault == "error"       ? Fault::Error
            : fault == "silent"      ? Fault::Silent
                                     : Fault::None;
  COLLIDE_ASSIGN_OR_RETURN(s.silent_after_setpoints,
                           r.integer("silent_after_setpoints", 0, {.ge = 0, .le = 1e9}));
  COLLIDE_ASSIGN_OR_RETURN(s.silent_timeout_ms,
                           r.number("silent_timeout_ms", 100.0, {.ge = 0.0, .le = 60000.0}));
  COLLIDE_RETURN_IF_ERROR(r.finish("the sim regulator backend"));
  return s;
}

LineModel RegulatorSimSettings::lineModel() const {
  // A leak lets the line reach only part of any rise: it never settles.
  return {time_constant_s, fault == Fault::NeverSettles ? kLeakReach : 1.0, hold_band_kPa};
}

PressureRegulatorSim::PressureRegulatorSim(std::shared_ptr<SimWorld> world,
                                           RegulatorSimSettings settings, std::string device)
    : PressureRegulator("regulator \"" + device + "\""),
      world_(std::move(world)),
      settings_(settings),
      device_(std::move(device)) {
  if (settings_.fault == RegulatorSimSettings::Fault::Silent)
    silence_ = SimSilence::forDevice(label(), settings_.silent_after_setpoints);
}

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

Status PressureRegulatorSim::heard(bool setpoint) {
  if (!silence_ || silence_->answer(setpoint)) return Ok{};
  Clock& clock = world_->clock();
  clock.sleepUntilNs(clock.nowNs() + std::llround(settings_.silent_timeout_ms * 1e6));
  return markLost("no answer within " + num(settings_.silent_timeout_ms) +
                      " ms (simulated fault regulator.fault = \"silent\")",
                  "the regulator's power and cable (regulator.device)");
}

Status PressureRegulatorSim::onSetPressureKPa(int channel, double kPa) {
  if (Status s = linkUp(); !s) return s;
  if (Status s = heard(true); !s) return s;
  world_->commandPressureKPa(channel, kPa);
  // The simulated link dies right after delivering its first setpoint.
  if (settings_.fault == RegulatorSimSettings::Fault::Error) link_failed_ = true;
  return Ok{};
}

Result<double> PressureRegulatorSim::onReadPressureKPa(int channel) {
  if (Status s = linkUp(); !s) return s.error();
  if (Status s = heard(false); !s) return s.error();
  return world_->linePressureKPa(channel, world_->clock().nowNs()) +
         (settings_.noise_kPa > 0
              ? world_->gaussian(SimWorld::Noise::Regulator, settings_.noise_kPa)
              : 0.0);
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
