#include "hw/modbus_map.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "hw/format.hpp"
#include "hw/try.hpp"

namespace collide::hw {

namespace {

const std::vector<PressureUnit>& units() {
  static const std::vector<PressureUnit> u = {{"kPa", 1.0},    {"bar", 100.0},
                                              {"mbar", 0.1},   {"Pa", 0.001},
                                              {"MPa", 1000.0}, {"psi", 6.894757293168361}};
  return u;
}

bool is32(ModbusValueType t) {
  return t == ModbusValueType::U32 || t == ModbusValueType::I32 || t == ModbusValueType::Float32;
}

// The raw count range of an integer type.
std::pair<double, double> rawRange(ModbusValueType t) {
  switch (t) {
    case ModbusValueType::U16: return {0.0, 65535.0};
    case ModbusValueType::I16: return {-32768.0, 32767.0};
    case ModbusValueType::U32: return {0.0, 4294967295.0};
    case ModbusValueType::I32: return {-2147483648.0, 2147483647.0};
    case ModbusValueType::Float32: break;
  }
  const double f = std::numeric_limits<float>::max();
  return {-f, f};
}

// 32 bits <-> two registers in the given byte order (see the header).
void toWords(std::uint32_t v, const std::string& order, bool wide, std::uint16_t* w) {
  const bool swap_bytes = order == "BADC" || order == "DCBA";
  const bool swap_words = order == "CDAB" || order == "DCBA";
  auto reg = [&](std::uint16_t x) {
    return swap_bytes ? static_cast<std::uint16_t>((x >> 8) | (x << 8)) : x;
  };
  if (!wide) {
    w[0] = reg(static_cast<std::uint16_t>(v));
    return;
  }
  const auto hi = static_cast<std::uint16_t>(v >> 16), lo = static_cast<std::uint16_t>(v);
  w[0] = reg(swap_words ? lo : hi);
  w[1] = reg(swap_words ? hi : lo);
}

std::uint32_t fromWords(const std::uint16_t* w, const std::string& order, bool wide) {
  const bool swap_bytes = order == "BADC" || order == "DCBA";
  const bool swap_words = order == "CDAB" || order == "DCBA";
  auto reg = [&](std::uint16_t x) {
    return swap_bytes ? static_cast<std::uint16_t>((x >> 8) | (x << 8)) : x;
  };
  if (!wide) return reg(w[0]);
  const std::uint32_t a = reg(w[0]), b = reg(w[1]);
  return swap_words ? (b << 16) | a : (a << 16) | b;
}

// The raw register value (a count, or the float) as a double.
double rawValue(const ModbusPressureRegisters& r, const std::uint16_t* words) {
  const std::uint32_t bits = fromWords(words, r.word_order, r.width() == 2);
  switch (r.type) {
    case ModbusValueType::U16: return static_cast<double>(static_cast<std::uint16_t>(bits));
    case ModbusValueType::I16: return static_cast<double>(static_cast<std::int16_t>(bits));
    case ModbusValueType::U32: return static_cast<double>(bits);
    case ModbusValueType::I32: return static_cast<double>(static_cast<std::int32_t>(bits));
    case ModbusValueType::Float32: return static_cast<double>(std::bit_cast<float>(bits));
  }
  return 0.0;
}

std::vector<std::uint16_t> wordsOf(const ModbusPressureRegisters& r, double raw) {
  std::uint32_t bits = 0;
  switch (r.type) {
    case ModbusValueType::U16:
    case ModbusValueType::U32: bits = static_cast<std::uint32_t>(raw); break;
    case ModbusValueType::I16:
      bits = static_cast<std::uint16_t>(static_cast<std::int16_t>(raw));
      break;
    case ModbusValueType::I32:
      bits = static_cast<std::uint32_t>(static_cast<std::int32_t>(raw));
      break;
    case ModbusValueType::Float32:
      bits = std::bit_cast<std::uint32_t>(static_cast<float>(raw));
      break;
  }
  std::vector<std::uint16_t> w(static_cast<std::size_t>(r.width()));
  toWords(bits, r.word_order, r.width() == 2, w.data());
  return w;
}

}  // namespace

const char* toString(ModbusTable t) {
  return t == ModbusTable::Holding ? "holding register" : "input register";
}

const char* toString(ModbusValueType t) {
  switch (t) {
    case ModbusValueType::U16: return "u16";
    case ModbusValueType::I16: return "i16";
    case ModbusValueType::U32: return "u32";
    case ModbusValueType::I32: return "i32";
    case ModbusValueType::Float32: return "float32";
  }
  return "?";
}

int ModbusPressureRegisters::width() const {
  return is32(type) ? 2 : 1;
}

Result<std::vector<std::uint16_t>> ModbusPressureRegisters::encode(double kPa) const {
  if (!std::isfinite(kPa)) return fail("pressure " + num(kPa) + " kPa is not a number");
  const double exact = (kPa / unit.kPa - offset) / scale;
  const double raw = type == ModbusValueType::Float32 ? exact : std::round(exact);
  const auto [lo, hi] = rawRange(type);
  if (!(raw >= lo && raw <= hi))
    return fail(num(kPa) + " kPa is " + num(exact) + " in the register's counts (" +
                num(kPa / unit.kPa) + " " + unit.name + ", scale " + num(scale) + ", offset " +
                num(offset) + "), outside what a " + toString(type) + " holds (" + num(lo) + ".." +
                num(hi) + "): check the register's type, scale and offset in the profile");
  return wordsOf(*this, raw);
}

Result<std::vector<std::uint16_t>> ModbusPressureRegisters::encodeAtMost(double kPa) const {
  COLLIDE_ASSIGN_OR_RETURN(std::vector<std::uint16_t> w, encode(kPa));
  if (!exceedsKPa(decode(w.data()), kPa)) return w;
  // Rounding went above the limit: take the neighbouring count (or float)
  // below it instead.
  const double raw = rawValue(*this, w.data());
  const double step_down =
      type == ModbusValueType::Float32
          ? static_cast<double>(std::nextafter(
                static_cast<float>(raw),
                scale > 0 ? -std::numeric_limits<float>::max() : std::numeric_limits<float>::max()))
          : raw - (scale > 0 ? 1.0 : -1.0);
  const auto [lo, hi] = rawRange(type);
  if (!(step_down >= lo && step_down <= hi))
    return fail(num(kPa) +
                " kPa cannot be written without exceeding it: the register's "
                "range ends there");
  return wordsOf(*this, step_down);
}

bool exceedsKPa(double kPa, double limit_kPa) {
  // Decoding 550 counts of 0.001 bar gives 55.000000000000007 kPa: that is
  // 55 kPa, not above it. A whole count above is what must never pass.
  return kPa > limit_kPa + 1e-9 * std::max(1.0, std::abs(limit_kPa));
}

double ModbusPressureRegisters::decode(const std::uint16_t* words) const {
  return (rawValue(*this, words) * scale + offset) * unit.kPa;
}

std::string ModbusPressureRegisters::rawText(const std::uint16_t* words) const {
  const double v = rawValue(*this, words);
  if (type == ModbusValueType::Float32) return num(v);
  return std::to_string(static_cast<long long>(v));
}

double ModbusPressureRegisters::resolutionKPa() const {
  return type == ModbusValueType::Float32 ? 0.0 : std::abs(scale) * unit.kPa;
}

std::string ModbusLinkSettings::endpoint() const {
  if (transport != ModbusTransport::Tcp) return serial_port;
  const bool ipv6 = host.find(':') != std::string::npos;
  return (ipv6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

std::string ModbusLinkSettings::describe() const {
  if (transport == ModbusTransport::Tcp)
    return "Modbus TCP " + endpoint() + ", unit " + std::to_string(unit_id);
  return "Modbus RTU " + serial_port + " " + std::to_string(baud) + " " +
         std::to_string(data_bits) + parity + std::to_string(stop_bits) + ", unit " +
         std::to_string(unit_id);
}

namespace {

Result<ModbusPressureRegisters> readRegisters(SettingsReader& r, const std::string& prefix,
                                              int channels, bool writable) {
  ModbusPressureRegisters reg;
  auto key = [&](const char* k) { return prefix + "." + k; };
  COLLIDE_ASSIGN_OR_RETURN(
      const std::string table,
      r.text(key("table"), writable ? std::optional<std::string>("holding") : std::nullopt,
             {"holding", "input"}));
  if (writable && table != "holding")
    return r.invalid(key("table"),
                     "a setpoint is written, so it must be a \"holding\" register "
                     "(input registers are read-only)");
  reg.table = table == "holding" ? ModbusTable::Holding : ModbusTable::Input;
  COLLIDE_ASSIGN_OR_RETURN(const std::string type, r.text(key("type"), std::nullopt,
                                                          {"u16", "i16", "u32", "i32", "float32"}));
  reg.type = type == "u16"   ? ModbusValueType::U16
             : type == "i16" ? ModbusValueType::I16
             : type == "u32" ? ModbusValueType::U32
             : type == "i32" ? ModbusValueType::I32
                             : ModbusValueType::Float32;
  COLLIDE_ASSIGN_OR_RETURN(reg.word_order,
                           r.text(key("word_order"), "ABCD", {"ABCD", "CDAB", "BADC", "DCBA"}));
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> addresses,
                           r.numbers(key("addresses"), 0, std::nullopt, {.ge = 0, .le = 65535}));
  if (addresses.size() != static_cast<std::size_t>(channels))
    return r.invalid(key("addresses"),
                     "give one address per channel (channels = " + std::to_string(channels) + ")");
  for (double a : addresses) {
    if (std::floor(a) != a) return r.invalid(key("addresses"), "addresses are whole numbers");
    if (a + reg.width() - 1 > 65535)
      return r.invalid(key("addresses"),
                       "a " + type + " at " + num(a) + " would run past the last register, 65535");
    reg.addresses.push_back(static_cast<int>(a));
  }
  // Two channels sharing a register would overwrite each other.
  for (std::size_t i = 0; i < reg.addresses.size(); ++i)
    for (std::size_t j = i + 1; j < reg.addresses.size(); ++j)
      if (std::abs(reg.addresses[i] - reg.addresses[j]) < reg.width())
        return r.invalid(key("addresses"), "channels " + std::to_string(i) + " and " +
                                               std::to_string(j) + " overlap (a " + type +
                                               " takes " + std::to_string(reg.width()) +
                                               " register" + (reg.width() > 1 ? "s" : "") + ")");
  COLLIDE_ASSIGN_OR_RETURN(reg.scale, r.number(key("scale"), 1.0));
  if (reg.scale == 0.0) return r.invalid(key("scale"), "must not be 0");
  COLLIDE_ASSIGN_OR_RETURN(reg.offset, r.number(key("offset"), 0.0));
  std::vector<std::string> names;
  for (const auto& u : units()) names.push_back(u.name);
  COLLIDE_ASSIGN_OR_RETURN(const std::string unit, r.text(key("unit"), std::nullopt, names));
  reg.unit = *std::find_if(units().begin(), units().end(),
                           [&](const PressureUnit& u) { return u.name == unit; });
  return reg;
}

Status checkHolds(SettingsReader& r, const std::string& prefix, const ModbusPressureRegisters& reg,
                  double min_kPa, double max_kPa) {
  for (double p : {min_kPa, max_kPa})
    if (Result<std::vector<std::uint16_t>> w = reg.encode(p); !w)
      return r.invalid(prefix + ".type", "cannot hold the device's range (regulator.range_kpa): " +
                                             w.error().message);
  return Ok{};
}

}  // namespace

Result<ModbusRegulatorMap> ModbusRegulatorMap::read(SettingsReader& r, const std::string& device) {
  ModbusRegulatorMap m;
  ModbusLinkSettings& l = m.link;
  COLLIDE_ASSIGN_OR_RETURN(const std::string transport,
                           r.text("transport", std::nullopt, {"tcp", "rtu"}));
  l.transport = transport == "tcp" ? ModbusTransport::Tcp : ModbusTransport::Rtu;
  if (l.transport == ModbusTransport::Tcp) {
    // "host", "host:port", "[ipv6]" or "[ipv6]:port"; a bare IPv6 address
    // (two colons or more) has no port. Names are resolved when connecting.
    std::string port;
    if (!device.empty() && device.front() == '[') {
      const auto close = device.find(']');
      if (close == std::string::npos || (close + 1 < device.size() && device[close + 1] != ':'))
        return r.invalid("device",
                         "for an IPv6 address write \"[address]:port\", e.g. \"[::1]:502\"");
      l.host = device.substr(1, close - 1);
      if (close + 1 < device.size()) port = device.substr(close + 2);
      if (close + 1 < device.size() && port.empty()) port = "-";  // "[::1]:" is malformed
    } else if (std::count(device.begin(), device.end(), ':') > 1) {
      l.host = device;
    } else {
      const auto colon = device.rfind(':');
      l.host = device.substr(0, colon);
      if (colon != std::string::npos)
        port = device.substr(colon + 1).empty() ? "-" : device.substr(colon + 1);
    }
    if (!port.empty()) {
      char* end = nullptr;
      const long p = std::strtol(port.c_str(), &end, 10);
      if (*end != '\0' || p < 1 || p > 65535)
        return r.invalid("device",
                         "for Modbus TCP write \"host:port\" with a port 1..65535, "
                         "e.g. \"192.168.1.50:502\", \"regulator.lab:502\" or \"[::1]:502\"");
      l.port = static_cast<int>(p);
    }
    if (l.host.empty())
      return r.invalid("device", "for Modbus TCP write the device's address, \"host:port\"");
  } else {
    if (device.empty() || device.front() != '/')
      return r.invalid("device",
                       "for Modbus RTU give the serial port's path, e.g. "
                       "\"/dev/ttyUSB0\"");
    l.serial_port = device;
  }
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t unit,
                           r.integer("unit_id", 1,
                                     {.ge = l.transport == ModbusTransport::Rtu ? 1.0 : 0.0,
                                      .le = l.transport == ModbusTransport::Rtu ? 247.0 : 255.0}));
  l.unit_id = static_cast<int>(unit);
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t timeout,
                           r.integer("timeout_ms", 200, {.ge = 1, .le = 60000}));
  l.timeout_ms = static_cast<int>(timeout);
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t retries,
                           r.integer("retries", 1, {.ge = 0, .le = 10}));
  l.retries = static_cast<int>(retries);
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t baud, r.integer("baud", 19200, {.ge = 50}));
  l.baud = static_cast<int>(baud);
  COLLIDE_ASSIGN_OR_RETURN(const std::string parity,
                           r.text("parity", "none", {"none", "even", "odd"}));
  l.parity = parity == "none" ? 'N' : parity == "even" ? 'E' : 'O';
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t data_bits,
                           r.integer("data_bits", 8, {.ge = 5, .le = 8}));
  l.data_bits = static_cast<int>(data_bits);
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t stop_bits,
                           r.integer("stop_bits", 1, {.ge = 1, .le = 2}));
  l.stop_bits = static_cast<int>(stop_bits);

  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t channels,
                           r.integer("channels", 2, {.ge = 1, .le = 64}));
  m.channels = static_cast<int>(channels);
  COLLIDE_ASSIGN_OR_RETURN(const std::vector<double> range,
                           r.numbers("range_kpa", 2, std::nullopt, {.ge = 0.0}));
  if (!(range[0] < range[1]))
    return r.invalid("range_kpa", "write [lowest, highest] kPa, lowest < highest");
  m.device_min_kPa = range[0];
  m.device_max_kPa = range[1];

  COLLIDE_ASSIGN_OR_RETURN(m.setpoint, readRegisters(r, "setpoint", m.channels, true));
  COLLIDE_ASSIGN_OR_RETURN(m.readback, readRegisters(r, "readback", m.channels, false));
  COLLIDE_RETURN_IF_ERROR(
      checkHolds(r, "setpoint", m.setpoint, m.device_min_kPa, m.device_max_kPa));
  COLLIDE_RETURN_IF_ERROR(
      checkHolds(r, "readback", m.readback, m.device_min_kPa, m.device_max_kPa));
  // A setpoint register that is also the read-back would read back the setpoint.
  if (m.readback.table == ModbusTable::Holding)
    for (int a : m.setpoint.addresses)
      for (int b : m.readback.addresses)
        if (a < b + m.readback.width() && b < a + m.setpoint.width())
          return r.invalid("readback.addresses",
                           "overlaps the setpoint registers (holding register " +
                               std::to_string(std::max(a, b)) +
                               "): the measured pressure must be a register of its own");
  COLLIDE_RETURN_IF_ERROR(r.finish("the modbus regulator backend"));
  return m;
}

