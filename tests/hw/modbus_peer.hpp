#pragma once
// Test (and benchmark) helpers for the Modbus regulator: a socat pty pair
// for RTU, a ModbusRegulatorServer serving on its own thread, and the two put
// together with a client map that points at the server. Used by
// pressure_regulator_modbus_peer_test.cpp and bench/modbus_regulator_bench.cpp.
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <thread>

#include "hw/modbus_map.hpp"
#include "hw/modbus_regulator_server.hpp"

namespace collide::hw::testing {

/// The full path of `program` on PATH, or "".
inline std::string findProgram(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "/usr/bin:/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const std::string candidate = dir + "/" + program;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return "";
}

/// Two linked ptys from `socat pty,raw,echo=0 pty,raw,echo=0`: what one end
/// writes, the other reads, like a null-modem cable. Stopped on destruction.
class SocatPtyPair {
 public:
  /// Why RTU tests cannot run here ("" if socat is installed).
  static std::string missing() {
    return findProgram("socat").empty()
               ? "socat is not installed (Debian package socat): the RTU tests need a pty pair"
               : "";
  }

  SocatPtyPair() {
    char dir_template[] = "/tmp/collide-pty-XXXXXX";
    if (!::mkdtemp(dir_template)) {
      error_ = "mkdtemp failed";
      return;
    }
    dir_ = dir_template;
    const std::string a = "pty,raw,echo=0,link=" + dir_ + "/a";
    const std::string b = "pty,raw,echo=0,link=" + dir_ + "/b";
    pid_ = ::fork();
    if (pid_ == 0) {
      const int null_fd = ::open("/dev/null", O_WRONLY);
      ::dup2(null_fd, STDOUT_FILENO);
      ::dup2(null_fd, STDERR_FILENO);
      ::execlp("socat", "socat", a.c_str(), b.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (std::chrono::steady_clock::now() < deadline) {
      std::error_code ec;
      if (std::filesystem::exists(dir_ + "/a", ec) && std::filesystem::exists(dir_ + "/b", ec)) {
        a_ = std::filesystem::read_symlink(dir_ + "/a", ec).string();
        b_ = std::filesystem::read_symlink(dir_ + "/b", ec).string();
        if (!a_.empty() && !b_.empty()) return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    error_ = "socat did not create its pty pair within 5 s";
  }
  ~SocatPtyPair() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
    if (!dir_.empty()) {
      std::error_code ec;
      std::filesystem::remove_all(dir_, ec);
    }
  }
  SocatPtyPair(const SocatPtyPair&) = delete;
  SocatPtyPair& operator=(const SocatPtyPair&) = delete;

  const std::string& error() const { return error_; }
  /// The two ends, e.g. "/dev/pts/5" and "/dev/pts/6".
  const std::string& a() const { return a_; }
  const std::string& b() const { return b_; }

 private:
  pid_t pid_ = -1;
  std::string dir_, a_, b_, error_;
};

/// A server answering on its own thread until destroyed.
struct ServerThread {
  explicit ServerThread(std::unique_ptr<ModbusRegulatorServer> s)
      : server(std::move(s)),
        thread([this](std::stop_token stop) { result = server->serve(stop); }) {}
  std::unique_ptr<ModbusRegulatorServer> server;
  Status result = Ok{};
  std::jthread thread;  // declared last: joined before the server goes
};

/// A simulated Modbus regulator to test a client against.
struct ModbusPeer {
  std::unique_ptr<SocatPtyPair> pty;  // RTU only
  std::unique_ptr<ServerThread> server;
  /// The served map with its link pointing at the server (TCP: its port; RTU:
  /// the pty's other end), unit id and a 200 ms timeout.
  ModbusRegulatorMap client_map;
  std::string skip;   // the peer cannot run here (socat missing): skip with this
  std::string error;  // the peer failed to start: a test failure

  ModbusRegulatorServer& srv() { return *server->server; }
};

/// Starts a server for `options` (its transport decides TCP on 127.0.0.1 with
/// a free port, or RTU on a fresh socat pty pair).
inline ModbusPeer startModbusPeer(ModbusServerOptions options) {
  ModbusPeer p;
  p.client_map = options.map;
  ModbusLinkSettings& link = p.client_map.link;
  link.transport = options.transport;
  link.unit_id = options.unit_id;
  link.timeout_ms = 200;
  if (options.transport == ModbusTransport::Tcp) {
    options.host = "127.0.0.1";
    options.port = 0;
  } else {
    p.skip = SocatPtyPair::missing();
    if (!p.skip.empty()) return p;
    p.pty = std::make_unique<SocatPtyPair>();
    if (!p.pty->error().empty()) {
      p.error = p.pty->error();
      return p;
    }
    options.serial_port = p.pty->a();
    link.serial_port = p.pty->b();
  }
  Result<std::unique_ptr<ModbusRegulatorServer>> s =
      ModbusRegulatorServer::create(std::move(options), nullptr);
  if (!s) {
    p.error = s.error().message;
    return p;
  }
  if (link.transport == ModbusTransport::Tcp) {
    link.host = "127.0.0.1";
    link.port = (*s)->port();
  }
  p.server = std::make_unique<ServerThread>(std::move(*s));
  return p;
}

/// Server options for `map` with the sim regulator's dynamics (10 ms, noise
/// 0.05 kPa, as config/sim.toml).
inline ModbusServerOptions serverOptions(ModbusTransport transport, ModbusRegulatorMap map) {
  ModbusServerOptions o;
  o.transport = transport;
  o.map = std::move(map);
  o.unit_id = 1;
  o.dynamics.channels = o.map.channels;
  o.dynamics.time_constant_s = 0.01;
  o.dynamics.noise_kPa = 0.05;
  return o;
}

}  // namespace collide::hw::testing
