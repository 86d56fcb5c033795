#pragma once
// ValveBankGpiod ("gpiod"): the solenoid valves on GPIO lines (GpiodLines,
// libgpiod 1.6). The lines are requested on open() (inactive) and held until
// close(); every edge of a firing pattern is timed by sleeping with
// clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) up to it. Each valve's
// closing edge is scheduled from when its opening edge actually happened (the
// end of the driver call), so a late or slow opening delays the pulse and
// never shortens it. The first opening
// anchors the pattern: when it comes late (a loaded machine, an instant
// already past), every later opening moves by as much, so the delays between
// valves (which decide where the spheres meet) hold; the events report when
// each edge really happened.
//
// Safety, in layers:
//  - fire() refuses pulses longer than safety.max_valve_pulse_us (ValveBank);
//  - a watchdog thread drives a line inactive if it has been active for
//    longer than that limit plus watchdog_grace_us, whatever the firing loop
//    is doing (stalled driver, preempted thread); fire() then fails;
//  - stop(), close(), a failed fire() and the destructor drive every line
//    inactive;
//  - exit and SIGINT/SIGTERM/SIGHUP/SIGQUIT/crash signals drive every line
//    inactive (valve_safety.hpp), and a firing stops at its next opening edge;
//  - SIGKILL: the kernel releases the requests (see valve_safety.hpp for what
//    the line then does, and why the rig needs pull resistors).
//
// [valves] settings (gpiod backend):
//   device = "gpiochip0"       chip of lines given as offsets
//   lines = [17, 27]           one per valve (valve 0 first): offsets on `device`,
//                              or strings: a line name "VALVE_LEFT" or "gpiochip1:17"
//   active_low = false         true: a valve is open while its line is low
//   consumer = "collide"       the name `gpioinfo` shows for the held lines
//   watchdog_grace_us = 2000   how far past the longest pulse the watchdog steps in
//   realtime_priority = 0      1..99: fire (and watch) at SCHED_FIFO priority, so
//                              other programs cannot delay the edges; needs
//                              CAP_SYS_NICE or an rtprio limit (limits.d); 0: off
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "hw/gpiod_lines.hpp"
#include "hw/settings.hpp"
#include "hw/valve_bank.hpp"
#include "hw/valve_lines.hpp"
#include "hw/valve_safety.hpp"

namespace collide::hw {

struct ValveGpiodSettings {
  std::vector<GpiodLineSpec> lines;
  bool active_low = false;
  std::string consumer = "collide";
  std::int64_t watchdog_grace_us = 2000;
  int realtime_priority = 0;

  /// From the [valves] table (device, lines, active_low, consumer,
  /// watchdog_grace_us, realtime_priority); refuses unknown keys. `chip` is valves.device.
  static Result<ValveGpiodSettings> read(SettingsReader& r, const std::string& chip);
};

class ValveBankGpiod final : public ValveBank {
 public:
  /// Opens the lines (called by open()); the gpiod backend passes
  /// GpiodLines::open, tests and benchmarks a RecordingValveLines.
  using LineOpener = std::function<Result<std::unique_ptr<ValveLines>>()>;

  ValveBankGpiod(std::string device, int valves, LineOpener open_lines,
                 std::int64_t watchdog_grace_us = 2000);
  ~ValveBankGpiod() override;

  ValveInfo info() const override;
  /// The open lines (null unless open). Control thread.
  ValveLines* lines() const { return lines_.get(); }
  /// How many times the watchdog cut a pulse short since open(). Any thread.
  int watchdogTrips() const;
  /// 1..99: fire() runs at this SCHED_FIFO priority (restored after), and the
  /// watchdog one above; start() fails if the process may not. 0: off.
  /// Before start().
  void setRealtimePriority(int priority) { rt_priority_ = priority; }

 protected:
  Status onOpen() override;
  Status onConfigure(const ValveConfig& config) override;
  Status onStart() override;
  Status onStop() override;
  Status onClose() override;
  Result<std::vector<ValveEvent>> onFire(const std::vector<ValvePulse>& pattern) override;
  Status onCloseAll() override;

 private:
  // When an edge happened: the middle of the driver call (the best estimate,
  // reported) and its end (by when the line had surely switched).
  struct Edge {
    std::int64_t mid_ns = 0;
    std::int64_t after_ns = 0;
  };
  // Drives `line` (CLOCK_MONOTONIC times). Keeps the watchdog informed.
  Result<Edge> drive(int line, bool active);
  void watchdogLoop();
  void stopWatchdog();

  std::string device_;
  int valves_;
  LineOpener open_lines_;
  std::int64_t grace_ns_;
  int rt_priority_ = 0;
  std::int64_t max_pulse_ns_ = 0;
  std::unique_ptr<ValveLines> lines_;
  std::unique_ptr<ValveSafetyGuard> guard_;

  // Watchdog state, under wd_mutex_: per line, when it went active (nullopt:
  // inactive); per line a mutex serialising edges on it.
  mutable std::mutex wd_mutex_;
  std::condition_variable wd_cv_;
  std::vector<std::optional<std::int64_t>> active_since_;
  std::vector<std::unique_ptr<std::mutex>> line_mutex_;
  std::vector<std::int64_t> tripped_at_;  // lines the watchdog closed during this fire()
  bool wd_stop_ = false;
  int wd_trips_ = 0;
  std::thread watchdog_;
};

}  // namespace collide::hw
