#include "hw/valve_lines.hpp"

#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "hw/clock.hpp"

namespace collide::hw {

RecordingValveLines::RecordingValveLines(int count)
    : level_(static_cast<std::size_t>(count < 1 ? 1 : count)) {}

std::string RecordingValveLines::describe(int line) const {
  return "recording line " + std::to_string(line);
}

Status RecordingValveLines::set(int line, bool active) {
  calls_.fetch_add(1);
  if (unplugged_.load())
    return fail("cannot drive " + describe(line) + (active ? " active" : " inactive") + " (" +
                std::strerror(ENODEV) + ")");
  Fault fault;
  {
    std::lock_guard lock(mutex_);
    if (fault_.line == line && fault_.active == active) {
      fault = fault_;
      fault_ = Fault{};
    }
  }
  if (fault.stall_ns > 0) {
    const timespec ts{static_cast<time_t>(fault.stall_ns / 1'000'000'000),
                      static_cast<long>(fault.stall_ns % 1'000'000'000)};
    nanosleep(&ts, nullptr);
  }
  if (fault.fail) return fail(describe(line) + ": the driver refused the edge (injected fault)");
  const std::int64_t t = monotonicNowNs();
  level_[static_cast<std::size_t>(line)].store(active);
  std::lock_guard lock(mutex_);
  edges_.push_back({line, active, t});
  return Ok{};
}

std::optional<std::string> RecordingValveLines::gone() const {
  if (!unplugged_.load()) return std::nullopt;
  return "its GPIO chip went away (" + std::string(std::strerror(ENODEV)) + ")";
}

bool RecordingValveLines::setAllInactiveFromSignal() noexcept {
  if (unplugged_.load()) return false;
  for (auto& l : level_) l.store(false);
  if (signal_fd_ >= 0 && signal_message_) {
    const ssize_t n = write(signal_fd_, signal_message_, std::strlen(signal_message_));
    (void)n;
  }
  return true;
}

std::vector<RecordingValveLines::Edge> RecordingValveLines::edges() const {
  std::lock_guard lock(mutex_);
  return edges_;
}

void RecordingValveLines::clearEdges() {
  std::lock_guard lock(mutex_);
  edges_.clear();
}

void RecordingValveLines::injectFault(int line, bool active, std::int64_t stall_ns, bool fail) {
  std::lock_guard lock(mutex_);
  fault_ = {line, active, stall_ns, fail};
}

}  // namespace collide::hw
