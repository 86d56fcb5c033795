#include "hw/modbus_regulator_server.hpp"

#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <map>
#include <thread>
#include <tuple>

#include "hw/format.hpp"
#include "hw/try.hpp"

namespace collide::hw {

namespace {

constexpr int kPollMs = 20;

std::pair<int, int> span(const std::vector<int>& addresses, int width) {
  const auto [lo, hi] = std::minmax_element(addresses.begin(), addresses.end());
  return {*lo, *hi + width};
}

}  // namespace

ModbusRegulatorServer::ModbusRegulatorServer(ModbusServerOptions options,
                                             std::shared_ptr<Clock> clock)
    : options_(std::move(options)), clock_(std::move(clock)), rng_(options_.seed) {}

ModbusRegulatorServer::~ModbusRegulatorServer() {
  if (listen_fd_ >= 0) ::close(listen_fd_);
  if (ctx_) {
    if (options_.transport == ModbusTransport::Rtu) modbus_close(ctx_);
    modbus_free(ctx_);
  }
  if (mapping_) modbus_mapping_free(mapping_);
}

Result<std::unique_ptr<ModbusRegulatorServer>> ModbusRegulatorServer::create(
    ModbusServerOptions options, std::shared_ptr<Clock> clock) {
  std::unique_ptr<ModbusRegulatorServer> s(
      new ModbusRegulatorServer(std::move(options), clock ? std::move(clock) : monotonicClock()));
  COLLIDE_RETURN_IF_ERROR(s->setUp());
  return s;
}

Status ModbusRegulatorServer::setUp() {
  const ModbusRegulatorMap& m = options_.map;
  if (options_.unit_id < 0 || options_.unit_id > 255 ||
      (options_.transport == ModbusTransport::Rtu && options_.unit_id < 1))
    return fail("unit id " + std::to_string(options_.unit_id) +
                " is not valid (TCP 0..255, RTU 1..247)");

  // The registers the map names, and nothing else: any other address gets
  // the "illegal data address" exception a real device would send.
  auto [h_lo, h_hi] = span(m.setpoint.addresses, m.setpoint.width());
  int i_lo = 0, i_hi = 0;
  if (m.readback.table == ModbusTable::Holding) {
    const auto [lo, hi] = span(m.readback.addresses, m.readback.width());
    h_lo = std::min(h_lo, lo);
    h_hi = std::max(h_hi, hi);
  } else {
    std::tie(i_lo, i_hi) = span(m.readback.addresses, m.readback.width());
  }
  holding_start_ = h_lo;
  holding_count_ = h_hi - h_lo;
  input_start_ = i_lo;
  input_count_ = i_hi - i_lo;
  mapping_ = modbus_mapping_new_start_address(0, 0, 0, 0, holding_start_, holding_count_,
                                              input_start_, input_count_);
  if (!mapping_)
    return fail(std::string("cannot allocate the register map: ") + std::strerror(errno));

  // Every line starts vented; the setpoint registers say so.
  const std::int64_t now = clock_->nowNs();
  lines_.assign(static_cast<std::size_t>(m.channels), PressureLine{});
  setpoints_kPa_.assign(static_cast<std::size_t>(m.channels), 0.0);
  const double start_kPa = std::clamp(0.0, m.device_min_kPa, m.device_max_kPa);
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<std::uint16_t> start, m.setpoint.encode(start_kPa));
  for (int ch = 0; ch < m.channels; ++ch) {
    PressureLine& line = lines_[static_cast<std::size_t>(ch)];
    line.setModel(options_.dynamics.lineModel(), now);
    line.command(start_kPa, now);
    setpoints_kPa_[static_cast<std::size_t>(ch)] = start_kPa;
    std::copy(start.begin(), start.end(),
              registerAt(ModbusTable::Holding, m.setpoint.addresses[static_cast<std::size_t>(ch)]));
  }
  refreshReadback();

