// A device that stops answering is "lost" (hw/device_health.hpp): the shot it
// failed in stops safely, every later shot is refused at once without asking
// anything of any device (counted by the simulated hardware, not timed), and
// only recheck() finds it again. Real simulated devices: the sim regulator's
// fault = "silent" and the sim camera's silent_after_bursts (sim_silence.hpp).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "hw/sequencer.hpp"
#include "hw/sim_silence.hpp"
#include "hw/valve_bank_sim.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using collide::hw::testing::rigFrom;
using collide::hw::testing::simProfileText;
using collide::hw::testing::withKey;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

// sim.toml with a regulator (device `device`) that answers `setpoints`
// setpoints, then goes silent.
std::string silentRegulatorText(const std::string& device, int setpoints) {
  std::string t = withKey(simProfileText(), "regulator", "device", "\"" + device + "\"");
  t = withKey(t, "regulator", "fault", "\"silent\"");
  t = withKey(t, "regulator", "silent_after_setpoints", std::to_string(setpoints));
  return withKey(t, "regulator", "silent_timeout_ms", "50");
}

// sim.toml with a camera (device `device`) that delivers `bursts` bursts, then
// no frame; a short collect timeout so the silent shot does not wait long.
std::string silentCameraText(const std::string& device, int bursts) {
  std::string t = withKey(simProfileText(), "camera", "device", "\"" + device + "\"");
  t = withKey(t, "camera", "silent_after_bursts", std::to_string(bursts));
  return withKey(t, "sequencer", "collect_timeout_s", "0.3");
}

std::size_t valveOpenings(const Rig& rig) {
  return dynamic_cast<const ValveBankSim&>(*rig.valves).log().size();
}

std::vector<std::string> stepNames(const Shot& shot) {
  std::vector<std::string> names;
  for (const auto& s : shot.steps) names.push_back(s.name);
  return names;
}

}  // namespace

TEST(DeviceLostSim, ASilentRegulatorIsLostAndTheNextShotIsRefusedWithoutAskingIt) {
  Rig rig = rigFrom(silentRegulatorText("lost-regulator-1", 2));
  Sequencer sequencer(rig);
  const Shot first = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(first.status, ShotStatus::Ok) << first.failure_reason;
  ASSERT_EQ(valveOpenings(rig), 2u);
  const std::shared_ptr<SimSilence> hardware = SimSilence::find("regulator \"lost-regulator-1\"");
  ASSERT_NE(hardware, nullptr);
  EXPECT_EQ(hardware->unanswered(), 0);

  // The third setpoint goes unanswered: one request waits its timeout, the
  // regulator is lost, the shot stops safely without venting through it.
  const Shot second = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(second.status, ShotStatus::Failed);
  EXPECT_THAT(second.failure_reason, StartsWith("regulator \"lost-regulator-1\" is lost (no answer "
                                                "within 50 ms"));
  EXPECT_THAT(second.failure_reason, HasSubstr("retrying will not help"));
  EXPECT_THAT(second.failure_reason, HasSubstr("check the regulator's power and cable"));
  EXPECT_EQ(hardware->unanswered(), 1) << "the safe stop must not ask the lost regulator again";
  EXPECT_THAT(second.failure_reason,
              HasSubstr("while stopping safely: the pressure was not vented (the regulator does "
                        "not answer): vent the lines by hand"));
  EXPECT_EQ(valveOpenings(rig), 2u) << "no valve opened in the failed shot";
  ASSERT_TRUE(rig.regulator->loss());
  EXPECT_FALSE(rig.camera->loss());

  // Every later shot: refused before any device is asked anything.
  for (int i = 0; i < 2; ++i) {
    const Shot refused = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
    ASSERT_EQ(refused.status, ShotStatus::Failed);
    EXPECT_THAT(refused.failure_reason,
                StartsWith("refused: regulator \"lost-regulator-1\" is lost (no answer"));
    EXPECT_THAT(stepNames(refused), ElementsAre("start", "refused"));
    EXPECT_TRUE(refused.burst.frames.empty());
  }
  EXPECT_EQ(hardware->unanswered(), 1) << "a lost regulator is not asked again";
  EXPECT_EQ(valveOpenings(rig), 2u);
  // Direct calls are refused at once too, with the same message.
  const auto read = rig.regulator->readPressureKPa(0);
  ASSERT_FALSE(read);
  EXPECT_THAT(read.error().message, HasSubstr("is lost"));
  EXPECT_EQ(hardware->unanswered(), 1);
}

TEST(DeviceLostSim, RecheckFindsARegulatorAgainOnlyOnceItAnswers) {
  Rig rig = rigFrom(silentRegulatorText("lost-regulator-2", 0));
  Sequencer sequencer(rig);
  ASSERT_EQ(sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0)).status, ShotStatus::Failed);
  ASSERT_TRUE(rig.regulator->loss());
  const std::shared_ptr<SimSilence> hardware = SimSilence::find("regulator \"lost-regulator-2\"");
  ASSERT_NE(hardware, nullptr);

  // Still silent: the re-check asks it (once) and it stays lost.
  const std::int64_t before = hardware->unanswered();
  const collide::Status still = recheck(rig);
  ASSERT_FALSE(still);
  EXPECT_THAT(still.error().message, HasSubstr("is lost"));
  EXPECT_GT(hardware->unanswered(), before);
  EXPECT_TRUE(rig.regulator->loss());
  EXPECT_EQ(sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0)).status, ShotStatus::Failed);

  // Plugged back in: the re-check clears it and the next shot fires.
  hardware->answerAgain();
  ASSERT_TRUE(recheck(rig)) << "the regulator answers again";
  EXPECT_FALSE(rig.regulator->loss());
  EXPECT_TRUE(rig.health->ready());
  const Shot shot = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  EXPECT_EQ(shot.status, ShotStatus::Ok) << shot.failure_reason;
  EXPECT_EQ(valveOpenings(rig), 2u);
}