Result<ModbusRegulatorMap> ModbusRegulatorMap::fromProfile(const RigProfile& profile) {
  if (profile.regulator.backend != "modbus")
    return fail(SettingsReader(profile.regulator.table).where("backend") + " = \"" +
                profile.regulator.backend +
                "\": not a Modbus regulator: give a profile whose [regulator] has backend = "
                "\"modbus\" (e.g. config/regulator-generic-10bar.toml)");
  SettingsReader r = profile.regulator.backendSettings();
  return read(r, profile.regulator.device);
}

ModbusRegulatorMap ModbusRegulatorMap::generic10Bar() {
  ModbusRegulatorMap m;
  m.link.transport = ModbusTransport::Tcp;
  m.link.host = "127.0.0.1";
  m.link.port = 1502;
  m.channels = 2;
  m.device_min_kPa = 0.0;
  m.device_max_kPa = 1000.0;
  const PressureUnit bar = *std::find_if(units().begin(), units().end(),
                                         [](const PressureUnit& u) { return u.name == "bar"; });
  m.setpoint = {ModbusTable::Holding, {0, 1}, ModbusValueType::U16, "ABCD", 0.001, 0.0, bar};
  m.readback = {ModbusTable::Input, {0, 1}, ModbusValueType::U16, "ABCD", 0.001, 0.0, bar};
  return m;
}

bool operator==(const PressureUnit& a, const PressureUnit& b) {
  return a.name == b.name && a.kPa == b.kPa;
}

bool operator==(const ModbusPressureRegisters& a, const ModbusPressureRegisters& b) {
  return a.table == b.table && a.addresses == b.addresses && a.type == b.type &&
         a.word_order == b.word_order && a.scale == b.scale && a.offset == b.offset &&
         a.unit == b.unit;
}

bool operator==(const ModbusLinkSettings& a, const ModbusLinkSettings& b) {
  return a.transport == b.transport && a.host == b.host && a.port == b.port &&
         a.serial_port == b.serial_port && a.baud == b.baud && a.parity == b.parity &&
         a.data_bits == b.data_bits && a.stop_bits == b.stop_bits && a.unit_id == b.unit_id &&
         a.timeout_ms == b.timeout_ms && a.retries == b.retries;
}

bool operator==(const ModbusRegulatorMap& a, const ModbusRegulatorMap& b) {
  return a.link == b.link && a.channels == b.channels && a.device_min_kPa == b.device_min_kPa &&
         a.device_max_kPa == b.device_max_kPa && a.setpoint == b.setpoint &&
         a.readback == b.readback;
}

}  // namespace collide::hw