  if (options_.transport == ModbusTransport::Tcp) {
    ctx_ = modbus_new_tcp(options_.host.c_str(), options_.port);
    if (!ctx_)
      return fail("cannot serve Modbus TCP on " + options_.host + ":" +
                  std::to_string(options_.port) + ": " + std::strerror(errno));
    listen_fd_ = modbus_tcp_listen(ctx_, 8);
    if (listen_fd_ < 0)
      return fail("cannot listen on " + options_.host + ":" + std::to_string(options_.port) + " (" +
                  modbus_strerror(errno) +
                  "): choose a free port (e.g. --tcp 127.0.0.1:1502) and an address of this "
                  "machine; ports below 1024 need root");
    sockaddr_in addr{};
    socklen_t len = sizeof addr;
    getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
  } else {
    const ModbusLinkSettings& l = m.link;
    ctx_ = modbus_new_rtu(options_.serial_port.c_str(), l.baud, l.parity, l.data_bits, l.stop_bits);
    if (!ctx_)
      return fail("cannot serve Modbus RTU on " + options_.serial_port + ": " +
                  std::strerror(errno));
    modbus_set_slave(ctx_, options_.unit_id);
    if (modbus_connect(ctx_) != 0)
      return fail("cannot open " + options_.serial_port + " (" + modbus_strerror(errno) +
                  "): give a serial port or one end of a pty pair, e.g. from `socat -d -d "
                  "pty,raw,echo=0 pty,raw,echo=0`");
  }
  return Ok{};
}

std::string ModbusRegulatorServer::endpoint() const {
  return options_.transport == ModbusTransport::Tcp ? options_.host + ":" + std::to_string(port_)
                                                    : options_.serial_port;
}

void ModbusRegulatorServer::setFaults(const ModbusServerFaults& faults) {
  std::lock_guard lock(mutex_);
  options_.faults = faults;
}

ModbusServerStats ModbusRegulatorServer::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

double ModbusRegulatorServer::linePressureKPa(int channel) const {
  std::lock_guard lock(mutex_);
  return lines_.at(static_cast<std::size_t>(channel)).pressureKPa(clock_->nowNs());
}

double ModbusRegulatorServer::setpointKPa(int channel) const {
  std::lock_guard lock(mutex_);
  return setpoints_kPa_.at(static_cast<std::size_t>(channel));
}

std::uint16_t* ModbusRegulatorServer::registerAt(ModbusTable table, int address) const {
  return table == ModbusTable::Holding ? mapping_->tab_registers + (address - holding_start_)
                                       : mapping_->tab_input_registers + (address - input_start_);
}

// Called with mutex_ held.
void ModbusRegulatorServer::refreshReadback() {
  const ModbusRegulatorMap& m = options_.map;
  const std::int64_t now = clock_->nowNs();
  const double noise = options_.dynamics.noise_kPa;
  for (int ch = 0; ch < m.channels; ++ch) {
    double p = lines_[static_cast<std::size_t>(ch)].pressureKPa(now);
    if (noise > 0) p += std::normal_distribution<double>(0.0, noise)(rng_);
    // A sensor reads within its range: noise around 0 kPa does not go negative
    // in an unsigned register.
    Result<std::vector<std::uint16_t>> w = m.readback.encode(p);
    if (!w) w = m.readback.encode(std::clamp(p, m.device_min_kPa, m.device_max_kPa));
    if (w)
      std::copy(w->begin(), w->end(),
                registerAt(m.readback.table, m.readback.addresses[static_cast<std::size_t>(ch)]));
  }
}

