#include "hw/modbus_link.hpp"

#include <modbus/modbus.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

#include "hw/format.hpp"

namespace collide::hw {

namespace {

bool isException(int err) {
  return err > MODBUS_ENOBASE && err <= EMBXGTAR;
}

// What to check for each Modbus exception code (the device answered, so the
// request itself is what it does not like).
std::string exceptionHint(int code, const ModbusRegisterRef& ref) {
  switch (code) {
    case MODBUS_EXCEPTION_ILLEGAL_FUNCTION:
      return "the device does not serve this request: check " + ref.key +
             ".table (holding or input) against its manual";
    case MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS:
      return "the device has no such register: check " + ref.key +
             ".addresses against its manual (0-based protocol addresses: holding register "
             "40001 is address 0)";
    case MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE:
      return "the device refused the value or the register count: check " + ref.key +
             ".type (a 32-bit value spans two registers), scale and offset, and the device's "
             "own limits";
    case MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE:
      return "the device reports an internal failure: check its status display and alarms, "
             "then power-cycle it";
    case MODBUS_EXCEPTION_ACKNOWLEDGE:
    case MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY:
      return "the device is busy: try again; if it persists check what else talks to it";
    case MODBUS_EXCEPTION_GATEWAY_PATH:
    case MODBUS_EXCEPTION_GATEWAY_TARGET:
      return "the gateway cannot reach the device behind it: check regulator.unit_id and the "
             "gateway's serial side";
    default: return "see the device's manual for this code";
  }
}

// Failures after which the link may be fine again once reopened.
bool isLinkFailure(int err) {
  return !isException(err);
}

}  // namespace

ModbusLink::ModbusLink(ModbusLinkSettings settings) : settings_(std::move(settings)) {}

ModbusLink::~ModbusLink() {
  close();
}

void ModbusLink::close() {
  if (ctx_) {
    modbus_close(ctx_);
    modbus_free(ctx_);
    ctx_ = nullptr;
  }
  connected_ = false;
}

Status ModbusLink::open() {
  close();
  const ModbusLinkSettings& s = settings_;
  ctx_ = s.transport == ModbusTransport::Tcp
             // The _pi variant resolves host names and IPv6 literals (getaddrinfo);
             // plain modbus_new_tcp takes dotted IPv4 only and turns "localhost"
             // into 255.255.255.255.
             ? modbus_new_tcp_pi(s.host.c_str(), std::to_string(s.port).c_str())
             : modbus_new_rtu(s.serial_port.c_str(), s.baud, s.parity, s.data_bits, s.stop_bits);
  if (!ctx_)
    return fail("cannot set up " + s.describe() + " (" + std::strerror(errno) +
                "): check regulator.device, baud, parity, data_bits and stop_bits");
  modbus_set_slave(ctx_, s.unit_id);
  const auto timeout_us = static_cast<std::uint32_t>(s.timeout_ms) * 1000u;
  modbus_set_response_timeout(ctx_, timeout_us / 1000000u, timeout_us % 1000000u);
  // Recovery is ours (reconnect and retry), not libmodbus' (which would sleep
  // and reconnect behind our back without resending).
  modbus_set_error_recovery(ctx_, MODBUS_ERROR_RECOVERY_NONE);
  errno = 0;
  if (modbus_connect(ctx_) != 0) {
    // libmodbus 3.1 may leave errno unset when a TCP connect times out.
    const int err = errno;
    const std::string why = err ? modbus_strerror(err) : "no answer within regulator.timeout_ms";
    close();
    if (s.transport == ModbusTransport::Tcp)
      return fail("cannot connect to " + s.describe() + " (" + why +
                  "): check that the device is on and reachable at " + s.endpoint() +
                  " (regulator.device) and that its Modbus TCP server is enabled");
    return fail("cannot open the serial port of " + s.describe() + " (" + why +
                "): check regulator.device, that the adapter is plugged in and that you may use "
                "it (the lab group, see the README's lab set-up)");
  }
  connected_ = true;
  return Ok{};
}

Status ModbusLink::connect() {
  Status s = open();
  last_silent_ = !s;
  return s;
}

std::string ModbusLink::failure(int err, const char* verb, const ModbusRegisterRef& ref) const {
  const ModbusLinkSettings& s = settings_;
  std::string regs = std::string(toString(ref.table)) + (ref.count > 1 ? "s " : " ") +
                     std::to_string(ref.address) +
                     (ref.count > 1 ? ".." + std::to_string(ref.address + ref.count - 1) : "") +
                     " (" + ref.what + ")";
  const std::string where = std::string(verb) + " " + regs + " on " + s.describe();
  const bool rtu = s.transport == ModbusTransport::Rtu;
  if (isException(err)) {
    const int code = err - MODBUS_ENOBASE;
    return where + ": the device answered with Modbus exception " + std::to_string(code) + " (" +
           modbus_strerror(err) + "): " + exceptionHint(code, ref) +
           " (retrying will not help until that is fixed)";
  }
  const std::string unit = "regulator.unit_id = " + std::to_string(s.unit_id);
  const std::string tries = " (tried " + std::to_string(1 + s.retries) + " time" +
                            (s.retries ? "s, reconnecting in between" : "") + ")";
  if (err == ETIMEDOUT)
    return where + ": no answer within " + std::to_string(s.timeout_ms) + " ms" + tries +
           ": check that the device is on and connected, that " + unit + " is its unit id" +
           (rtu ? ", that baud, parity, data_bits and stop_bits match it" : "") +
           ", and raise regulator.timeout_ms if it is merely slow";
  if (err == EMBBADSLAVE)
    return where + ": the answer came from another unit id than " + unit + tries +
           ": check the device's unit id and that no two devices on the line share one";
  if (err == EMBBADCRC)
    return where + ": answers arrive corrupted (bad CRC)" + tries +
           ": check baud, parity, data_bits and stop_bits against the device, the wiring and "
           "the line termination";
  if (err == EMBBADDATA || err == EMBMDATA || err == EMBBADEXC || err == EMBUNKEXC)
    return where + ": the answer did not match the request (" + modbus_strerror(err) + ")" + tries +
           ": check that regulator.device is the regulator this profile describes" +
           (rtu ? " and that the serial settings match it" : "");
  return where + ": the link failed (" + modbus_strerror(err) + ")" + tries +
         ": check the cable or network and that the device is on";
}

template <class Op>
Status ModbusLink::exchange(const char* verb, const ModbusRegisterRef& ref, Op op) {
  ++stats_.requests;
  int err = 0;
  std::string connect_error;
  for (int attempt = 0; attempt <= settings_.retries; ++attempt) {
    if (!connected_) {
      if (attempt > 0 || stats_.requests > 1) ++stats_.reconnects;
      if (Status s = open(); !s) {
        connect_error = s.error().message;
        ++stats_.failures;
        continue;
      }
      // Anything still in flight from before belongs to an old request.
      modbus_flush(ctx_);
    }
    errno = 0;
    if (op(ctx_) >= 0) return Ok{};
    err = errno ? errno : EIO;
    ++stats_.failures;
    if (!isLinkFailure(err)) break;  // the device answered: asking again gets the same answer
    close();
    // On a serial line a late answer may still be on its way: let it pass
    // before the port is opened again, by this call or the next one, or it
    // could pass for the answer to another request for as many registers
    // (TCP drops it with the connection; its transaction ids tell answers apart).
    if (settings_.transport == ModbusTransport::Rtu && err == ETIMEDOUT)
      std::this_thread::sleep_for(std::chrono::milliseconds(settings_.timeout_ms));
  }
  // Silence: never connected, or no answer in time, or the link reset.
  last_silent_ = err == 0 || err == ETIMEDOUT || err == ECONNRESET || err == ECONNREFUSED ||
                 err == EPIPE || err == ENOTCONN || err == EHOSTUNREACH || err == ENETUNREACH;
  if (err == 0) return fail(connect_error);  // never got as far as asking
  std::string message = failure(err, verb, ref);
  if (!connect_error.empty()) message += "; reconnecting failed too: " + connect_error;
  return fail(message);
}

Result<std::vector<std::uint16_t>> ModbusLink::read(const ModbusRegisterRef& ref) {
  std::vector<std::uint16_t> words(static_cast<std::size_t>(ref.count));
  Status s = exchange("reading", ref, [&](_modbus* ctx) {
    return ref.table == ModbusTable::Holding
               ? modbus_read_registers(ctx, ref.address, ref.count, words.data())
               : modbus_read_input_registers(ctx, ref.address, ref.count, words.data());
  });
  if (!s) return s.error();
  return words;
}

Status ModbusLink::write(const ModbusRegisterRef& ref, const std::vector<std::uint16_t>& words) {
  return exchange("writing", ref, [&](_modbus* ctx) {
    return words.size() == 1 ? modbus_write_register(ctx, ref.address, words[0])
                             : modbus_write_registers(ctx, ref.address,
                                                      static_cast<int>(words.size()), words.data());
  });
}

}  // namespace collide::hw
