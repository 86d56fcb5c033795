// `collide sim-regulator`: a simulated pressure regulator behind a real Modbus
// server (TCP or RTU), with the same dynamics as the in-process simulated
// regulator, serving the register map of a rig profile. For trying the Modbus
// backend (and Modbus tools such as mbpoll) without hardware, and for tests.
#include <csignal>
#include <iostream>
#include <sstream>
#include <stop_token>

#include "app/cli/command.hpp"
#include "hw/modbus_regulator_server.hpp"

namespace {

std::stop_source* g_stop = nullptr;
extern "C" void onStopSignal(int) {
  if (g_stop) g_stop->request_stop();  // async-signal-safe: an atomic store
}

struct Options {
  std::string tcp;
  std::string rtu;
  std::string map;
  int unit = -1;
  double time_constant_ms = 10.0;
  double hold_band_kPa = collide::hw::RegulatorSimSettings::kDefaultHoldBandKPa;
  double noise_kPa = 0.05;
  bool leak = false;
  std::uint64_t seed = 1;
  collide::hw::ModbusServerFaults faults;
};

std::string number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string registersText(const collide::hw::ModbusPressureRegisters& r) {
  std::string s = std::string(toString(r.table)) + "s";
  for (std::size_t i = 0; i < r.addresses.size(); ++i)
    s += (i ? ", " : " ") + std::to_string(r.addresses[i]);
  s += " (" + std::string(toString(r.type));
  if (r.width() == 2 || r.word_order != "ABCD") s += " " + r.word_order;
  if (r.type != collide::hw::ModbusValueType::Float32 || r.scale != 1.0)
    s += ", x" + number(r.scale);
  if (r.offset != 0.0) s += " + " + number(r.offset);
  return s + " " + r.unit.name + ")";
}

int run(const Options& o) {
  using namespace collide::hw;
  using collide::Result;
  using collide::Status;
  auto bad = [](const std::string& m) {
    std::cerr << "collide sim-regulator: " << m << "\n";
    return collide::cli::kExitBadInput;
  };
  ModbusServerOptions s;
  std::string map_name = "built-in generic 0-10 bar map";
  s.map = ModbusRegulatorMap::generic10Bar();
  if (!o.map.empty()) {
    Result<RigProfile> profile = loadRigProfile(o.map);
    if (!profile) return bad(profile.error().message);
    Result<ModbusRegulatorMap> map = ModbusRegulatorMap::fromProfile(*profile);
    if (!map) return bad(map.error().message);
    s.map = *map;
    map_name = "map of " + o.map;
  }
  if (!o.tcp.empty()) {
    s.transport = ModbusTransport::Tcp;
    const auto colon = o.tcp.rfind(':');
    if (colon == std::string::npos || colon == 0)
      return bad("--tcp " + o.tcp + ": write HOST:PORT, e.g. 127.0.0.1:1502");
    s.host = o.tcp.substr(0, colon);
    try {
      std::size_t used = 0;
      s.port = std::stoi(o.tcp.substr(colon + 1), &used);
      if (used != o.tcp.size() - colon - 1 || s.port < 0 || s.port > 65535) throw 0;
    } catch (...) {
      return bad("--tcp " + o.tcp + ": the port must be a number 0..65535 (0: any free port)");
    }
  } else {
    s.transport = ModbusTransport::Rtu;
    s.serial_port = o.rtu;
  }
  s.unit_id = o.unit >= 0 ? o.unit : s.map.link.unit_id;
  s.dynamics.channels = s.map.channels;
  s.dynamics.time_constant_s = o.time_constant_ms * 1e-3;
  s.dynamics.hold_band_kPa = o.hold_band_kPa;
  s.dynamics.noise_kPa = o.noise_kPa;
  s.dynamics.fault =
      o.leak ? RegulatorSimSettings::Fault::NeverSettles : RegulatorSimSettings::Fault::None;
  s.dynamics.device_min_kPa = s.map.device_min_kPa;
  s.dynamics.device_max_kPa = s.map.device_max_kPa;
  s.seed = o.seed;
  s.faults = o.faults;

  Result<std::unique_ptr<ModbusRegulatorServer>> server = ModbusRegulatorServer::create(s, nullptr);
  if (!server) return bad(server.error().message);
  std::cout << "collide sim-regulator: serving a simulated regulator as "
            << (s.transport == ModbusTransport::Tcp ? "Modbus TCP on " : "Modbus RTU on ")
            << (*server)->endpoint() << ", unit " << s.unit_id << "\n"
            << "  " << s.map.channels << " channels, " << s.map.device_min_kPa << ".."
            << s.map.device_max_kPa << " kPa, time constant " << o.time_constant_ms << " ms, noise "
            << o.noise_kPa << " kPa" << (o.leak ? ", leaking" : "") << "\n"
            << "  " << map_name << "\n"
            << "  setpoints: " << registersText(s.map.setpoint) << "\n"
            << "  measured:  " << registersText(s.map.readback) << "\n"
            << "Ctrl-C stops." << std::endl;
  std::stop_source stop;
  g_stop = &stop;
  std::signal(SIGINT, onStopSignal);
  std::signal(SIGTERM, onStopSignal);
  Status served = (*server)->serve(stop.get_token());
  g_stop = nullptr;
  const ModbusServerStats st = (*server)->stats();
  std::cout << "collide sim-regulator: stopped after " << st.requests << " requests ("
            << st.answered << " answered, " << st.exceptions << " exceptions, " << st.ignored
            << " for other unit ids, " << st.dropped_links << " links dropped)" << std::endl;
  if (!served) {
    std::cerr << "collide sim-regulator: " << served.error().message << "\n";
    return collide::cli::kExitFailure;
  }
  return collide::cli::kExitOk;
}

void setupSimRegulator(CLI::App& sub, std::function<int()>& run_command) {
  auto o = std::make_shared<Options>();
  auto* tcp =
      sub.add_option("--tcp", o->tcp, "Serve Modbus TCP on HOST:PORT (port 0: any free one)");
  auto* rtu = sub.add_option("--rtu", o->rtu,
                             "Serve Modbus RTU on this serial port, e.g. /dev/pts/N (one end of a "
                             "socat pty pair)");
  tcp->excludes(rtu);
  rtu->excludes(tcp);
  sub.add_option("--map", o->map,
                 "Rig profile whose [regulator] (backend \"modbus\") gives the register map, "
                 "range and serial settings (default: a generic 0-10 bar map, as in "
                 "config/regulator-generic-10bar.toml)");
  sub.add_option("--unit", o->unit, "Unit id served (default: the map's unit_id)")
      ->check(CLI::Range(0, 255));
  sub.add_option("--time-constant-ms", o->time_constant_ms,
                 "First-order response of each line to a new setpoint, ms")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub.add_option("--hold-band-kpa", o->hold_band_kPa,
                 "Within this of the setpoint the line is held at it, kPa (0: a pure "
                 "first-order approach that never quite arrives)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub.add_option("--noise-kpa", o->noise_kPa, "Read-back noise, std dev, kPa")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub.add_flag("--leak", o->leak, "The lines leak: a rise stalls at 80 %, never settling");
  sub.add_option("--seed", o->seed, "Seed of the read-back noise");
  auto* faults = sub.add_option_group("Faults", "Misbehave, to test a client's failure paths");
  faults->add_option("--delay-ms", o->faults.delay_ms, "Answer every request this late")
      ->check(CLI::NonNegativeNumber);
  faults
      ->add_option("--exception", o->faults.exception_code,
                   "Answer every request with this Modbus exception code (1..11)")
      ->check(CLI::Range(1, 11));
  faults
      ->add_option("--drop-every", o->faults.drop_every,
                   "Drop the link instead of answering every Nth request (TCP: close the "
                   "connection; RTU: close the port briefly)")
      ->check(CLI::PositiveNumber);
  faults->add_flag("--wrong-unit-reply", o->faults.wrong_unit_reply,
                   "Answer as unit id + 1 (libmodbus detects it on RTU only)");
  faults->add_flag("--ignore-writes", o->faults.ignore_writes,
                   "Acknowledge setpoint writes but keep the old value (a device in local mode)");
  sub.footer(
      "Each channel follows the same first-order dynamics as the simulated regulator of\n"
      "config/sim.toml. A pty pair for RTU: socat -d -d pty,raw,echo=0 pty,raw,echo=0\n"
      "(serve on one end, point regulator.device at the other).");
  run_command = [o] {
    if (o->tcp.empty() == o->rtu.empty()) {
      std::cerr << "collide sim-regulator: give --tcp HOST:PORT or --rtu /dev/pts/N\n";
      return collide::cli::kExitBadInput;
    }
    return run(*o);
  };
}

}  // namespace

// The name has a dash, so the macro's argument must stay one token sequence
// without spaces ("sim-regulator", not "sim - regulator").
// clang-format off
COLLIDE_COMMAND(sim-regulator,
                "Serve a simulated pressure regulator over Modbus TCP or RTU (--tcp | --rtu)",
                setupSimRegulator);
// clang-format on
