// The Modbus register map: value encodings against hand-worked register
// contents, and the profile keys that describe a regulator (both shipped
// profiles load; bad maps are refused with file, line and field).
#include "hw/modbus_map.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "hw/rig.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

namespace {

ModbusPressureRegisters regs(ModbusValueType type, std::string order = "ABCD", double scale = 1.0,
                             double offset = 0.0, PressureUnit unit = {"kPa", 1.0}) {
  return {ModbusTable::Holding, {0}, type, std::move(order), scale, offset, unit};
}

std::string profilePath(const std::string& name) {
  return std::string(COLLIDE_SOURCE_DIR) + "/config/" + name;
}

std::string genericText() {
  return readFile(profilePath("regulator-generic-10bar.toml"));
}

collide::Result<ModbusRegulatorMap> mapOf(const std::string& text) {
  auto profile = parseRigProfile(text, "test.toml");
  if (!profile) return profile.error();
  return ModbusRegulatorMap::fromProfile(*profile);
}

std::string mapError(const std::string& text) {
  auto m = mapOf(text);
  return m ? std::string("(no error)") : m.error().message;
}

}  // namespace

// 123456.0f is 0x47F12000 (IEEE 754): bytes A=47 B=F1 C=20 D=00.
TEST(ModbusEncoding, Float32InEveryWordOrder) {
  const std::vector<std::pair<std::string, std::vector<std::uint16_t>>> cases = {
      {"ABCD", {0x47F1, 0x2000}},
      {"CDAB", {0x2000, 0x47F1}},
      {"BADC", {0xF147, 0x0020}},
      {"DCBA", {0x0020, 0xF147}}};
  for (const auto& [order, words] : cases) {
    const ModbusPressureRegisters r = regs(ModbusValueType::Float32, order);
    auto w = r.encode(123456.0);
    ASSERT_TRUE(w) << order;
    EXPECT_EQ(*w, words) << order;
    EXPECT_EQ(r.decode(words.data()), 123456.0) << order;
  }
}

TEST(ModbusEncoding, ScaledSixteenBitRegisters) {
  // 5 bar at 1 mbar per count is 5000 = 0x1388.
  const ModbusPressureRegisters bar =
      regs(ModbusValueType::U16, "ABCD", 0.001, 0.0, {"bar", 100.0});
  EXPECT_THAT(*bar.encode(500.0), ElementsAre(0x1388));
  const std::uint16_t w = 0x1388;
  EXPECT_DOUBLE_EQ(bar.decode(&w), 500.0);
  EXPECT_DOUBLE_EQ(bar.resolutionKPa(), 0.1);
  // Byte-swapped 16-bit register.
  const ModbusPressureRegisters swapped =
      regs(ModbusValueType::U16, "BADC", 0.001, 0.0, {"bar", 100.0});
  EXPECT_THAT(*swapped.encode(500.0), ElementsAre(0x8813));
  // -1.5 kPa at 0.1 kPa per count is -15 = 0xFFF1 in two's complement.
  const ModbusPressureRegisters signed16 = regs(ModbusValueType::I16, "ABCD", 0.1);
  EXPECT_THAT(*signed16.encode(-1.5), ElementsAre(0xFFF1));
  const std::uint16_t n = 0xFFF1;
  EXPECT_DOUBLE_EQ(signed16.decode(&n), -1.5);
  // An offset: raw 0 is -1 bar (absolute sensor read as gauge).
  const ModbusPressureRegisters offset =
      regs(ModbusValueType::U16, "ABCD", 0.01, -1.0, {"bar", 100.0});
  EXPECT_THAT(*offset.encode(0.0), ElementsAre(100));
}

TEST(ModbusEncoding, ThirtyTwoBitIntegers) {
  // 70000 = 0x00011170.
  EXPECT_THAT(*regs(ModbusValueType::U32).encode(70000.0), ElementsAre(0x0001, 0x1170));
  EXPECT_THAT(*regs(ModbusValueType::U32, "CDAB").encode(70000.0), ElementsAre(0x1170, 0x0001));
  // -2 = 0xFFFFFFFE.
  EXPECT_THAT(*regs(ModbusValueType::I32).encode(-2.0), ElementsAre(0xFFFF, 0xFFFE));
  const std::uint16_t w[2] = {0xFFFF, 0xFFFE};
  EXPECT_EQ(regs(ModbusValueType::I32).decode(w), -2.0);
  EXPECT_EQ(regs(ModbusValueType::U32).width(), 2);
  EXPECT_EQ(regs(ModbusValueType::I16).width(), 1);
}

