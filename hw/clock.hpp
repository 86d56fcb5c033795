#pragma once
// Time for the devices and the sequencer: integer nanoseconds on the host's
// CLOCK_MONOTONIC, the one clock every StepStamp, valve event and frame
// timestamp of a shot is on. The clock is injected so that tests can move time
// by hand instead of waiting for it.
#include <atomic>
#include <cstdint>
#include <memory>

namespace collide::hw {

class Clock {
 public:
  virtual ~Clock() = default;
  /// Now, nanoseconds. Any thread.
  virtual std::int64_t nowNs() const = 0;
  /// Blocks the calling thread until nowNs() >= t_ns; returns at once if that
  /// time has passed. Any thread.
  virtual void sleepUntilNs(std::int64_t t_ns) = 0;
};

/// CLOCK_MONOTONIC, nanoseconds. Any thread.
std::int64_t monotonicNowNs();

/// The process-wide CLOCK_MONOTONIC clock.
std::shared_ptr<Clock> monotonicClock();

/// A clock that moves only when told to; sleepUntilNs() jumps it forward to the
/// wanted time (so code that sleeps runs instantly). For tests; any thread.
class ManualClock final : public Clock {
 public:
  explicit ManualClock(std::int64_t start_ns = 1'000'000'000) : now_ns_(start_ns) {}
  std::int64_t nowNs() const override { return now_ns_.load(); }
  void sleepUntilNs(std::int64_t t_ns) override;
  void advanceNs(std::int64_t dt_ns) { now_ns_ += dt_ns; }

 private:
  std::atomic<std::int64_t> now_ns_;
};

}  // namespace collide::hw
