// PressureRegulatorModbus against a real Modbus server (libmodbus, the
// simulated regulator `collide sim-regulator` serves) over loopback TCP and
// over a socat pty pair for RTU: the role's conformance suite, then the
// backend's own guarantees (verified writes, settling from the read-back,
// the safety limit before any write) and every fault mode of the server
// (slow answers, wrong unit id, exception replies, a dropped link).
// RTU cases skip with a message when socat is missing.
#include <chrono>
#include <optional>

#include "hw/pressure_regulator_modbus.hpp"
#include "hw/rig_profile.hpp"
#include "modbus_peer.hpp"
#include "regulator_conformance.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;
using ::testing::HasSubstr;

namespace {

std::string configPath(const std::string& name) {
  return std::string(COLLIDE_SOURCE_DIR) + "/config/" + name;
}

ModbusRegulatorMap profileMap(const std::string& name) {
  auto profile = loadRigProfile(configPath(name));
  if (!profile) throw std::runtime_error(profile.error().message);
  auto map = ModbusRegulatorMap::fromProfile(*profile);
  if (!map) throw std::runtime_error(map.error().message);
  return *map;
}

// ---- the conformance suite over Modbus --------------------------------------

struct PeerAndClient {
  ModbusPeer peer;
};

RegulatorBench modbusBench(ModbusTransport transport, const ModbusRegulatorMap& map) {
  auto keep = std::make_shared<PeerAndClient>();
  keep->peer = startModbusPeer(serverOptions(transport, map));
  RegulatorBench b;
  b.clock = monotonicClock();
  if (!keep->peer.skip.empty()) {
    b.skip = keep->peer.skip;
    return b;
  }
  if (!keep->peer.error.empty()) throw std::runtime_error(keep->peer.error);
  auto modbus = std::make_unique<PressureRegulatorModbus>(keep->peer.client_map, 200.0,
                                                          keep->peer.client_map.link.endpoint());
  PressureRegulatorModbus* client = modbus.get();
  b.regulator = std::move(modbus);
  // The device is switched off: its server stops (TCP: the port closes; RTU:
  // nothing answers on the line).
  b.unplug = [keep] { keep->peer.server.reset(); };
  b.requests = [client] { return client->linkStats().requests; };
  b.keep_alive = keep;
  return b;
}

INSTANTIATE_TEST_SUITE_P(
    Modbus, RegulatorConformance,
    ::testing::Values(RegulatorBackend{"tcp_u16",
                                       [] {
                                         return modbusBench(ModbusTransport::Tcp,
                                                            ModbusRegulatorMap::generic10Bar());
                                       }},
                      RegulatorBackend{"rtu_u16",
                                       [] {
                                         return modbusBench(ModbusTransport::Rtu,
                                                            ModbusRegulatorMap::generic10Bar());
                                       }},
                      RegulatorBackend{"tcp_float32",
                                       [] {
                                         return modbusBench(ModbusTransport::Tcp,
                                                            profileMap("regulator-float32.toml"));
                                       }}),
    [](const auto& info) { return info.param.name; });

// ---- the backend's own tests, over TCP and RTU --------------------------------

class ModbusRegulatorBase : public ::testing::Test {
 protected:
  virtual ModbusTransport transport() const = 0;

  // Starts a server for `options` (transport from the parameter) and a
  // client for it; `client` may adjust the client's map first.
  void start(ModbusServerOptions options,
             const std::function<void(ModbusRegulatorMap&)>& client = {},
             double max_pressure_kPa = 200.0) {
    options.transport = transport();
    peer_ = startModbusPeer(std::move(options));
    if (!peer_.skip.empty()) GTEST_SKIP() << peer_.skip;
    ASSERT_TRUE(peer_.error.empty()) << peer_.error;
    ModbusRegulatorMap map = peer_.client_map;
    if (client) client(map);
    reg_ = std::make_unique<PressureRegulatorModbus>(map, max_pressure_kPa, "test-regulator");
  }
  void start() { start(serverOptions(transport(), ModbusRegulatorMap::generic10Bar())); }

