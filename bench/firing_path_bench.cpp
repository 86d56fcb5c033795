// Firing path timing on the host: programmed against achieved delay between
// two valve edges. The host has no GPIO chip, so this measures ValveBankGpiod
// itself (edge scheduling with clock_nanosleep(CLOCK_MONOTONIC,
// TIMER_ABSTIME), pattern anchoring, the watchdog running alongside) driving a
// RecordingValveLines, which stamps CLOCK_MONOTONIC when each line changes.
// A real line adds one GPIO ioctl per edge (tens of microseconds), measured
// from the kernel's side in the VM test (tests/vm/gpiod_vm_test.cpp).
//
// Each iteration fires valve 0 at t0 = now + 2 ms and valve 1 at t0 + delay,
// 500 us pulses, and records:
//   delay_err  = (valve 1 opened - valve 0 opened) - programmed delay
//   open_late  = valve 0 opened - t0 (wake-up latency of the firing thread)
//   width_err  = (valve closed - valve opened) - 500 us, both valves
// Counters are percentiles over the iterations, in microseconds. The last case
// fires at SCHED_FIFO priority 50 (valves.realtime_priority; skipped where the
// process may not).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <memory>
#include <vector>

#include "hw/clock.hpp"
#include "hw/valve_bank_gpiod.hpp"
#include "hw/valve_lines.hpp"

using namespace collide::hw;

namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5)];
}

// range(0): programmed delay, us; range(1): SCHED_FIFO priority (0: normal).
void BM_FiringPathDelay(benchmark::State& state) {
  const std::int64_t delay_us = state.range(0);
  const int priority = static_cast<int>(state.range(1));
  constexpr std::int64_t kPulseUs = 500;
  RecordingValveLines* lines = nullptr;
  ValveBankGpiod bank("bench", 2, [&]() -> collide::Result<std::unique_ptr<ValveLines>> {
    auto l = std::make_unique<RecordingValveLines>(2);
    lines = l.get();
    return std::unique_ptr<ValveLines>(std::move(l));
  });
  bank.setRealtimePriority(priority);
  if (!bank.open() || !bank.configure({50000})) {
    state.SkipWithError("cannot bring the valve bank up");
    return;
  }
  if (const auto started = bank.start(); !started) {
    state.SkipWithError(started.error().message.c_str());
    return;
  }
  std::vector<double> delay_err, open_late, width_err;
  for (auto _ : state) {
    lines->clearEdges();
    const std::int64_t t0 = monotonicNowNs() + 2'000'000;
    const auto events = bank.fire({{0, t0, kPulseUs}, {1, t0 + delay_us * 1000, kPulseUs}});
    if (!events) {
      state.SkipWithError(events.error().message.c_str());
      return;
    }
    std::int64_t open[2] = {0, 0}, close[2] = {0, 0};
    for (const auto& e : lines->edges()) (e.active ? open : close)[e.line] = e.t_ns;
    delay_err.push_back(static_cast<double>(open[1] - open[0] - delay_us * 1000) / 1e3);
    open_late.push_back(static_cast<double>(open[0] - t0) / 1e3);
    for (int v = 0; v < 2; ++v)
      width_err.push_back(static_cast<double>(close[v] - open[v] - kPulseUs * 1000) / 1e3);
  }
  state.counters["delay_err_p50_us"] = percentile(delay_err, 0.50);
  state.counters["delay_err_p99_us"] = percentile(delay_err, 0.99);
  state.counters["delay_err_max_us"] = percentile(delay_err, 1.0);
  state.counters["open_late_p50_us"] = percentile(open_late, 0.50);
  state.counters["open_late_p99_us"] = percentile(open_late, 0.99);
  state.counters["width_err_p50_us"] = percentile(width_err, 0.50);
  state.counters["width_err_p99_us"] = percentile(width_err, 0.99);
}

}  // namespace

BENCHMARK(BM_FiringPathDelay)
    ->ArgNames({"delay_us", "rt_priority"})
    ->Args({1000, 0})
    ->Args({3000, 0})
    ->Args({10000, 0})
    ->Args({3000, 50})
    ->Iterations(300)
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
