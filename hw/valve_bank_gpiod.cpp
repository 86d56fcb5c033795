#include "hw/valve_bank_gpiod.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <limits>
#include <set>

#include "hw/backend_registry.hpp"
#include "hw/clock.hpp"
#include "hw/format.hpp"
#include "hw/try.hpp"

namespace collide::hw {

namespace {

// Sleeps until `t_ns` on CLOCK_MONOTONIC, waking early only for a signal
// (the caller checks for one and goes back to sleep otherwise).
void sleepUntilMonotonic(std::int64_t t_ns) {
  const timespec ts{static_cast<time_t>(t_ns / 1'000'000'000),
                    static_cast<long>(t_ns % 1'000'000'000)};
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
}

// Runs the calling thread at SCHED_FIFO `priority` for its lifetime (0: no change).
class RealtimeScope {
 public:
  explicit RealtimeScope(int priority) {
    if (priority <= 0) return;
    pthread_getschedparam(pthread_self(), &policy_, &param_);
    sched_param p{};
    p.sched_priority = priority;
    error_ = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
    active_ = error_ == 0;
  }
  ~RealtimeScope() {
    if (active_) pthread_setschedparam(pthread_self(), policy_, &param_);
  }
  int error() const { return error_; }

 private:
  int policy_ = SCHED_OTHER;
  sched_param param_{};
  int error_ = 0;
  bool active_ = false;
};

std::string signalName(int sig) {
  const char* abbrev = sigabbrev_np(sig);
  return abbrev ? std::string("SIG") + abbrev : "signal " + std::to_string(sig);
}

}  // namespace

Result<ValveGpiodSettings> ValveGpiodSettings::read(SettingsReader& r, const std::string& chip) {
  ValveGpiodSettings s;
  const auto it = r.table().values.find("lines");
  if (it == r.table().values.end())
    return r.invalid("lines",
                     "is missing: list one GPIO line per valve, as offsets on valves.device "
                     "([17, 27]) or as names ([\"VALVE_LEFT\", \"gpiochip1:5\"])");
  r.markRead("lines");
  const SettingValue& v = it->second;
  if (const auto* offsets = std::get_if<std::vector<double>>(&v.value)) {
    if (chip.empty() || chip == "gpiod")
      return r.invalid("lines",
                       "offsets need their chip: set valves.device (e.g. \"gpiochip0\"; "
                       "`gpiodetect` lists chips)");
    for (double d : *offsets) {
      if (!(d >= 0) || d != static_cast<double>(static_cast<unsigned>(d)) || d > 65535)
        return r.invalid("lines", "offsets must be whole numbers >= 0");
      s.lines.push_back({chip, static_cast<unsigned>(d), ""});
    }
  } else if (const auto* names = std::get_if<std::vector<std::string>>(&v.value)) {
    for (const std::string& n : *names) {
      GpiodLineSpec spec;
      if (!parseGpiodLineSpec(n, spec))
        return r.invalid("lines", "\"" + n + "\" is neither a line name nor \"chip:offset\"");
      s.lines.push_back(spec);
    }
  } else {
    return r.invalid("lines", "must be an array of line offsets or of line names");
  }
  if (s.lines.empty()) return r.invalid("lines", "names no line: give one per valve");
  std::set<std::string> seen;
  for (const GpiodLineSpec& spec : s.lines)
    if (!seen.insert(spec.text()).second)
      return r.invalid("lines", spec.text() + " is listed twice: one line per valve");
  COLLIDE_ASSIGN_OR_RETURN(s.active_low, r.boolean("active_low", false));
  COLLIDE_ASSIGN_OR_RETURN(s.consumer, r.text("consumer", "collide"));
  if (s.consumer.empty() || s.consumer.size() > 31)
    return r.invalid("consumer", "must be 1 to 31 characters (the kernel's limit)");
  COLLIDE_ASSIGN_OR_RETURN(s.watchdog_grace_us,
                           r.integer("watchdog_grace_us", 2000, {.ge = 0, .le = 1'000'000}));
  COLLIDE_ASSIGN_OR_RETURN(s.realtime_priority,
                           r.integer("realtime_priority", 0, {.ge = 0, .le = 98}));
  COLLIDE_RETURN_IF_ERROR(r.finish("the gpiod valve backend"));
  return s;
}

ValveBankGpiod::ValveBankGpiod(std::string device, int valves, LineOpener open_lines,
                               std::int64_t watchdog_grace_us)
    : ValveBank("valves \"" + device + "\""),
      device_(std::move(device)),
      valves_(valves),
      open_lines_(std::move(open_lines)),
      grace_ns_(watchdog_grace_us * 1000) {}

ValveBankGpiod::~ValveBankGpiod() {
  stopWatchdog();
  if (lines_) lines_->setAllInactiveFromSignal();
  guard_.reset();
  lines_.reset();
}

ValveInfo ValveBankGpiod::info() const {
  return {"gpiod", device_, valves_};
}

int ValveBankGpiod::watchdogTrips() const {
  std::lock_guard lock(wd_mutex_);
  return wd_trips_;
}

Status ValveBankGpiod::onOpen() {
  COLLIDE_ASSIGN_OR_RETURN(std::unique_ptr<ValveLines> lines, open_lines_());
  if (lines->count() != valves_)
    return fail("opened " + std::to_string(lines->count()) + " lines for " +
                std::to_string(valves_) + " valves");
  auto guard = std::make_unique<ValveSafetyGuard>(lines.get());
  if (!guard->registered())
    return fail("too many valve banks open in one process (64) to guard them on exit");
  {
    std::lock_guard lock(wd_mutex_);
    active_since_.assign(static_cast<std::size_t>(valves_), std::nullopt);
    line_mutex_.clear();
    for (int i = 0; i < valves_; ++i) line_mutex_.push_back(std::make_unique<std::mutex>());
    wd_trips_ = 0;
  }
  lines_ = std::move(lines);
  guard_ = std::move(guard);
  return Ok{};
}

Status ValveBankGpiod::onConfigure(const ValveConfig& config) {
  std::lock_guard lock(wd_mutex_);
  max_pulse_ns_ = config.max_pulse_us * 1000;
  return Ok{};
}

Status ValveBankGpiod::onStart() {
  if (rt_priority_ > 0) {
    // Find out now, not at the first shot, whether real-time priority is allowed.
    RealtimeScope probe(rt_priority_);
    if (probe.error())
      return fail("cannot fire at real-time priority " + std::to_string(rt_priority_) + " (" +
                  std::strerror(probe.error()) +
                  "): allow it (CAP_SYS_NICE, or a line `@collide - rtprio " +
                  std::to_string(rt_priority_ + 1) +
                  "` in /etc/security/limits.d/, then log in again) or set "
                  "valves.realtime_priority = 0");
  }
  clearValveSafetySignal();
  {
    std::lock_guard lock(wd_mutex_);
    wd_stop_ = false;
  }
  watchdog_ = std::thread(&ValveBankGpiod::watchdogLoop, this);
  if (rt_priority_ > 0) {
    // The watchdog must be able to preempt a firing loop that runs away.
    sched_param p{};
    p.sched_priority = rt_priority_ + 1;
    pthread_setschedparam(watchdog_.native_handle(), SCHED_FIFO, &p);
  }
  return Ok{};
}

void ValveBankGpiod::stopWatchdog() {
  {
    std::lock_guard lock(wd_mutex_);
    wd_stop_ = true;
    wd_cv_.notify_all();
  }
  if (watchdog_.joinable()) watchdog_.join();
}

Status ValveBankGpiod::onStop() {
  stopWatchdog();
  return Ok{};
}

Status ValveBankGpiod::onClose() {
  stopWatchdog();
  Status s = onCloseAll();
  guard_.reset();  // unregister before the lines go
  lines_.reset();  // releases the requests
  return s;
}

Result<ValveBankGpiod::Edge> ValveBankGpiod::drive(int line, bool active) {
  std::lock_guard edge(*line_mutex_[static_cast<std::size_t>(line)]);
  const std::int64_t t0 = monotonicNowNs();
  if (active) {
    // The watchdog starts counting before the edge: it may only err early.
    std::lock_guard lock(wd_mutex_);
    active_since_[static_cast<std::size_t>(line)] = t0;
    wd_cv_.notify_all();
  }
  Status s = lines_->set(line, active);
  const std::int64_t t1 = monotonicNowNs();
  if (!active || !s) {
    std::lock_guard lock(wd_mutex_);
    active_since_[static_cast<std::size_t>(line)] = std::nullopt;
  }
  if (!s) {
    // The chip went away: the bank is lost, and every later fire() is refused
    // at once until it is reopened (closeAll() still tries every line).
    if (std::optional<std::string> gone = lines_->gone())
      return markLost(*gone,
                      "that the GPIO chip is still there (`gpiodetect`), its cable or "
                      "board connection and power, and valves.device / valves.lines");
    return s.error();
  }
  return Edge{t0 + (t1 - t0) / 2, t1};
}

void ValveBankGpiod::watchdogLoop() {
  std::unique_lock lock(wd_mutex_);
  while (!wd_stop_) {
    std::int64_t deadline = std::numeric_limits<std::int64_t>::max();
    int due = -1;
    for (std::size_t i = 0; i < active_since_.size(); ++i) {
      if (!active_since_[i]) continue;
      const std::int64_t d = *active_since_[i] + max_pulse_ns_ + grace_ns_;
      if (d < deadline) {
        deadline = d;
        due = static_cast<int>(i);
      }
    }
    if (due < 0) {
      wd_cv_.wait(lock);
      continue;
    }
    if (monotonicNowNs() < deadline) {
      wd_cv_.wait_until(lock,
                        std::chrono::steady_clock::time_point(std::chrono::nanoseconds(deadline)));
      continue;
    }
    // Over the limit: take the line's edge lock (lock order: line, then state).
    const std::int64_t since = *active_since_[static_cast<std::size_t>(due)];
    lock.unlock();
    {
      std::lock_guard edge(*line_mutex_[static_cast<std::size_t>(due)]);
      std::lock_guard relock(wd_mutex_);
      auto& slot = active_since_[static_cast<std::size_t>(due)];
      if (slot && *slot == since) {
        (void)lines_->set(due, false);
        slot = std::nullopt;
        ++wd_trips_;
        tripped_at_.push_back(due);
      }
    }
    lock.lock();
  }
}

Result<std::vector<ValveEvent>> ValveBankGpiod::onFire(const std::vector<ValvePulse>& pattern) {
  if (const int sig = valveSafetySignal())
    return fail("a " + signalName(sig) +
                " drove every valve line inactive: stop() and start() the valves to fire again");
  {
    std::lock_guard lock(wd_mutex_);
    tripped_at_.clear();
  }
  // Sleep to each edge without the kernel's default 50 us timer slack (it
  // may otherwise wake this thread that much late, on purpose); restored after.
  struct SlackGuard {
    int previous = prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0);
    SlackGuard() { prctl(PR_SET_TIMERSLACK, 1, 0, 0, 0); }
    ~SlackGuard() {
      if (previous > 0) prctl(PR_SET_TIMERSLACK, previous, 0, 0, 0);
    }
  } slack;
  const RealtimeScope realtime(rt_priority_);
  struct Slot {
    ValvePulse pulse;
    std::optional<std::int64_t> opened, close_at, closed;
  };
  std::vector<Slot> slots;
  for (const ValvePulse& p : pattern) slots.push_back({p, {}, {}, {}});

  // The first opening anchors the pattern: if it comes late (a busy machine,
  // an instant already past), every later opening moves with it, so the
  // delays between valves, which decide where the spheres meet, hold.
  std::optional<std::int64_t> shift;
  for (;;) {
    // The next edge: the earliest unopened opening or pending closing.
    std::int64_t next = std::numeric_limits<std::int64_t>::max();
    Slot* which = nullptr;
    for (Slot& s : slots) {
      const std::optional<std::int64_t> t =
          !s.opened   ? std::optional(s.pulse.open_at_ns + shift.value_or(0))
          : !s.closed ? s.close_at
                      : std::nullopt;
      if (t && *t < next) {
        next = *t;
        which = &s;
      }
    }
    if (!which) break;
    while (monotonicNowNs() < next && !valveSafetySignal()) sleepUntilMonotonic(next);
    if (const int sig = valveSafetySignal())
      return fail("a " + signalName(sig) +
                  " stopped the firing; every valve line was driven "
                  "inactive");
    Slot& s = *which;
    if (!s.opened) {
      COLLIDE_ASSIGN_OR_RETURN(const Edge e, drive(s.pulse.valve, true));
      // A signal between the check above and the edge: undo at once.
      if (const int sig = valveSafetySignal()) {
        (void)drive(s.pulse.valve, false);
        return fail("a " + signalName(sig) +
                    " stopped the firing; every valve line was driven "
                    "inactive");
      }
      s.opened = e.mid_ns;
      // Timed from when the call returned, by which time the line had surely
      // switched: a pulse is never shorter than asked, even when the driver
      // call is slow.
      s.close_at = e.after_ns + s.pulse.pulse_us * 1000;
      if (!shift) shift = std::max<std::int64_t>(0, e.mid_ns - s.pulse.open_at_ns);
    } else {
      COLLIDE_ASSIGN_OR_RETURN(const Edge e, drive(s.pulse.valve, false));
      s.closed = e.mid_ns;
    }
  }

  std::vector<std::int64_t> tripped;
  {
    std::lock_guard lock(wd_mutex_);
    tripped.swap(tripped_at_);
  }
  if (!tripped.empty()) {
    std::string which;
    for (std::int64_t v : tripped) which += (which.empty() ? "" : ", ") + std::to_string(v);
    return fail("valve " + which + " stayed active longer than safety.max_valve_pulse_us = " +
                std::to_string(max_pulse_ns_ / 1000) + " us (+" + std::to_string(grace_ns_ / 1000) +
                " us grace): the watchdog drove it inactive; the firing thread was held up "
                "(driver stall or an overloaded machine)");
  }
  std::vector<ValveEvent> events;
  for (const Slot& s : slots) events.push_back({s.pulse.valve, *s.opened, *s.closed});
  return events;
}

Status ValveBankGpiod::onCloseAll() {
  if (!lines_) return Ok{};
  Status first = Ok{};
  for (int i = 0; i < valves_; ++i) {
    auto r = drive(i, false);
    if (!r && first) first = r.error();
  }
  return first;
}

namespace {

Result<std::unique_ptr<ValveBank>> makeGpiod(BackendContext& ctx) {
  SettingsReader r = ctx.device.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(const ValveGpiodSettings s,
                           ValveGpiodSettings::read(r, ctx.device.device));
  if (ctx.clock != monotonicClock())
    return fail("valves \"" + ctx.device.device +
                "\": GPIO valves fire on CLOCK_MONOTONIC; build their rig without RigHooks::clock");
  ValveBankGpiod::LineOpener opener = [s]() -> Result<std::unique_ptr<ValveLines>> {
    COLLIDE_ASSIGN_OR_RETURN(std::unique_ptr<GpiodLines> lines,
                             GpiodLines::open(s.lines, s.active_low, s.consumer));
    return std::unique_ptr<ValveLines>(std::move(lines));
  };
  auto bank = std::make_unique<ValveBankGpiod>(ctx.device.device, static_cast<int>(s.lines.size()),
                                               opener, s.watchdog_grace_us);
  bank->setRealtimePriority(s.realtime_priority);
  return std::unique_ptr<ValveBank>(std::move(bank));
}

const bool registered = BackendRegistry<ValveBank>::instance().add("gpiod", &makeGpiod);

}  // namespace

}  // namespace collide::hw