  void bringUp(double max_kPa = 200.0) {
    ASSERT_TRUE(reg_->open()) << reg_->open().error().message;
    ASSERT_TRUE(reg_->configure({0.0, max_kPa}));
    ASSERT_TRUE(reg_->start());
  }

  ModbusRegulatorServer& server() { return peer_.srv(); }
  PressureRegulatorModbus& reg() { return *reg_; }

  ModbusPeer peer_;
  std::unique_ptr<PressureRegulatorModbus> reg_;
};

// Over TCP and RTU.
class ModbusRegulator : public ModbusRegulatorBase,
                        public ::testing::WithParamInterface<ModbusTransport> {
 protected:
  ModbusTransport transport() const override { return GetParam(); }
};
class ModbusRegulatorTcp : public ModbusRegulatorBase {
 protected:
  ModbusTransport transport() const override { return ModbusTransport::Tcp; }
};
class ModbusRegulatorRtu : public ModbusRegulatorBase {
 protected:
  ModbusTransport transport() const override { return ModbusTransport::Rtu; }
};

std::string transportName(const ::testing::TestParamInfo<ModbusTransport>& info) {
  return info.param == ModbusTransport::Tcp ? "tcp" : "rtu";
}

// Waits (real time) until `channel` has read within `tolerance_kPa` of its
// setpoint continuously for 30 ms (the sequencer's settle-and-hold); then a
// fresh reading.
double settle(PressureRegulator& reg, int channel, double tolerance_kPa) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  std::optional<Clock::time_point> since;
  while (Clock::now() < deadline) {
    auto s = reg.settled(channel, tolerance_kPa);
    EXPECT_TRUE(s) << s.error().message;
    if (!s) return NAN;
    if (!*s)
      since.reset();
    else if (!since)
      since = Clock::now();
    else if (Clock::now() - *since >= std::chrono::milliseconds(30))
      return *reg.readPressureKPa(channel);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ADD_FAILURE() << "channel " << channel << " never settled";
  return NAN;
}

}  // namespace

TEST_P(ModbusRegulator, WritesAreVerifiedAndSettlingComesFromTheDevice) {
  start();
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(0, 123.4));
  ASSERT_TRUE(reg().setPressureKPa(1, 55.0));
  // The device (server) holds exactly what was asked, in its own counts.
  EXPECT_DOUBLE_EQ(server().setpointKPa(0), 123.4);
  EXPECT_DOUBLE_EQ(server().setpointKPa(1), 55.0);
  // Right after the write the line has not got there yet: settled() asks the
  // device, it does not trust the setpoint.
  auto early = reg().settled(0, 0.5);
  ASSERT_TRUE(early);
  EXPECT_FALSE(*early);
  EXPECT_NEAR(settle(reg(), 0, 0.5), 123.4, 0.5);
  EXPECT_NEAR(settle(reg(), 1, 0.5), 55.0, 0.5);
  // ... and what it read is the simulated line's true pressure (ground truth).
  EXPECT_NEAR(server().linePressureKPa(0), 123.4, 0.3);
  // Each setpoint: one write, one verifying read.
  EXPECT_EQ(reg().linkStats().reconnects, 0);
}

TEST_P(ModbusRegulator, AWriteTheDeviceDoesNotTakeFailsVerification) {
  start();
  bringUp();
  ModbusServerFaults local_mode;
  local_mode.ignore_writes = true;
  server().setFaults(local_mode);
  const auto s = reg().setPressureKPa(0, 80.0);
  ASSERT_FALSE(s);
  EXPECT_THAT(s.error().message, HasSubstr("regulator \"test-regulator\": wrote 800 (80 kPa) to "
                                           "holding register 0 (setpoint, channel 0)"));
  EXPECT_THAT(s.error().message, HasSubstr("but it reads back 0 (0 kPa)"));
  EXPECT_THAT(s.error().message, HasSubstr("check that it is in remote (Modbus) mode"));
  EXPECT_EQ(*reg().setpointKPa(0), 0.0);  // not remembered as set
  EXPECT_DOUBLE_EQ(server().setpointKPa(0), 0.0);
}

