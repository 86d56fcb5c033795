// Fuzz target: the registers a Modbus regulator answers with, decoded under
// every register layout a profile can describe (type, word order, scale,
// offset, unit). Any answer decodes to a number (NaN/inf included: the
// regulator backend refuses those) and prints; and a pressure that decodes
// and encodes again round-trips to within one count.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "hw/modbus_map.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using collide::hw::ModbusPressureRegisters;
  using collide::hw::ModbusValueType;
  if (size < 2 + 2 * sizeof(double) + 4) return 0;
  ModbusPressureRegisters r;
  r.type = static_cast<ModbusValueType>(data[0] % 5);
  static const char* kOrders[] = {"ABCD", "CDAB", "BADC", "DCBA"};
  r.word_order = kOrders[data[1] % 4];
  double scale, offset;
  std::memcpy(&scale, data + 2, sizeof scale);
  std::memcpy(&offset, data + 2 + sizeof scale, sizeof offset);
  if (!std::isfinite(scale) || !std::isfinite(offset) || scale == 0) return 0;
  r.scale = scale;
  r.offset = offset;
  r.unit = {"bar", 100.0};
  std::uint16_t words[2];
  std::memcpy(words, data + 2 + 2 * sizeof(double), sizeof words);
  const double kPa = r.decode(words);
  (void)r.rawText(words);
  if (!std::isfinite(kPa)) return 0;
  auto encoded = r.encode(kPa);
  if (!encoded) return 0;  // out of the type's range: refused with a message
  const double again = r.decode(encoded->data());
  const double count_kPa =
      r.type == ModbusValueType::Float32 ? std::abs(kPa) * 1e-6 : std::abs(scale) * r.unit.kPa;
  if (std::abs(again - kPa) > count_kPa * 0.5000001 + 1e-9 * std::abs(kPa)) __builtin_trap();
  return 0;
}
