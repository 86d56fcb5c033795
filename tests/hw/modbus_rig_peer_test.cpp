// A whole shot on config/regulator-generic-10bar.toml: the Modbus regulator
// (talking to the simulated Modbus regulator over loopback TCP) with the
// simulated valves and camera. The sequencer sets, verifies and waits for the
// pressure over Modbus, and the simulated spheres leave their tubes at the
// pressure the Modbus device measured.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

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
}