TEST_P(ModbusRegulator, TheSafetyLimitHoldsBeforeAnythingIsWritten) {
  // 0.3 kPa per count: 150.05 kPa is 500.17 counts; the nearest, 500.33 ->
  // 500 = 150 kPa, fine; 150.2 kPa is 500.67 -> 501 = 150.3 kPa, above a
  // 150.2 limit, so the backend must write 500 instead.
  ModbusRegulatorMap map = ModbusRegulatorMap::generic10Bar();
  map.setpoint.scale = map.readback.scale = 0.3;
  map.setpoint.unit = map.readback.unit = {"kPa", 1.0};
  start(serverOptions(transport(), map), {}, 150.2);
  ASSERT_TRUE(reg().open());
  const auto requests_before = server().stats().requests;
  const auto above = reg().configure({0.0, 180.0});
  ASSERT_FALSE(above);
  EXPECT_THAT(above.error().message, HasSubstr("above safety.max_pressure_kpa = 150.2"));
  ASSERT_TRUE(reg().configure({0.0, 150.2}));
  ASSERT_TRUE(reg().start());
  EXPECT_FALSE(reg().setPressureKPa(0, 150.3));  // refused by the limits
  EXPECT_EQ(server().stats().requests, requests_before) << "something reached the device";
  ASSERT_TRUE(reg().setPressureKPa(0, 150.2));
  EXPECT_LE(server().setpointKPa(0), 150.2);
  EXPECT_NEAR(server().setpointKPa(0), 150.0, 1e-9);
}

TEST_P(ModbusRegulator, ExceptionRepliesNameDeviceRegisterAndWhatToCheck) {
  start();
  bringUp();
  ModbusServerFaults busy;
  busy.exception_code = 4;
  server().setFaults(busy);
  const auto read = reg().readPressureKPa(1);
  ASSERT_FALSE(read);
  const std::string m = read.error().message;
  EXPECT_THAT(m, HasSubstr("regulator \"test-regulator\": reading input register 1 (measured "
                           "pressure, channel 1) on Modbus "));
  EXPECT_THAT(m, HasSubstr("unit 1: the device answered with Modbus exception 4 (Slave device "
                           "or server failure): the device reports an internal failure"));
  // An exception is an answer: no reconnection, no second try.
  EXPECT_EQ(reg().linkStats().reconnects, 0);
  server().setFaults({});
  EXPECT_TRUE(reg().readPressureKPa(1));
}

TEST_P(ModbusRegulator, AWrongAddressIsCaughtWhenOpening) {
  start(serverOptions(transport(), ModbusRegulatorMap::generic10Bar()), [](ModbusRegulatorMap& m) {
    m.setpoint.addresses = {0, 7};
  });
  const auto open = reg().open();
  ASSERT_FALSE(open);
  EXPECT_THAT(open.error().message, HasSubstr("reading holding register 7 (setpoint, channel 1)"));
  EXPECT_THAT(open.error().message,
              HasSubstr("Modbus exception 2 (Illegal data address): the device has no such "
                        "register: check regulator.setpoint.addresses"));
  EXPECT_EQ(reg().state(), DeviceState::Closed);
}

TEST_P(ModbusRegulator, AValueOutsideTheDeviceRangeIsRefusedByTheDevice) {
  // The client believes in a 0..20 bar device; the device is 0..10 bar.
  start(
      serverOptions(transport(), ModbusRegulatorMap::generic10Bar()),
      [](ModbusRegulatorMap& m) { m.device_max_kPa = 2000.0; }, 2000.0);
  bringUp(2000.0);
  const auto s = reg().setPressureKPa(0, 1500.0);
  ASSERT_FALSE(s);
  EXPECT_THAT(s.error().message, HasSubstr("writing holding register 0 (setpoint, channel 0)"));
  EXPECT_THAT(s.error().message, HasSubstr("exception 3 (Illegal data value)"));
}

