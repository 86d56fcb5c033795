#include "hw/valve_bank.hpp"

#include <set>

#include "hw/clock.hpp"
#include "hw/format.hpp"

namespace collide::hw {

std::int64_t ValveBank::nowNs() const {
  return monotonicNowNs();
}

Status ValveBank::open() {
  return lifecycle_.open([&] { return prefixed(label(), onOpen()); });
}

Status ValveBank::configure(const ValveConfig& config) {
  return lifecycle_.configure([&]() -> Status {
    if (config.max_pulse_us <= 0)
      return fail(label() +
                  ": the longest valve pulse must be > 0 us: check "
                  "safety.max_valve_pulse_us");
    if (Status s = prefixed(label(), onConfigure(config)); !s) return s;
    config_ = config;
    return Ok{};
  });
}

Status ValveBank::start() {
  return lifecycle_.start([&] { return prefixed(label(), onStart()); });
}

Status ValveBank::stop() {
  return lifecycle_.stop([&]() -> Status {
    // Never leave a valve open behind a stopped device.
    Status closed = prefixed(label(), onCloseAll());
    Status stopped = prefixed(label(), onStop());
    return closed ? stopped : closed;
  });
}

Status ValveBank::close() {
  return lifecycle_.close(
      [&]() -> Status {
        Status closed = prefixed(label(), onCloseAll());
        Status stopped = prefixed(label(), onStop());
        return closed ? stopped : closed;
      },
      [&] { return prefixed(label(), onClose()); });
}

Result<std::vector<ValveEvent>> ValveBank::fire(const std::vector<ValvePulse>& pattern) {
  if (Status s = lifecycle_.require("fire()", {DeviceState::Running}); !s) return s.error();
  if (pattern.empty()) return fail(label() + ": fire(): the pattern names no valve");
  const int valves = info().valves;
  const std::int64_t now = nowNs();
  std::set<int> seen;
  for (const ValvePulse& p : pattern) {
    const std::string which = label() + ": valve " + std::to_string(p.valve);
    if (p.valve < 0 || p.valve >= valves)
      return fail(which + " does not exist (the bank has " + std::to_string(valves) +
                  "): check launcher.valve");
    if (!seen.insert(p.valve).second) return fail(which + " appears twice in one firing pattern");
    if (p.pulse_us <= 0 || p.pulse_us > config_.max_pulse_us)
      return fail(which + ": pulse of " + std::to_string(p.pulse_us) + " us is outside 1.." +
                  std::to_string(config_.max_pulse_us) +
                  " us (sequencer.pulse_us, safety.max_valve_pulse_us)");
    if (p.open_at_ns - now > 10'000'000'000)
      return fail(which + ": opening " + num((p.open_at_ns - now) * 1e-9) +
                  " s from now is too far ahead (at most 10 s)");
  }
  Result<std::vector<ValveEvent>> events = onFire(pattern);
  if (!events) {
    Status closed = onCloseAll();
    const std::string why = prefixed(label(), Status(events.error())).error().message;
    if (closed) return fail(why + "; all valves closed");
    // A bank that is gone fails the closing for the same reason: say it once.
    if (closed.error().message == why)
      return fail(why + "; closing the valves failed too, for the same reason");
    return fail(why + "; closing the valves failed too: " + closed.error().message);
  }
  return events;
}

Status ValveBank::closeAll() {
  // Never refused on a lost bank: a valve must not stay open, and driving a
  // line that is gone fails at once (it waits on nothing).
  if (Status s = lifecycle_.requireState(
          "closeAll()", {DeviceState::Open, DeviceState::Configured, DeviceState::Running});
      !s)
    return s;
  return prefixed(label(), onCloseAll());
}

}  // namespace collide::hw