TEST(ModbusEncoding, RefusesValuesTheTypeCannotHold) {
  const ModbusPressureRegisters bar =
      regs(ModbusValueType::U16, "ABCD", 0.001, 0.0, {"bar", 100.0});
  const auto high = bar.encode(7000.0);  // 70 bar = 70000 counts
  ASSERT_FALSE(high);
  EXPECT_THAT(high.error().message, HasSubstr("outside what a u16 holds (0..65535)"));
  EXPECT_FALSE(bar.encode(-1.0));
  EXPECT_FALSE(bar.encode(std::nan("")));
}

TEST(ModbusEncoding, EncodeAtMostNeverRoundsAboveTheLimit) {
  // 0.3 kPa per count: 1.1 kPa is 3.67 counts, rounded to 4 = 1.2 kPa.
  const ModbusPressureRegisters r = regs(ModbusValueType::U16, "ABCD", 0.3);
  EXPECT_NEAR(r.decode(r.encode(1.1)->data()), 1.2, 1e-12);
  const auto at_most = r.encodeAtMost(1.1);
  ASSERT_TRUE(at_most);
  EXPECT_NEAR(r.decode(at_most->data()), 0.9, 1e-12);
  // Floating-point noise is not "above": 55 kPa at 1 mbar per count decodes
  // as 55.000000000000007 but is 550 counts, not 549.
  const ModbusPressureRegisters bar =
      regs(ModbusValueType::U16, "ABCD", 0.001, 0.0, {"bar", 100.0});
  EXPECT_THAT(*bar.encodeAtMost(55.0), ElementsAre(550));
  const ModbusPressureRegisters f = regs(ModbusValueType::Float32);
  const double limit = 200.1;  // not exact in float32: 200.100006...
  EXPECT_LE(f.decode(f.encodeAtMost(limit)->data()), limit);
}

TEST(ModbusMapProfile, GenericProfileIsTheBuiltInMap) {
  auto m = mapOf(genericText());
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_TRUE(*m == ModbusRegulatorMap::generic10Bar());
  EXPECT_EQ(m->link.describe(), "Modbus TCP 127.0.0.1:1502, unit 1");
}

TEST(ModbusMapProfile, Float32Profile) {
  auto m = mapOf(readFile(profilePath("regulator-float32.toml")));
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->setpoint.type, ModbusValueType::Float32);
  EXPECT_EQ(m->setpoint.word_order, "CDAB");
  EXPECT_THAT(m->setpoint.addresses, ElementsAre(100, 102));
  EXPECT_EQ(m->readback.table, ModbusTable::Holding);
  EXPECT_THAT(m->readback.addresses, ElementsAre(110, 112));
  EXPECT_EQ(m->readback.unit.name, "bar");
}

TEST(ModbusMapProfile, ShippedProfilesBuildAModbusRig) {
  for (const char* name : {"regulator-generic-10bar.toml", "regulator-float32.toml"}) {
    auto profile = loadRigProfile(profilePath(name));
    ASSERT_TRUE(profile) << profile.error().message;
    auto rig = makeRig(*profile);
    ASSERT_TRUE(rig) << rig.error().message;
    EXPECT_EQ(rig->regulator->info().backend, "modbus");
    EXPECT_EQ(rig->regulator->info().device, "127.0.0.1:1502");
    EXPECT_EQ(rig->regulator->info().device_max_kPa, 1000.0);
    EXPECT_EQ(rig->regulator->state(), DeviceState::Closed);  // nothing opened yet
  }
}

TEST(ModbusMapProfile, RtuSettings) {
  std::string t = withKey(genericText(), "regulator", "transport", "\"rtu\"");
  t = withKey(t, "regulator", "device", "\"/dev/ttyUSB0\"");
  t = withKey(t, "regulator", "parity", "\"even\"");
  t = withKey(t, "regulator", "baud", "9600");
  auto m = mapOf(t);
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->link.describe(), "Modbus RTU /dev/ttyUSB0 9600 8E1, unit 1");
}