TEST_P(ModbusRegulator, SlowAnswersTimeOutAndTheLinkRecovers) {
  start();
  bringUp();
  ModbusServerFaults slow;
  slow.delay_ms = 300;  // the client waits 200 ms
  server().setFaults(slow);
  const auto t0 = std::chrono::steady_clock::now();
  const auto read = reg().readPressureKPa(0);
  const double waited_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_FALSE(read);
  EXPECT_THAT(read.error().message,
              HasSubstr("reading input register 0 (measured pressure, channel 0)"));
  EXPECT_THAT(read.error().message,
              HasSubstr("no answer within 200 ms (tried 2 times, reconnecting in between)"));
  EXPECT_THAT(read.error().message, HasSubstr("that regulator.unit_id = 1 is its unit id"));
  EXPECT_GE(waited_s, 0.4);  // two attempts of 200 ms each
  // Still silent after its retries: lost. The next call is refused at once,
  // without a request (it would wait out the timeouts again).
  EXPECT_THAT(read.error().message, HasSubstr("regulator \"test-regulator\" is lost ("));
  EXPECT_THAT(read.error().message, HasSubstr("retrying will not help"));
  ASSERT_TRUE(reg().loss());
  const std::int64_t requests = reg().linkStats().requests;
  const auto refused = reg().setPressureKPa(0, 42.0);
  ASSERT_FALSE(refused);
  EXPECT_THAT(refused.error().message, HasSubstr("is lost"));
  EXPECT_EQ(reg().linkStats().requests, requests) << "a lost regulator is not asked";
  // The device answers promptly again and is reopened: the late answers to
  // the old requests must not be taken for new ones.
  server().setFaults({});
  std::this_thread::sleep_for(std::chrono::milliseconds(900));  // the server works off its backlog
  ASSERT_TRUE(reg().close());
  bringUp();
  EXPECT_FALSE(reg().loss()) << "reopening found it again";
  ASSERT_TRUE(reg().setPressureKPa(0, 42.0)) << "did not recover";
  EXPECT_NEAR(settle(reg(), 0, 0.5), 42.0, 0.5);
}

TEST_P(ModbusRegulator, AWrongUnitIdGetsNoAnswer) {
  ModbusServerOptions o = serverOptions(transport(), ModbusRegulatorMap::generic10Bar());
  o.unit_id = 7;  // the device's
  start(o, [](ModbusRegulatorMap& m) { m.link.unit_id = 1; });
  const auto open = reg().open();
  ASSERT_FALSE(open);
  EXPECT_THAT(open.error().message, HasSubstr("unit 1: no answer within 200 ms"));
  EXPECT_THAT(open.error().message, HasSubstr("check that the device is on and connected, that "
                                              "regulator.unit_id = 1 is its unit id"));
  EXPECT_GE(server().stats().ignored, 1);
  EXPECT_EQ(server().stats().answered, 0);
}

// RTU only: libmodbus 3.1.6 does not check the unit id of a TCP answer (a
// Modbus TCP device echoes whatever it was sent).
TEST_F(ModbusRegulatorRtu, AnAnswerFromAnotherUnitIsRefused) {
  start();
  bringUp();
  ModbusServerFaults f;
  f.wrong_unit_reply = true;
  server().setFaults(f);
  const auto read = reg().readPressureKPa(0);
  ASSERT_FALSE(read);
  EXPECT_THAT(read.error().message,
              HasSubstr("the answer came from another unit id than regulator.unit_id = 1"));
}