TEST(DeviceLostSim, ACameraThatDeliversNothingIsLostTheNextShotRefusedAndRecheckClearsIt) {
  Rig rig = rigFrom(silentCameraText("lost-camera-1", 1));
  Sequencer sequencer(rig);
  const Shot first = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(first.status, ShotStatus::Ok) << first.failure_reason;
  const std::shared_ptr<SimSilence> hardware = SimSilence::find("camera \"lost-camera-1\"");
  ASSERT_NE(hardware, nullptr);

  const Shot second = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(second.status, ShotStatus::Failed);
  EXPECT_THAT(
      second.failure_reason,
      StartsWith("camera \"lost-camera-1\" is lost (it delivered no frame after the trigger"));
  EXPECT_THAT(second.failure_reason, HasSubstr("retrying will not help"));
  EXPECT_EQ(hardware->unanswered(), 1);
  ASSERT_TRUE(rig.camera->loss());
  const std::size_t opened = valveOpenings(rig);

  const Shot refused = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(refused.status, ShotStatus::Failed);
  EXPECT_THAT(refused.failure_reason, StartsWith("refused: camera \"lost-camera-1\" is lost"));
  EXPECT_THAT(stepNames(refused), ElementsAre("start", "refused"));
  EXPECT_EQ(hardware->unanswered(), 1) << "the lost camera was not armed again";
  EXPECT_EQ(valveOpenings(rig), opened) << "no valve opened for the refused shot";

  hardware->answerAgain();
  const collide::Status found = recheck(rig);
  ASSERT_TRUE(found) << found.error().message;
  EXPECT_FALSE(rig.camera->loss());
  const Shot again = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  EXPECT_EQ(again.status, ShotStatus::Ok) << again.failure_reason;
}

TEST(DeviceLostSim, AHealthSharedByRigsBuiltInTurnKeepsTheLossForTheNextRig) {
  // A campaign builds one rig per shot for the same devices.
  const std::string text = silentRegulatorText("lost-regulator-3", 0);
  auto health = std::make_shared<DeviceHealth>();
  auto profile = parseRigProfile(text, "sim.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  {
    auto rig = makeRig(*profile, {.health = health});
    ASSERT_TRUE(rig) << rig.error().message;
    ASSERT_EQ(Sequencer(*rig).fire(ShotRequest::atSpeeds(2.0, 2.0)).status, ShotStatus::Failed);
    (void)shutDown(*rig);
  }
  const std::shared_ptr<SimSilence> hardware = SimSilence::find("regulator \"lost-regulator-3\"");
  ASSERT_NE(hardware, nullptr);
  EXPECT_EQ(hardware->unanswered(), 1);
  auto rig = makeRig(*profile, {.health = health});
  ASSERT_TRUE(rig) << rig.error().message;
  const Shot refused = Sequencer(*rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  EXPECT_THAT(refused.failure_reason, StartsWith("refused: regulator \"lost-regulator-3\""));
  EXPECT_EQ(rig->regulator->state(), DeviceState::Closed) << "not even opened";
  EXPECT_EQ(hardware->unanswered(), 1);
  // A rig with a health of its own (a new program run) asks the device again.
  auto fresh = makeRig(*profile);
  ASSERT_TRUE(fresh) << fresh.error().message;
  EXPECT_FALSE(fresh->health->loss("regulator \"lost-regulator-3\""));
}

TEST(DeviceLostSim, AFailureThatIsNotSilenceDoesNotLoseTheDevice) {
  // fault = "error": the link refuses at once (an answer, not silence).
  Rig rig = rigFrom(withKey(simProfileText(), "regulator", "fault", "\"error\""));
  Sequencer sequencer(rig);
  EXPECT_EQ(sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0)).status, ShotStatus::Failed);
  EXPECT_FALSE(rig.regulator->loss());
  EXPECT_TRUE(rig.health->ready());
}

TEST(DeviceLostSim, RecheckProbesAndClearsEveryLostDeviceThatAnswers) {
  Rig rig = rigFrom(simProfileText());
  ASSERT_TRUE(bringUp(rig));
  EXPECT_TRUE(recheck(rig)) << "nothing lost: nothing to do";
  (void)rig.camera->markLost("a test said so", "nothing");
  (void)rig.regulator->markLost("a test said so", "nothing");
  EXPECT_EQ(rig.health->lost().size(), 2u);
  const collide::Status found = recheck(rig);
  ASSERT_TRUE(found) << found.error().message;
  EXPECT_TRUE(rig.health->lost().empty());
  EXPECT_EQ(rig.camera->state(), DeviceState::Running);
  const Shot shot = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  EXPECT_EQ(shot.status, ShotStatus::Ok) << shot.failure_reason;
}

TEST(DeviceLostSim, ADeviceLostInItsOwnHealthRefusesTheShotToo) {
  // A rig put together by hand leaves each device its own health.
  Rig rig = rigFrom(simProfileText());
  rig.regulator->setHealth(std::make_shared<DeviceHealth>());
  (void)rig.regulator->markLost("no answer (a test said so)", "nothing");
  EXPECT_TRUE(rig.health->ready()) << "the rig's health does not know";
  const Shot refused = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  EXPECT_THAT(refused.failure_reason, StartsWith("refused: regulator \"sim-regulator\" is lost"));
  EXPECT_THAT(stepNames(refused), ElementsAre("start", "refused"));
  EXPECT_EQ(valveOpenings(rig), 0u);
}
