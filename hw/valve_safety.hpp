#pragma once
// Last-resort safety for valve lines: while a ValveLines is registered here,
// the process drives all of its lines inactive when it exits (atexit, also
// after main returns) and when it receives SIGINT, SIGTERM, SIGHUP, SIGQUIT
// or a crash signal (SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL). The handlers
// are installed on the first registration. After driving the lines, a signal
// handler passes the signal on: to the handler installed before ours if there
// was one (so a program's own Ctrl-C handling keeps working), else to the
// default action (the process ends with that signal as usual).
//
// SIGKILL (and a power cut, or a kernel panic) cannot be caught. Then only
// the kernel acts: it closes the process's line requests, and a released line
// goes back to what its GPIO chip driver does with a free line. gpio-sim and
// the project's VM test chip (tests/vm/gpio-sim-collide) turn it back into an
// input at its pull level; many SoC GPIO controllers keep driving the last
// value. So on the rig, wire each valve driver's input with a pull resistor
// to its inactive level: that, not software, is what holds a valve shut
// after a SIGKILL.
//
// Threads: register/unregister from any thread; the handlers run on whatever
// thread the signal lands on.
#include "hw/valve_lines.hpp"

namespace collide::hw {

/// Keeps `lines` registered for its lifetime. `lines` must outlive it.
class ValveSafetyGuard {
 public:
  explicit ValveSafetyGuard(ValveLines* lines);
  ~ValveSafetyGuard();
  ValveSafetyGuard(const ValveSafetyGuard&) = delete;
  ValveSafetyGuard& operator=(const ValveSafetyGuard&) = delete;
  /// False if the registry was full (64 banks): the lines then lack the
  /// exit/signal safety net and the bank refuses to open.
  bool registered() const { return slot_ >= 0; }

 private:
  int slot_ = -1;
};

/// The signal number that last made the handler drive the lines inactive, or
/// 0. A firing in progress checks this before each opening edge and stops.
int valveSafetySignal();
/// Forgets a caught signal (a bank's start() does, to fire again).
void clearValveSafetySignal();

}  // namespace collide::hw