TEST(ModbusMapProfile, BadMapsNameFileLineAndField) {
  const std::string text = genericText();
  const int addresses = lineOf(text, "regulator.setpoint", "addresses");
  EXPECT_THAT(mapError(withKey(text, "regulator.setpoint", "addresses", "[0]")),
              HasSubstr("test.toml:" + std::to_string(addresses) +
                        ": regulator.setpoint.addresses = [0]: give one address per channel"));
  EXPECT_THAT(mapError(withKey(text, "regulator.setpoint", "table", "\"input\"")),
              HasSubstr("regulator.setpoint.table = \"input\": a setpoint is written, so it "
                        "must be a \"holding\" register"));
  std::string overlap = withKey(text, "regulator.readback", "type", "\"float32\"");
  EXPECT_THAT(mapError(overlap), HasSubstr("regulator.readback.addresses = [0, 1]: channels 0 "
                                           "and 1 overlap (a float32 takes 2 registers)"));
  EXPECT_THAT(mapError(withKey(text, "regulator.readback", "table", "\"holding\"")),
              HasSubstr("regulator.readback.addresses = [0, 1]: overlaps the setpoint registers"));
  EXPECT_THAT(mapError(withKey(text, "regulator", "range_kpa", "[0.0, 10000.0]")),
              HasSubstr("regulator.setpoint.type = \"u16\": cannot hold the device's range"));
  EXPECT_THAT(mapError(withKey(text, "regulator.setpoint", "unit", "\"atm\"")),
              HasSubstr("regulator.setpoint.unit = \"atm\": must be one of \"kPa\", \"bar\""));
  EXPECT_THAT(mapError(withKey(text, "regulator.setpoint", "scael", "0.1")),
              HasSubstr("regulator.setpoint.scael: unknown setting for the modbus regulator"));
  EXPECT_THAT(mapError(withKey(text, "regulator", "device", "\"127.0.0.1:http\"")),
              HasSubstr("regulator.device = \"127.0.0.1:http\": for Modbus TCP write "
                        "\"host:port\""));
  EXPECT_THAT(mapError(withKey(text, "regulator", "transport", "\"rtu\"")),
              HasSubstr("regulator.device = \"127.0.0.1:1502\": for Modbus RTU give the serial "
                        "port's path"));
  EXPECT_THAT(mapError(withKey(text, "regulator", "unit_id", "300")),
              HasSubstr("regulator.unit_id = 300: must be >= 0 and <= 255"));
  // The same errors come out of makeRig, which builds the backend.
  auto profile = parseRigProfile(withKey(text, "regulator", "timeout_ms", "0"), "test.toml");
  ASSERT_TRUE(profile);
  auto rig = makeRig(*profile);
  ASSERT_FALSE(rig);
  EXPECT_THAT(rig.error().message, HasSubstr("regulator.timeout_ms = 0: must be >= 1"));
}

TEST(ModbusMapProfile, HostNamesAndIpv6AddressesAreKeptForResolving) {
  const std::string text = genericText();
  struct Case {
    const char* device;
    const char* host;
    int port;
    const char* endpoint;
  };
  for (const Case& c :
       {Case{"localhost:1502", "localhost", 1502, "localhost:1502"},
        Case{"[::1]:1502", "::1", 1502, "[::1]:1502"},
        Case{"[fe80::1]", "fe80::1", 502, "[fe80::1]:502"}, Case{"::1", "::1", 502, "[::1]:502"},
        Case{"regulator.lab", "regulator.lab", 502, "regulator.lab:502"}}) {
    auto m = mapOf(withKey(text, "regulator", "device", std::string("\"") + c.device + "\""));
    ASSERT_TRUE(m) << c.device << ": " << m.error().message;
    EXPECT_EQ(m->link.host, c.host) << c.device;
    EXPECT_EQ(m->link.port, c.port) << c.device;
    EXPECT_EQ(m->link.endpoint(), c.endpoint) << c.device;
  }
  for (const char* bad : {"[::1", "[::1]1502", "[::1]:", "host:", "host:0", "[::1]:99999"})
    EXPECT_THAT(mapError(withKey(text, "regulator", "device", std::string("\"") + bad + "\"")),
                HasSubstr("regulator.device = \"" + std::string(bad) + "\""))
        << bad;
}

TEST(ModbusMapProfile, FromProfileRefusesANonModbusRegulator) {
  auto profile = defaultRigProfile();
  ASSERT_TRUE(profile);
  auto m = ModbusRegulatorMap::fromProfile(*profile);
  ASSERT_FALSE(m);
  EXPECT_THAT(m.error().message, HasSubstr("regulator.backend = \"sim\": not a Modbus regulator"));
}