// Called with mutex_ held, after a request has been applied to the map.
void ModbusRegulatorServer::takeSetpoints() {
  const ModbusRegulatorMap& m = options_.map;
  const std::int64_t now = clock_->nowNs();
  for (int ch = 0; ch < m.channels; ++ch) {
    const double kPa = m.setpoint.decode(
        registerAt(ModbusTable::Holding, m.setpoint.addresses[static_cast<std::size_t>(ch)]));
    double& current = setpoints_kPa_[static_cast<std::size_t>(ch)];
    if (kPa != current) {
      lines_[static_cast<std::size_t>(ch)].command(kPa, now);
      current = kPa;
    }
  }
}

// A write that would leave a setpoint outside the device's range is refused
// with "illegal data value", as a real regulator does.
bool ModbusRegulatorServer::writeIsValid(const std::uint8_t* q, int length) const {
  const int hl = modbus_get_header_length(ctx_);
  const int fn = q[hl];
  int address = 0;
  std::vector<std::uint16_t> values;
  if (fn == MODBUS_FC_WRITE_SINGLE_REGISTER && length >= hl + 5) {
    address = (q[hl + 1] << 8) | q[hl + 2];
    values.push_back(static_cast<std::uint16_t>((q[hl + 3] << 8) | q[hl + 4]));
  } else if (fn == MODBUS_FC_WRITE_MULTIPLE_REGISTERS && length >= hl + 6) {
    address = (q[hl + 1] << 8) | q[hl + 2];
    const int n = (q[hl + 3] << 8) | q[hl + 4];
    if (length < hl + 6 + 2 * n) return true;  // malformed: libmodbus answers it
    for (int i = 0; i < n; ++i)
      values.push_back(static_cast<std::uint16_t>((q[hl + 6 + 2 * i] << 8) | q[hl + 7 + 2 * i]));
  } else {
    return true;
  }
  const ModbusRegulatorMap& m = options_.map;
  const int width = m.setpoint.width();
  for (int ch = 0; ch < m.channels; ++ch) {
    const int a = m.setpoint.addresses[static_cast<std::size_t>(ch)];
    if (address >= a + width || address + static_cast<int>(values.size()) <= a) continue;
    if (address < holding_start_ ||
        address + static_cast<int>(values.size()) > holding_start_ + holding_count_)
      return true;  // partly outside the map: libmodbus answers "illegal data address"
    std::uint16_t words[2];
    std::copy_n(registerAt(ModbusTable::Holding, a), width, words);
    for (int i = 0; i < width; ++i)
      if (a + i >= address && a + i < address + static_cast<int>(values.size()))
        words[i] = values[static_cast<std::size_t>(a + i - address)];
    const double kPa = m.setpoint.decode(words);
    if (!(kPa >= m.device_min_kPa && kPa <= m.device_max_kPa)) return false;
  }
  return true;
}

