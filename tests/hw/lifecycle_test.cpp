#include "hw/lifecycle.hpp"

#include <gtest/gtest.h>

using collide::Ok;
using collide::Status;
using collide::hw::DeviceState;
using collide::hw::Lifecycle;

namespace {
Status ok() {
  return Ok{};
}
Status broken() {
  return collide::fail("hardware says no");
}
}  // namespace

TEST(Lifecycle, WalksClosedOpenConfiguredRunningAndBack) {
  Lifecycle l("camera \"test\"");
  EXPECT_EQ(l.state(), DeviceState::Closed);
  ASSERT_TRUE(l.open(ok));
  EXPECT_EQ(l.state(), DeviceState::Open);
  ASSERT_TRUE(l.configure(ok));
  ASSERT_TRUE(l.configure(ok));  // reconfiguring is allowed
  EXPECT_EQ(l.state(), DeviceState::Configured);
  ASSERT_TRUE(l.start(ok));
  EXPECT_EQ(l.state(), DeviceState::Running);
  ASSERT_TRUE(l.stop(ok));
  EXPECT_EQ(l.state(), DeviceState::Configured);
  ASSERT_TRUE(l.close(ok, ok));
  EXPECT_EQ(l.state(), DeviceState::Closed);
}

TEST(Lifecycle, RefusesOutOfOrderCallsNamingDeviceStateAndNextStep) {
  Lifecycle l("valves \"sim\"");
  const Status s = l.start(ok);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().message,
            "valves \"sim\": start() refused: the device is closed; call open() first");
  ASSERT_TRUE(l.open(ok));
  EXPECT_EQ(l.start(ok).error().message,
            "valves \"sim\": start() refused: the device is open; call configure() first");
  EXPECT_FALSE(l.open(ok));
  EXPECT_FALSE(l.stop(ok));
  EXPECT_EQ(l.state(), DeviceState::Open);
}

TEST(Lifecycle, RequirePointsBackwardsWhenTheDeviceIsTooFarAlong) {
  Lifecycle l("camera \"sim\"");
  ASSERT_TRUE(l.open(ok));
  ASSERT_TRUE(l.configure(ok));
  ASSERT_TRUE(l.start(ok));
  const Status s = l.configure(ok);
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("is running; call stop() first"), std::string::npos)
      << s.error().message;
  EXPECT_TRUE(l.require("x()", {DeviceState::Running}));
}

TEST(Lifecycle, AFailingHookKeepsTheState) {
  Lifecycle l("regulator \"sim\"");
  ASSERT_TRUE(l.open(ok));
  ASSERT_TRUE(l.configure(ok));
  const Status s = l.start(broken);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().message, "hardware says no");
  EXPECT_EQ(l.state(), DeviceState::Configured);
}

TEST(Lifecycle, CloseFromRunningStopsFirstAndEndsClosedEvenOnError) {
  Lifecycle l("camera \"sim\"");
  ASSERT_TRUE(l.open(ok));
  ASSERT_TRUE(l.configure(ok));
  ASSERT_TRUE(l.start(ok));
  int stops = 0;
  const Status s = l.close(
      [&] {
        ++stops;
        return broken();
      },
      ok);
  EXPECT_EQ(stops, 1);
  EXPECT_FALSE(s);
  EXPECT_EQ(l.state(), DeviceState::Closed);
  EXPECT_FALSE(l.close(ok, ok));  // already closed
}

TEST(Lifecycle, CloseFromConfiguredDoesNotRunTheStopHook) {
  Lifecycle l("camera \"sim\"");
  ASSERT_TRUE(l.open(ok));
  ASSERT_TRUE(l.configure(ok));
  int stops = 0;
  EXPECT_TRUE(l.close(
      [&] {
        ++stops;
        return ok();
      },
      ok));
  EXPECT_EQ(stops, 0);
}

TEST(Lifecycle, ALostDeviceRefusesConfigureAndStartWithoutAskingItButStopsClosesAndReopens) {
  Lifecycle l("camera \"lab\"");
  ASSERT_TRUE(l.open(ok));
  ASSERT_TRUE(l.configure(ok));
  ASSERT_TRUE(l.start(ok));
  ASSERT_TRUE(l.stop(ok));
  const std::string lost = l.markLost("it stopped answering", "its power and cable").message;
  int asked = 0;
  const auto ask = [&] {
    ++asked;
    return ok();
  };
  for (const Status& s : {l.start(ask), l.configure(ask)}) {
    ASSERT_FALSE(s);
    EXPECT_EQ(s.error().message, lost);
    EXPECT_NE(s.error().message.find("retrying will not help"), std::string::npos);
  }
  EXPECT_EQ(asked, 0) << "a lost device was asked anyway";
  EXPECT_EQ(l.state(), DeviceState::Configured);
  // The state check alone passes: calls that ask the device nothing.
  EXPECT_TRUE(l.requireState("takeBurst()", {DeviceState::Configured}));
  EXPECT_FALSE(l.require("takeBurst()", {DeviceState::Configured}));
  ASSERT_TRUE(l.close(ok, ask));
  EXPECT_EQ(asked, 1) << "closing a lost device must still run its hook";
  ASSERT_TRUE(l.open(ok));  // reopened: it answers again
  EXPECT_FALSE(l.loss());
  EXPECT_TRUE(l.configure(ok));
}
