#include "hw/clock.hpp"

#include <cerrno>
#include <ctime>

namespace collide::hw {

namespace {

class MonotonicClock final : public Clock {
 public:
  std::int64_t nowNs() const override { return monotonicNowNs(); }
  void sleepUntilNs(std::int64_t t_ns) override {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(t_ns / 1'000'000'000);
    ts.tv_nsec = static_cast<long>(t_ns % 1'000'000'000);
    // Absolute sleep: no drift from the time spent computing the deadline;
    // EINTR (a signal) just means sleep again until the same instant.
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
  }
};

}  // namespace

std::int64_t monotonicNowNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::shared_ptr<Clock> monotonicClock() {
  static const std::shared_ptr<Clock> clock = std::make_shared<MonotonicClock>();
  return clock;
}

void ManualClock::sleepUntilNs(std::int64_t t_ns) {
  std::int64_t now = now_ns_.load();
  while (now < t_ns && !now_ns_.compare_exchange_weak(now, t_ns)) {
  }
}

}  // namespace collide::hw
