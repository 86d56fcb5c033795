#include "hw/valve_bank_sim.hpp"

#include <algorithm>

#include "hw/backend_registry.hpp"
#include "hw/try.hpp"

namespace collide::hw {

Result<ValveSimSettings> ValveSimSettings::read(SettingsReader& r) {
  ValveSimSettings s;
  COLLIDE_ASSIGN_OR_RETURN(s.count, r.integer("count", 2, {.ge = 1, .le = 64}));
  COLLIDE_ASSIGN_OR_RETURN(s.jitter_us, r.number("jitter_us", 0.0, {.ge = 0.0, .le = 1e5}));
  COLLIDE_ASSIGN_OR_RETURN(const std::string fault, r.text("fault", "none", {"none", "error"}));
  s.fault = fault == "error" ? Fault::Error : Fault::None;
  COLLIDE_RETURN_IF_ERROR(r.finish("the sim valve backend"));
  return s;
}

ValveBankSim::ValveBankSim(std::shared_ptr<SimWorld> world, std::shared_ptr<Clock> clock,
                           ValveSimSettings settings, std::string device)
    : ValveBank("valves \"" + device + "\""),
      world_(std::move(world)),
      clock_(std::move(clock)),
      settings_(settings),
      device_(std::move(device)) {}

ValveInfo ValveBankSim::info() const {
  return {"sim", device_, settings_.count};
}

Result<std::vector<ValveEvent>> ValveBankSim::onFire(const std::vector<ValvePulse>& pattern) {
  if (settings_.fault == ValveSimSettings::Fault::Error)
    return fail(
        "the driver refused to drive the valve lines (simulated fault valves.fault = "
        "\"error\"): check the valve driver's power");
  // The whole pattern is decided up front (openings with jitter, never in the
  // past) so the world knows the launch before the valves open in real time.
  const std::int64_t now = clock_->nowNs();
  std::vector<ValveEvent> events;
  for (const ValvePulse& p : pattern) {
    const double jitter_ns = settings_.jitter_us > 0 ? world_->gaussian(SimWorld::Noise::Valves,
                                                                        settings_.jitter_us * 1e3)
                                                     : 0;
    const std::int64_t opened = std::max(now, p.open_at_ns + static_cast<std::int64_t>(jitter_ns));
    events.push_back({p.valve, opened, opened + p.pulse_us * 1000});
  }
  if (Status s = world_->launch(events); !s) return s.error();
  std::int64_t last_close = now;
  for (const ValveEvent& e : events) last_close = std::max(last_close, e.closed_ns);
  clock_->sleepUntilNs(last_close);
  log_.insert(log_.end(), events.begin(), events.end());
  return events;
}

Status ValveBankSim::onCloseAll() {
  ++close_all_count_;
  return Ok{};
}

namespace {

Result<std::unique_ptr<ValveBank>> makeSim(BackendContext& ctx) {
  SettingsReader r = ctx.device.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(const ValveSimSettings settings, ValveSimSettings::read(r));
  COLLIDE_ASSIGN_OR_RETURN(const std::shared_ptr<SimWorld> world, ctx.simWorld());
  return std::unique_ptr<ValveBank>(
      std::make_unique<ValveBankSim>(world, ctx.clock, settings, ctx.device.device));
}

const bool registered = BackendRegistry<ValveBank>::instance().add("sim", &makeSim);

}  // namespace

}  // namespace collide::hw
