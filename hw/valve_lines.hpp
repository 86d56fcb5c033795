#pragma once
// The output side of a valve bank: N lines, each driven active (valve open)
// or inactive (closed). ValveBankGpiod times the edges; a ValveLines only
// drives them. GpiodLines (gpiod_lines.hpp) drives real GPIO lines through
// libgpiod; RecordingValveLines below drives nothing and records when each
// edge was asked for, so the firing logic can be tested and benchmarked on a
// host without a GPIO chip.
//
// Threads: set() may be called from two threads at once for different lines
// (the firing loop and the pulse watchdog), never for the same line at once.
// setAllInactiveFromSignal() may run in a signal handler, interrupting anything.
#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"

namespace collide::hw {

class ValveLines {
 public:
  virtual ~ValveLines() = default;

  /// Number of lines, numbered 0 .. count()-1 (the valve numbers).
  virtual int count() const = 0;
  /// How the line is named in messages, e.g. `gpiochip0 line 17 ("VALVE_LEFT")`.
  virtual std::string describe(int line) const = 0;
  /// Drives line `line` active (valve open) or inactive. Errors name the line.
  virtual Status set(int line, bool active) = 0;
  /// Drives every line inactive. Async-signal-safe: no allocation, no locks,
  /// only system calls. Returns false if any line could not be driven.
  virtual bool setAllInactiveFromSignal() noexcept = 0;
  /// What happened if a set() found its chip gone (unplugged, its driver
  /// unbound: ENODEV, ENXIO, EIO), so that no line can be driven until the
  /// lines are requested again; none while every failure was something else.
  /// Any thread.
  virtual std::optional<std::string> gone() const { return std::nullopt; }
};

/// Lines that drive nothing: each set() is recorded with the CLOCK_MONOTONIC
/// instant the level changed. A fault knob makes one edge stall or fail, to test
/// what the bank does when a driver misbehaves.
class RecordingValveLines final : public ValveLines {
 public:
  struct Edge {
    int line = 0;
    bool active = false;
    std::int64_t t_ns = 0;  ///< CLOCK_MONOTONIC when the level changed (after any stall)
  };

  explicit RecordingValveLines(int count);

  int count() const override { return static_cast<int>(level_.size()); }
  std::string describe(int line) const override;
  Status set(int line, bool active) override;
  bool setAllInactiveFromSignal() noexcept override;

  /// Every edge so far, oldest first (a copy; any thread).
  std::vector<Edge> edges() const;
  void clearEdges();
  /// Current level of `line` (true: active). Any thread.
  bool active(int line) const { return level_[static_cast<std::size_t>(line)].load(); }

  /// Fault: the next set(line, active) call sleeps `stall_ns` before acting
  /// (a stuck driver), and/or fails instead of acting (`fail`).
  void injectFault(int line, bool active, std::int64_t stall_ns, bool fail);
  /// Fault: the chip goes away (unplugged): from now on every set() fails
  /// as GpiodLines does on ENODEV, and gone() says so.
  void unplug() { unplugged_.store(true); }
  std::optional<std::string> gone() const override;
  /// set() calls made since construction, answered or not. Any thread.
  int calls() const { return calls_.load(); }

  /// When setAllInactiveFromSignal() runs, it also writes `message` to file
  /// descriptor `fd` (write(2), signal-safe), so a test can see it happened.
  void reportSignalTo(int fd, const char* message) {
    signal_fd_ = fd;
    signal_message_ = message;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<Edge> edges_;
  std::vector<std::atomic<bool>> level_;
  struct Fault {
    int line = -1;
    bool active = false;
    std::int64_t stall_ns = 0;
    bool fail = false;
  } fault_;
  std::atomic<bool> unplugged_{false};
  std::atomic<int> calls_{0};
  int signal_fd_ = -1;
  const char* signal_message_ = nullptr;
};

}  // namespace collide::hw