bool ModbusRegulatorServer::handle(std::uint8_t* q, int length) {
  const int hl = modbus_get_header_length(ctx_);
  const int unit = q[hl - 1];
  ModbusServerFaults f;
  {
    std::lock_guard lock(mutex_);
    f = options_.faults;
    ++stats_.requests;
    // RTU: libmodbus has already left other units' requests unanswered. TCP:
    // do the same, as a device on a shared line (or behind a gateway) would.
    if (options_.transport == ModbusTransport::Tcp && unit != options_.unit_id) {
      ++stats_.ignored;
      return true;
    }
  }
  if (f.drop_every > 0 && ++on_link_ % f.drop_every == 0) {
    std::lock_guard lock(mutex_);
    ++stats_.dropped_links;
    return false;
  }
  if (f.delay_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(f.delay_ms));
  if (f.exception_code > 0) {
    modbus_reply_exception(ctx_, q, static_cast<unsigned>(f.exception_code));
    std::lock_guard lock(mutex_);
    ++stats_.exceptions;
    return true;
  }
  if (f.wrong_unit_reply) q[hl - 1] = static_cast<std::uint8_t>(unit + 1);

  std::lock_guard lock(mutex_);
  refreshReadback();
  if (!writeIsValid(q, length)) {
    modbus_reply_exception(ctx_, q, MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
    ++stats_.exceptions;
    return true;
  }
  std::vector<std::uint16_t> before;
  if (f.ignore_writes && holding_count_ > 0)
    before.assign(mapping_->tab_registers, mapping_->tab_registers + holding_count_);
  const int rc = modbus_reply(ctx_, q, length, mapping_);
  if (f.ignore_writes && holding_count_ > 0)
    std::copy(before.begin(), before.end(), mapping_->tab_registers);
  else
    takeSetpoints();
  if (rc < 0) return false;  // the answer could not be sent: the link is gone
  ++stats_.answered;
  return true;
}

Status ModbusRegulatorServer::serve(std::stop_token stop) {
  return options_.transport == ModbusTransport::Tcp ? serveTcp(stop) : serveRtu(stop);
}

Status ModbusRegulatorServer::serveTcp(std::stop_token& stop) {
  std::map<int, std::int64_t> clients;  // socket -> requests on it
  std::uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
  auto drop = [&](int fd) {
    ::close(fd);
    clients.erase(fd);
  };
  while (!stop.stop_requested()) {
    std::vector<pollfd> fds{{listen_fd_, POLLIN, 0}};
    for (const auto& [fd, n] : clients) fds.push_back({fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), kPollMs) < 0) {
      if (errno == EINTR) continue;
      return fail(std::string("poll failed: ") + std::strerror(errno));
    }
    if (fds[0].revents & POLLIN) {
      const int fd = ::accept(listen_fd_, nullptr, nullptr);
      if (fd >= 0) {
        clients[fd] = 0;
        std::lock_guard lock(mutex_);
        ++stats_.connections;
      }
    }
    for (std::size_t i = 1; i < fds.size(); ++i) {
      if (!fds[i].revents) continue;
      const int fd = fds[i].fd;
      modbus_set_socket(ctx_, fd);
      const int rc = modbus_receive(ctx_, query);
      if (rc < 0) {
        drop(fd);  // the client went away (or sent garbage)
        continue;
      }
      if (rc == 0) continue;
      on_link_ = clients[fd];
      const bool keep = handle(query, rc);
      clients[fd] = on_link_;
      if (!keep) drop(fd);
    }
    modbus_set_socket(ctx_, -1);
  }
  for (const auto& [fd, n] : clients) ::close(fd);
  return Ok{};
}

Status ModbusRegulatorServer::serveRtu(std::stop_token& stop) {
  std::uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
  while (!stop.stop_requested()) {
    pollfd p{modbus_get_socket(ctx_), POLLIN, 0};
    if (::poll(&p, 1, kPollMs) < 0) {
      if (errno == EINTR) continue;
      return fail(std::string("poll failed: ") + std::strerror(errno));
    }
    if (p.revents & (POLLERR | POLLNVAL))
      return fail("the serial port " + options_.serial_port + " failed");
    if (p.revents & POLLHUP) {
      // The other end of a pty pair is gone for the moment: wait for it.
      std::this_thread::sleep_for(std::chrono::milliseconds(kPollMs));
      continue;
    }
    if (!(p.revents & POLLIN)) continue;
    const int rc = modbus_receive(ctx_, query);
    if (rc == 0) {  // for another unit id: libmodbus left it unanswered
      std::lock_guard lock(mutex_);
      ++stats_.requests;
      ++stats_.ignored;
      continue;
    }
    if (rc < 0) {  // a broken frame (bad CRC, cut short): wait for the next one
      modbus_flush(ctx_);
      continue;
    }
    if (!handle(query, rc)) {
      // Drop the line: close the port, stay silent a moment, open it again.
      modbus_close(ctx_);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      if (modbus_connect(ctx_) != 0)
        return fail("cannot reopen " + options_.serial_port + ": " + modbus_strerror(errno));
      modbus_flush(ctx_);
    }
  }
  return Ok{};
}

}  // namespace collide::hw
