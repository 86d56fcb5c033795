#pragma once
// ModbusRegulatorServer: a simulated pressure regulator behind a real Modbus
// server (libmodbus), over TCP or RTU, serving a register map read from a rig
// profile (modbus_map.hpp). Each channel's pressure follows the same
// first-order dynamics as the in-process simulated regulator (PressureLine,
// with its time constant, read-back noise and optional leak); a setpoint
// written to its holding register(s) is the new target, and the read-back
// registers report the line's pressure at the instant they are read.
// `collide sim-regulator` runs one; the Modbus backend's peer tests and the
// benchmark run one in a thread.
//
// Fault knobs, so that every failure path of a client can be exercised:
// answers delayed past a timeout, requests for another unit id going
// unanswered (as on a shared line), answers sent from another unit id, every
// request answered with a Modbus exception, the link dropped every N
// requests, setpoint writes acknowledged but not taken (local mode).
//
// Threads: construct, then serve() on one thread; stop it from any other
// thread through the stop_token; the read-only accessors from any thread.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <random>
#include <stop_token>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "hw/clock.hpp"
#include "hw/modbus_map.hpp"
#include "hw/pressure_line.hpp"
#include "hw/pressure_regulator_sim.hpp"

struct _modbus;
struct _modbus_mapping_t;

namespace collide::hw {

struct ModbusServerFaults {
  int delay_ms = 0;        ///< answer each request this late (0: at once)
  int exception_code = 0;  ///< answer every request with this Modbus exception (0: none)
  int drop_every = 0;      ///< drop the link instead of answering every Nth request (0: never)
  bool wrong_unit_reply = false;  ///< answer as unit id + 1
  bool ignore_writes = false;     ///< acknowledge setpoint writes but keep the old value
};

struct ModbusServerOptions {
  /// The register map, channels and device range served (the link part of
  /// it is ignored except the serial settings in RTU).
  ModbusRegulatorMap map;
  ModbusTransport transport = ModbusTransport::Tcp;
  std::string host = "127.0.0.1";  ///< TCP: listen address
  int port = 1502;                 ///< TCP: 0 picks a free port (see endpoint())
  std::string serial_port;         ///< RTU: the tty to serve on, e.g. one end of a socat pty pair
  int unit_id = 1;                 ///< the unit id served; requests for others get no answer
  /// The dynamics: time constant, read-back noise, leak (fault "never_settles").
  RegulatorSimSettings dynamics;
  std::uint64_t seed = 1;  ///< of the read-back noise
  ModbusServerFaults faults;
};

struct ModbusServerStats {
  std::int64_t requests = 0;       ///< requests received (for any unit)
  std::int64_t answered = 0;       ///< normal answers sent
  std::int64_t exceptions = 0;     ///< exception answers sent
  std::int64_t ignored = 0;        ///< requests for another unit id
  std::int64_t dropped_links = 0;  ///< links dropped by the fault knob
  std::int64_t connections = 0;    ///< TCP connections accepted
};

class ModbusRegulatorServer {
 public:
  /// Binds the TCP port (listening) or opens the serial port. Errors: the
  /// port in use or the tty missing, with what to do.
  static Result<std::unique_ptr<ModbusRegulatorServer>> create(ModbusServerOptions options,
                                                               std::shared_ptr<Clock> clock);
  ~ModbusRegulatorServer();
  ModbusRegulatorServer(const ModbusRegulatorServer&) = delete;
  ModbusRegulatorServer& operator=(const ModbusRegulatorServer&) = delete;

  /// Answers requests until `stop` is requested (checked every 20 ms).
  /// Returns an error only if the server itself fails (e.g. the tty went away
  /// for good). One thread.
  Status serve(std::stop_token stop);

  /// "127.0.0.1:40123" (the port actually bound) or the tty path.
  std::string endpoint() const;
  int port() const { return port_; }
  const ModbusServerOptions& options() const { return options_; }
  /// Changes the fault knobs from the next request on. Any thread.
  void setFaults(const ModbusServerFaults& faults);
  ModbusServerStats stats() const;
  /// The simulated line's true pressure now (no noise), kPa. Any thread.
  double linePressureKPa(int channel) const;
  /// The setpoint the server last accepted on `channel`, kPa. Any thread.
  double setpointKPa(int channel) const;

 private:
  ModbusRegulatorServer(ModbusServerOptions options, std::shared_ptr<Clock> clock);
  Status setUp();
  Status serveTcp(std::stop_token& stop);
  Status serveRtu(std::stop_token& stop);
  /// Handles one request of `length` bytes; false if the link must be dropped.
  bool handle(std::uint8_t* request, int length);
  void refreshReadback();
  void takeSetpoints();
  bool writeIsValid(const std::uint8_t* request, int length) const;
  std::uint16_t* registerAt(ModbusTable table, int address) const;

  ModbusServerOptions options_;
  std::shared_ptr<Clock> clock_;
  _modbus* ctx_ = nullptr;
  _modbus_mapping_t* mapping_ = nullptr;
  int listen_fd_ = -1;
  int port_ = 0;
  int holding_start_ = 0, holding_count_ = 0, input_start_ = 0, input_count_ = 0;
  std::int64_t on_link_ = 0;  // requests on the current link, for drop_every

  mutable std::mutex mutex_;  // guards options_.faults, lines_, setpoints_kPa_, stats_
  std::vector<PressureLine> lines_;
  std::vector<double> setpoints_kPa_;
  ModbusServerStats stats_;
  std::mt19937_64 rng_;
};

}  // namespace collide::hw
