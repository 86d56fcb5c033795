// A whole shot on config/regulator-generic-10bar.toml: the Modbus regulator
// (talking to the simulated Modbus regulator over loopback TCP) with the
// simulated valves and camera. The sequencer sets, verifies and waits for the
// pressure over Modbus, and the simulated spheres leave their tubes at the
// pressure the Modbus device measured.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "hw/pressure_regulator_modbus.hpp"
#include "hw/sequencer.hpp"
#include "modbus_peer.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using namespace collide::hw::testing;
using ::testing::HasSubstr;

namespace {

std::string genericProfileAt(int port) {
  const std::string text =
      readFile(std::string(COLLIDE_SOURCE_DIR) + "/config/regulator-generic-10bar.toml");
  return withKey(text, "regulator", "device", "\"127.0.0.1:" + std::to_string(port) + "\"");
}

}  // namespace

TEST(ModbusRig, AShotWithTheModbusRegulatorLaunchesAtTheMeasuredPressure) {
  ModbusPeer peer =
      startModbusPeer(serverOptions(ModbusTransport::Tcp, ModbusRegulatorMap::generic10Bar()));
  ASSERT_TRUE(peer.error.empty()) << peer.error;
  auto profile = parseRigProfile(genericProfileAt(peer.srv().port()), "generic.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  auto rig = makeRig(*profile);
  ASSERT_TRUE(rig) << rig.error().message;
  ASSERT_EQ(rig->regulator->info().backend, "modbus");

  Sequencer sequencer(*rig);
  const Shot shot = sequencer.fire(ShotRequest::atPressures(60.0, 45.0));
  ASSERT_EQ(shot.status, ShotStatus::Ok) << shot.failure_reason;
  // The device holds the setpoints the sequencer wrote ...
  EXPECT_DOUBLE_EQ(peer.srv().setpointKPa(0), 60.0);
  EXPECT_DOUBLE_EQ(peer.srv().setpointKPa(1), 45.0);
  // ... the shot records what the device measured ...
  EXPECT_DOUBLE_EQ(shot.launchers[0].commanded_kPa, 60.0);
  EXPECT_NEAR(shot.launchers[0].readback_kPa, 60.0, 0.5);
  EXPECT_NEAR(shot.launchers[1].readback_kPa, 45.0, 0.5);
  // ... and the simulated spheres flew at that pressure (ground truth).
  ASSERT_TRUE(shot.truth.has_value());
  EXPECT_FALSE(shot.truth->states.empty());
  EXPECT_TRUE(std::isfinite(shot.truth->t_collision_s)) << "the spheres did not collide";
  EXPECT_TRUE(shutDown(*rig));
}

TEST(ModbusRig, ARegulatorThatStopsAnsweringFailsTheShotSafely) {
  ModbusPeer peer =
      startModbusPeer(serverOptions(ModbusTransport::Tcp, ModbusRegulatorMap::generic10Bar()));
  ASSERT_TRUE(peer.error.empty()) << peer.error;
  auto profile = parseRigProfile(genericProfileAt(peer.srv().port()), "generic.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  auto rig = makeRig(*profile);
  ASSERT_TRUE(rig) << rig.error().message;
  ASSERT_TRUE(bringUp(*rig));
  ModbusServerFaults f;
  f.exception_code = 4;
  peer.srv().setFaults(f);
  Sequencer sequencer(*rig);
  const Shot shot = sequencer.fire(ShotRequest::atPressures(60.0, 45.0));
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_THAT(shot.failure_reason, HasSubstr("regulator \"127.0.0.1:"));
  EXPECT_THAT(shot.failure_reason, HasSubstr("Modbus exception 4"));
  // An exception is an answer (a device fault or a wrong profile), not
  // silence: the regulator is not lost, and the message says a retry alone
  // will not help.
  EXPECT_THAT(shot.failure_reason, HasSubstr("retrying will not help until that is fixed"));
  EXPECT_FALSE(rig->regulator->loss());
}

// The device falls silent (answers later than regulator.timeout_ms): the shot
// fails after the link's retries, the regulator is lost, and the next shot is
// refused without a single request reaching the device; reopening (re-check)
// finds it again once it answers in time.
TEST(ModbusRig, ARegulatorThatFallsSilentIsLostAndTheNextShotIsRefusedWithoutARequest) {
  ModbusPeer peer =
      startModbusPeer(serverOptions(ModbusTransport::Tcp, ModbusRegulatorMap::generic10Bar()));
  ASSERT_TRUE(peer.error.empty()) << peer.error;
  auto profile = parseRigProfile(genericProfileAt(peer.srv().port()), "generic.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  auto rig = makeRig(*profile);
  ASSERT_TRUE(rig) << rig.error().message;
  ASSERT_TRUE(bringUp(*rig));
  ModbusServerFaults slow;
  slow.delay_ms = 300;  // the client waits 200 ms (regulator.timeout_ms)
  peer.srv().setFaults(slow);
  Sequencer sequencer(*rig);
  const Shot lost = sequencer.fire(ShotRequest::atPressures(60.0, 45.0));
  ASSERT_EQ(lost.status, ShotStatus::Failed);
  EXPECT_THAT(lost.failure_reason, HasSubstr("is lost ("));
  EXPECT_THAT(lost.failure_reason, HasSubstr("no answer within"));
  EXPECT_THAT(lost.failure_reason, HasSubstr("retrying will not help"));
  ASSERT_TRUE(rig->regulator->loss());

  const auto& modbus = dynamic_cast<const PressureRegulatorModbus&>(*rig->regulator);
  const std::int64_t requests = modbus.linkStats().requests;
  const Shot refused = sequencer.fire(ShotRequest::atPressures(60.0, 45.0));
  ASSERT_EQ(refused.status, ShotStatus::Failed);
  EXPECT_THAT(refused.failure_reason, HasSubstr("refused: regulator \"127.0.0.1:"));
  ASSERT_EQ(refused.steps.size(), 2u);
  EXPECT_EQ(refused.steps[1].name, "refused");
  EXPECT_EQ(modbus.linkStats().requests, requests) << "no request was sent to the lost regulator";

  peer.srv().setFaults({});
  std::this_thread::sleep_for(std::chrono::milliseconds(900));  // the server works off its backlog
  const collide::Status found = recheck(*rig);
  ASSERT_TRUE(found) << found.error().message;
  const Shot again = sequencer.fire(ShotRequest::atPressures(60.0, 45.0));
  EXPECT_EQ(again.status, ShotStatus::Ok) << again.failure_reason;
  EXPECT_TRUE(shutDown(*rig));
}
