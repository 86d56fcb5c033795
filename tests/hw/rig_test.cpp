// makeRig: one line of the profile picks each backend from the registry.
#include "hw/rig.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "hw/backend_registry.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using collide::hw::testing::lineOf;
using collide::hw::testing::simProfileText;
using collide::hw::testing::withKey;
using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

RigProfile profileFrom(const std::string& text) {
  auto p = parseRigProfile(text, "rig.toml");
  if (!p) throw std::runtime_error(p.error().message);
  return *p;
}

// A stand-in backend registered by the test itself, as a later backend
// (aravis, gpiod, modbus) registers from its own file.
class TestRegulator final : public PressureRegulator {
 public:
  explicit TestRegulator(std::string address)
      : PressureRegulator("regulator \"test\""), address_(std::move(address)) {}
  RegulatorInfo info() const override { return {"test", address_, 2, 0.0, 500.0}; }
  std::string address_;

 protected:
  collide::Status onOpen() override { return collide::Ok{}; }
  collide::Status onConfigure(const RegulatorConfig&) override { return collide::Ok{}; }
  collide::Status onStart() override { return collide::Ok{}; }
  collide::Status onStop() override { return collide::Ok{}; }
  collide::Status onClose() override { return collide::Ok{}; }
  collide::Status onSetPressureKPa(int, double) override { return collide::Ok{}; }
  collide::Result<double> onReadPressureKPa(int) override { return 0.0; }
};

const bool test_backend_registered = BackendRegistry<PressureRegulator>::instance().add(
    "test", [](BackendContext& ctx) -> collide::Result<std::unique_ptr<PressureRegulator>> {
      SettingsReader r = ctx.device.backendSettings();
      auto address = r.text("address");
      if (!address) return address.error();
      if (auto s = r.finish("the test regulator backend"); !s) return s.error();
      return std::unique_ptr<PressureRegulator>(std::make_unique<TestRegulator>(*address));
    });

}  // namespace

TEST(Rig, BuildsTheSimulatedDevicesTheProfileNames) {
  auto rig = makeRig(profileFrom(simProfileText()));
  ASSERT_TRUE(rig) << rig.error().message;
  EXPECT_EQ(rig->regulator->info().backend, "sim");
  EXPECT_EQ(rig->valves->info().device, "sim-valves");
  EXPECT_EQ(rig->camera->info().sensor_width, 640);
  EXPECT_TRUE(rig->camera->groundTruth());
  EXPECT_EQ(rig->regulator->state(), DeviceState::Closed);
}

TEST(Rig, BringUpRunsEveryDeviceAndShutDownClosesThem) {
  auto rig = makeRig(profileFrom(simProfileText()));
  ASSERT_TRUE(rig);
  ASSERT_TRUE(bringUp(*rig));
  EXPECT_EQ(rig->regulator->state(), DeviceState::Running);
  EXPECT_EQ(rig->valves->state(), DeviceState::Running);
  EXPECT_EQ(rig->camera->state(), DeviceState::Running);
  EXPECT_EQ(rig->regulator->config().max_kPa, 200.0);  // capped by the safety limit
  EXPECT_EQ(rig->camera->config().width, 640);
  ASSERT_TRUE(bringUp(*rig));  // already running: nothing to do
  ASSERT_TRUE(shutDown(*rig));
  EXPECT_EQ(rig->camera->state(), DeviceState::Closed);
  EXPECT_EQ(rig->valves->state(), DeviceState::Closed);
  EXPECT_EQ(rig->regulator->state(), DeviceState::Closed);
}

TEST(Rig, ALaterBackendRegistersItselfAndReadsItsOwnSettings) {
  ASSERT_TRUE(test_backend_registered);
  std::string text = withKey(simProfileText(), "regulator", "backend", "\"test\"");
  for (const char* k : {"channels", "time_constant_ms", "hold_band_kpa", "noise_kpa", "fault"})
    text = collide::hw::testing::withoutKey(text, "regulator", k);
  text = withKey(text, "regulator", "address", "\"10.0.0.7:502\"");
  auto rig = makeRig(profileFrom(text));
  ASSERT_TRUE(rig) << rig.error().message;
  EXPECT_EQ(rig->regulator->info().device, "10.0.0.7:502");
  EXPECT_THAT(BackendRegistry<PressureRegulator>::instance().names(), Contains("test"));
}

TEST(Rig, AnotherBackendsSettingIsRefusedWithItsLine) {
  const std::string text = withKey(simProfileText(), "camera", "packet_size", "9000");
  auto rig = makeRig(profileFrom(text));
  ASSERT_FALSE(rig);
  EXPECT_EQ(rig.error().message,
            "rig.toml:" + std::to_string(lineOf(text, "camera", "packet_size")) +
                ": camera.packet_size: unknown setting for the sim camera backend (a typo, or a "
                "setting of another backend?)");
}

TEST(Rig, BackendSettingOutOfRangeIsRefusedWithItsLine) {
  const std::string text = withKey(simProfileText(), "regulator", "time_constant_ms", "0");
  auto rig = makeRig(profileFrom(text));
  ASSERT_FALSE(rig);
  EXPECT_EQ(rig.error().message,
            "rig.toml:" + std::to_string(lineOf(text, "regulator", "time_constant_ms")) +
                ": regulator.time_constant_ms = 0: must be > 0 and <= 60000");
}

TEST(Rig, UnknownBackendInAProfileBuiltByCodeNamesTheKnownOnes) {
  RigProfile p = profileFrom(simProfileText());
  p.valves.backend = "nonesuch";
  auto rig = makeRig(p);
  ASSERT_FALSE(rig);
  EXPECT_THAT(
      rig.error().message,
      StartsWith("rig.toml:" + std::to_string(lineOf(simProfileText(), "valves", "backend")) +
                 ": valves.backend = \"nonesuch\": unknown backend (known: "));
  EXPECT_THAT(rig.error().message, HasSubstr("\"sim\""));
  EXPECT_THAT(rig.error().message, HasSubstr("\"gpiod\""));
}

TEST(Rig, SimulatedCameraRefusesAnInjectedClock) {
  RigHooks hooks;
  hooks.clock = std::make_shared<ManualClock>();
  auto rig = makeRig(profileFrom(simProfileText()), hooks);
  ASSERT_FALSE(rig);
  EXPECT_THAT(rig.error().message, HasSubstr("runs on CLOCK_MONOTONIC"));
}
