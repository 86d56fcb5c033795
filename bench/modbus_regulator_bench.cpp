// Modbus regulator: how long a setpoint takes from the call to a confirmed
// read-back (one write and one verifying read: PressureRegulatorModbus::
// setPressureKPa), against the simulated Modbus regulator over loopback TCP
// and over a socat pty pair (RTU, 19200 baud set on the ptys, which do not
// pace bytes like a real line). Reports p50 and p99 per call. Figures and the
// command in docs/benchmarks.md ("## Modbus regulator").
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <vector>

#include "hw/pressure_regulator_modbus.hpp"
#include "tests/hw/modbus_peer.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;

namespace {

void setpointToConfirmedReadback(benchmark::State& state, ModbusTransport transport,
                                 const ModbusRegulatorMap& served) {
  ModbusPeer peer = startModbusPeer(serverOptions(transport, served));
  if (!peer.skip.empty() || !peer.error.empty()) {
    state.SkipWithError((peer.skip + peer.error).c_str());
    return;
  }
  PressureRegulatorModbus reg(peer.client_map, 200.0, peer.client_map.link.endpoint());
  if (!reg.open() || !reg.configure({0.0, 200.0}) || !reg.start()) {
    state.SkipWithError("the regulator did not come up");
    return;
  }
  std::vector<double> us;
  us.reserve(100000);
  int i = 0;
  for (auto _ : state) {
    const double kPa = (i++ % 2) ? 120.0 : 80.0;  // every call changes the setpoint
    const auto t0 = std::chrono::steady_clock::now();
    const collide::Status s = reg.setPressureKPa(0, kPa);
    us.push_back(
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    if (!s) {
      state.SkipWithError(s.error().message.c_str());
      return;
    }
  }
  std::sort(us.begin(), us.end());
  auto pct = [&](double p) { return us[static_cast<std::size_t>(p * (us.size() - 1))]; };
  state.counters["p50_us"] = pct(0.50);
  state.counters["p99_us"] = pct(0.99);
  state.counters["max_us"] = us.back();
  state.counters["reconnects"] = static_cast<double>(reg.linkStats().reconnects);
}

void BM_ModbusSetpoint_Tcp_U16(benchmark::State& state) {
  setpointToConfirmedReadback(state, ModbusTransport::Tcp, ModbusRegulatorMap::generic10Bar());
}
void BM_ModbusSetpoint_Rtu_U16(benchmark::State& state) {
  setpointToConfirmedReadback(state, ModbusTransport::Rtu, ModbusRegulatorMap::generic10Bar());
}
void BM_ModbusSetpoint_Tcp_Float32(benchmark::State& state) {
  ModbusRegulatorMap m = ModbusRegulatorMap::generic10Bar();
  m.setpoint.type = m.readback.type = ModbusValueType::Float32;
  m.setpoint.scale = m.readback.scale = 1.0;
  m.setpoint.addresses = m.readback.addresses = {0, 2};
  m.setpoint.word_order = m.readback.word_order = "CDAB";
  setpointToConfirmedReadback(state, ModbusTransport::Tcp, m);
}

}  // namespace

BENCHMARK(BM_ModbusSetpoint_Tcp_U16)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_ModbusSetpoint_Tcp_Float32)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_ModbusSetpoint_Rtu_U16)->Unit(benchmark::kMicrosecond)->MinTime(2.0);

BENCHMARK_MAIN();