TEST_P(ModbusRegulator, ADroppedLinkIsReconnected) {
  start();
  bringUp();
  ModbusServerFaults f;
  f.drop_every = 3;
  server().setFaults(f);
  for (int i = 0; i < 12; ++i) {
    const double kPa = 10.0 * (i + 1);
    const auto s = reg().setPressureKPa(i % 2, kPa);  // a write and a verifying read each
    ASSERT_TRUE(s) << "call " << i << ": " << s.error().message;
    EXPECT_DOUBLE_EQ(server().setpointKPa(i % 2), kPa);
  }
  EXPECT_GE(server().stats().dropped_links, 6);
  EXPECT_GE(reg().linkStats().reconnects, 6);
}

// "localhost:PORT" is resolved (libmodbus' plain TCP constructor took it for
// 255.255.255.255), and so is the IPv6 loopback where the machine has one.
TEST_F(ModbusRegulatorTcp, HostNamesAreResolved) {
  start(serverOptions(ModbusTransport::Tcp, ModbusRegulatorMap::generic10Bar()),
        [](ModbusRegulatorMap& m) { m.link.host = "localhost"; });
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(0, 30.0));
  EXPECT_DOUBLE_EQ(server().setpointKPa(0), 30.0);
}

// TCP: the device's port closes and opens again (RTU's equivalent, a port
// closed for a while, is the dropped-link case).
TEST_F(ModbusRegulatorTcp, ADeviceGoneForGoodIsReportedAndFoundAgainWhenBack) {
  start();
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(0, 30.0));
  const int port = server().port();
  const ModbusServerOptions options = server().options();
  peer_.server.reset();  // the device is switched off
  const auto read = reg().readPressureKPa(0);
  ASSERT_FALSE(read);
  EXPECT_THAT(read.error().message, HasSubstr("regulator \"test-regulator\""));
  EXPECT_THAT(read.error().message, HasSubstr("check that the device is on and reachable at "
                                              "127.0.0.1:" +
                                              std::to_string(port)));
  EXPECT_THAT(read.error().message, HasSubstr("is lost"));
  // Switched on again at the same address: still lost (nothing is asked of a
  // lost device) until it is reopened, which reconnects.
  ModbusServerOptions again = options;
  again.port = port;
  auto s = ModbusRegulatorServer::create(again, nullptr);
  ASSERT_TRUE(s) << s.error().message;
  peer_.server = std::make_unique<ServerThread>(std::move(*s));
  EXPECT_FALSE(reg().setPressureKPa(0, 35.0));
  EXPECT_EQ(server().stats().answered, 0);
  ASSERT_TRUE(reg().close());
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(0, 35.0));
  EXPECT_DOUBLE_EQ(server().setpointKPa(0), 35.0);
}

TEST_P(ModbusRegulator, Float32ControllerWithWordOrder) {
  start(serverOptions(transport(), profileMap("regulator-float32.toml")));
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(1, 87.5));
  EXPECT_DOUBLE_EQ(server().setpointKPa(1), 87.5);
  EXPECT_NEAR(settle(reg(), 1, 0.5), 87.5, 0.5);
}

TEST_P(ModbusRegulator, ALeakingLineNeverSettles) {
  ModbusServerOptions o = serverOptions(transport(), ModbusRegulatorMap::generic10Bar());
  o.dynamics.fault = RegulatorSimSettings::Fault::NeverSettles;
  start(o);
  bringUp();
  ASSERT_TRUE(reg().setPressureKPa(0, 100.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(150));  // 15 time constants
  const auto settled = reg().settled(0, 0.5);
  ASSERT_TRUE(settled);
  EXPECT_FALSE(*settled);
  EXPECT_NEAR(*reg().readPressureKPa(0), 80.0, 0.5);  // stalls at 80 % of the rise
}

INSTANTIATE_TEST_SUITE_P(Transports, ModbusRegulator,
                         ::testing::Values(ModbusTransport::Tcp, ModbusTransport::Rtu),
                         transportName);
