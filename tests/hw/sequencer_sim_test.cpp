// The shot sequencer on the fully simulated rig (config/sim.toml): the happy
// path, and every way a shot can fail, each of which must stop safely.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>

#include "analysis/calibration.hpp"
#include "hw/pressure_regulator_sim.hpp"
#include "hw/sequencer.hpp"
#include "hw/valve_bank_sim.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using collide::hw::testing::rigFrom;
using collide::hw::testing::simProfileText;
using collide::hw::testing::withKey;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

namespace {

std::string thesisProfileText() {
  return collide::hw::testing::readFile(std::string(COLLIDE_SOURCE_DIR) +
                                        "/config/sim-thesis.toml");
}

std::vector<std::string> stepNames(const Shot& shot) {
  std::vector<std::string> names;
  for (const auto& s : shot.steps) names.push_back(s.name);
  return names;
}

const ValveBankSim& simValves(const Rig& rig) {
  return dynamic_cast<const ValveBankSim&>(*rig.valves);
}

bool hasStep(const Shot& shot, const std::string& name, const std::string& detail_part = {}) {
  for (const auto& s : shot.steps)
    if (s.name == name && s.detail.find(detail_part) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST(SequencerSim, HappyPathShotCollidesInsideTheBurstWithTruth) {
  Rig rig = rigFrom(simProfileText());
  Sequencer sequencer(rig);
  std::vector<std::string> progressed;
  const auto wall_start = std::chrono::steady_clock::now();
  const Shot shot = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0),
                                   [&](const StepStamp& s) { progressed.push_back(s.name); });
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  ASSERT_EQ(shot.status, ShotStatus::Ok) << shot.failure_reason;
  EXPECT_TRUE(shot.failure_reason.empty());
  EXPECT_EQ(shot.rig_name, "sim");
  EXPECT_EQ(shot.rig_profile_toml, simProfileText());

  // Steps in order, on one monotonic clock, reported as they happened.
  EXPECT_THAT(stepNames(shot), ElementsAre("start", "bring_up", "set_pressure", "settled", "arm",
                                           "trigger", "fire", "fired", "collected", "stop"));
  EXPECT_EQ(progressed, stepNames(shot));
  for (std::size_t i = 1; i < shot.steps.size(); ++i)
    EXPECT_GE(shot.steps[i].t_ns, shot.steps[i - 1].t_ns) << shot.steps[i].name;

  // Pressures from the calibration, read back settled.
  const auto curve = collide::LaunchCalibration::thesis();
  const double p2 = *curve.pressure_kPa(2.0);
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(shot.launchers[i].wanted_speed_m_s, 2.0, 1e-12);
    EXPECT_NEAR(shot.launchers[i].commanded_kPa, p2, 1e-9);
    EXPECT_NEAR(shot.launchers[i].readback_kPa, p2, 0.5 + 0.3);  // tolerance + read noise
    // Valve pulses recorded as the sim valves achieved them.
    EXPECT_EQ(shot.launchers[i].pulse_us, rig.profile.sequencer.pulse_us);
    EXPECT_GT(shot.launchers[i].valve_open_ns, shot.steps.front().t_ns);
  }
  // Same speed, symmetric tubes: both valves open together (within the jitter).
  EXPECT_LT(std::abs(shot.launchers[0].valve_open_ns - shot.launchers[1].valve_open_ns), 200'000);
  ASSERT_EQ(simValves(rig).log().size(), 2u);

  // The full burst, ids -pre .. post-1.
  const int pre = rig.profile.burst.pre_trigger_frames;
  const int post = rig.profile.burst.post_trigger_frames;
  ASSERT_TRUE(shot.burst.complete) << shot.burst.note;
  ASSERT_EQ(shot.burst.frames.size(), static_cast<std::size_t>(pre + post));
  EXPECT_EQ(shot.burst.frames.front().id, -pre);
  EXPECT_EQ(shot.burst.frames.back().id, post - 1);
  EXPECT_EQ(shot.burst.stats.dropped, 0u);
  EXPECT_EQ(shot.burst.width(), 640);
  EXPECT_EQ(shot.camera.backend, "sim");
  EXPECT_EQ(shot.camera.post_trigger_frames, post);
  EXPECT_DOUBLE_EQ(shot.scene.pixel_size_m, rig.profile.geometry.pixel_size_m);

  // Ground truth: the spheres collide inside the burst, near frame 0 (the
  // predicted contact), apart from the 1 % speed scatter.
  ASSERT_TRUE(shot.truth.has_value());
  const TruthRecord& truth = *shot.truth;
  ASSERT_EQ(truth.frame_id.size(), shot.burst.frames.size());
  EXPECT_GT(truth.t_collision_s, -pre / 1000.0);
  EXPECT_LT(truth.t_collision_s, post / 1000.0);
  EXPECT_LT(std::abs(truth.t_collision_s), 0.003);
  EXPECT_NEAR(truth.material.e, 0.97, 1e-12);
  EXPECT_FALSE(truth.dot_centres[0].empty());

  // A simulated shot takes about its physics (~0.1 s) plus rendering.
  EXPECT_LT(wall_s, 10.0);
}

TEST(SequencerSim, SecondShotReusesTheRig) {
  Rig rig = rigFrom(simProfileText());
  Sequencer sequencer(rig);
  const Shot first = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(first.status, ShotStatus::Ok) << first.failure_reason;
  const Shot second = sequencer.fire(ShotRequest::atPressures(40.0, 30.0));
  ASSERT_EQ(second.status, ShotStatus::Ok) << second.failure_reason;
  EXPECT_TRUE(std::isnan(second.launchers[0].wanted_speed_m_s));
  EXPECT_DOUBLE_EQ(second.launchers[0].commanded_kPa, 40.0);
  // Unequal speeds: the slower sphere's valve opens first.
  EXPECT_LT(second.launchers[1].valve_open_ns, second.launchers[0].valve_open_ns);
  ASSERT_TRUE(second.truth.has_value());
  EXPECT_LT(std::abs(second.truth->t_collision_s), 0.003);
  EXPECT_EQ(simValves(rig).log().size(), 4u);
}

// ---- failure paths: each must fail with a reason and stop safely ----------

TEST(SequencerSim, RegulatorThatNeverSettlesFailsVentsAndNeverFires) {
  std::string text = withKey(simProfileText(), "regulator", "fault", "\"never_settles\"");
  text = withKey(text, "sequencer", "settle_timeout_s", "0.3");
  Rig rig = rigFrom(text);
  const Shot shot = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 2.0));

  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_THAT(shot.failure_reason, HasSubstr("the regulator did not settle within 0.3 s"));
  EXPECT_THAT(shot.failure_reason, HasSubstr("raise sequencer.settle_timeout_s"));
  EXPECT_THAT(stepNames(shot), ElementsAre("start", "bring_up", "set_pressure", "safe_stop"));
  EXPECT_TRUE(hasStep(shot, "safe_stop", "valves closed"));
  EXPECT_TRUE(hasStep(shot, "safe_stop", "pressure vented to 0 kPa"));
  EXPECT_TRUE(simValves(rig).log().empty());
  EXPECT_GE(simValves(rig).closeAllCount(), 1);
  for (int ch = 0; ch < 2; ++ch) EXPECT_EQ(*rig.regulator->setpointKPa(ch), 0.0);
}

TEST(SequencerSim, WithoutVentOnFailureThePressureIsLeftSet) {
  std::string text = withKey(simProfileText(), "regulator", "fault", "\"never_settles\"");
  text = withKey(text, "sequencer", "settle_timeout_s", "0.2");
  text = withKey(text, "safety", "vent_on_failure", "false");
  Rig rig = rigFrom(text);
  const Shot shot = Sequencer(rig).fire(ShotRequest::atPressures(50.0, 50.0));
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_TRUE(hasStep(shot, "safe_stop", "valves closed"));
  EXPECT_FALSE(hasStep(shot, "safe_stop", "vented"));
  EXPECT_EQ(*rig.regulator->setpointKPa(0), 50.0);
}

TEST(SequencerSim, CameraThatStopsEarlyFailsButKeepsTheFramesThatArrived) {
  // The thesis' small frames render fast, so the timeout only waits for the
  // frames that will never come.
  std::string text = withKey(thesisProfileText(), "camera", "stop_after_frames", "5");
  text = withKey(text, "sequencer", "collect_timeout_s", "0.5");
  Rig rig = rigFrom(text);
  const Shot shot = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 2.0));

  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_THAT(shot.failure_reason, HasSubstr("the camera fell short of frames"));
  EXPECT_THAT(shot.failure_reason,
              HasSubstr("5 of " + std::to_string(rig.profile.burst.post_trigger_frames) +
                        " post-trigger frames"));
  EXPECT_FALSE(shot.burst.complete);
  const int pre = rig.profile.burst.pre_trigger_frames;
  ASSERT_EQ(shot.burst.frames.size(), static_cast<std::size_t>(pre + 5));
  EXPECT_EQ(shot.burst.frames.back().id, 4);
  // The valves did fire: the shot failed afterwards, and still stopped safely.
  EXPECT_EQ(simValves(rig).log().size(), 2u);
  EXPECT_TRUE(hasStep(shot, "safe_stop", "pressure vented"));
  EXPECT_EQ(rig.camera->state(), DeviceState::Configured);
  ASSERT_TRUE(shot.truth.has_value());
  EXPECT_EQ(shot.truth->frame_id.size(), shot.burst.frames.size());
}

// A camera slower than real time (the lab preset ray-casts each frame for
// about 10 ms, 130 frames where the burst lasts 130 ms): the sequencer waits on
// while frames keep arriving, collect_timeout_s being the longest silence, so
// the shot is complete although its last frame comes long after the burst's
// end plus the timeout. (Before, it failed: "the camera fell short of frames".)
TEST(SequencerSim, ACameraSlowerThanRealTimeStillDeliversItsBurst) {
  std::string text =
      collide::hw::testing::readFile(std::string(COLLIDE_SOURCE_DIR) + "/config/sim-lab.toml");
  text = withKey(text, "sequencer", "collect_timeout_s", "1.0");
  Rig rig = rigFrom(text);
  const auto start = std::chrono::steady_clock::now();
  const Shot shot = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  const double took_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(shot.status, ShotStatus::Ok) << shot.failure_reason;
  EXPECT_TRUE(shot.burst.complete);
  const int frames = rig.profile.burst.pre_trigger_frames + rig.profile.burst.post_trigger_frames;
  EXPECT_EQ(shot.burst.frames.size(), static_cast<std::size_t>(frames));
  std::printf("slow camera: %d frames collected, the shot took %.2f s\n", frames, took_s);
}

TEST(SequencerSim, TooManyDroppedFramesFailTheShot) {
  const std::string text = withKey(simProfileText(), "camera", "drop_every", "7");
  Rig rig = rigFrom(text);
  const Shot shot = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_THAT(shot.failure_reason, HasSubstr("more than sequencer.max_dropped_frames = 2"));
  // 70 frames, every 7th lost in transport.
  EXPECT_EQ(shot.burst.stats.dropped, 10u);
  EXPECT_EQ(shot.burst.frames.size(), 60u);
}

TEST(SequencerSim, RegulatorLinkFailureFailsTheShotNamingTheDevice) {
  const std::string text = withKey(simProfileText(), "regulator", "fault", "\"error\"");
  Rig rig = rigFrom(text);
  const Shot shot = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_THAT(shot.failure_reason, HasSubstr("regulator \"sim-regulator\": no reply on the link"));
  EXPECT_TRUE(hasStep(shot, "safe_stop", "valves closed"));
  // Venting needs the link too: the reason says it failed.
  EXPECT_THAT(shot.failure_reason, HasSubstr("stopping safely hit the same error"));
  EXPECT_TRUE(simValves(rig).log().empty());
}

TEST(SequencerSim, ValveDriverErrorFailsTheShotAndClosesTheValves) {
  const std::string text = withKey(simProfileText(), "valves", "fault", "\"error\"");
  Rig rig = rigFrom(text);
  const Shot shot = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_THAT(shot.failure_reason, HasSubstr("valves \"sim-valves\": the driver refused"));
  EXPECT_THAT(shot.failure_reason, HasSubstr("all valves closed"));
  EXPECT_TRUE(hasStep(shot, "safe_stop", "pressure vented"));
  EXPECT_EQ(rig.camera->state(), DeviceState::Configured);
}

TEST(SequencerSim, CancelWhileSettlingStopsSafely) {
  Rig rig = rigFrom(simProfileText());
  std::stop_source stop;
  const Shot shot = Sequencer(rig).fire(
      ShotRequest::atSpeeds(2.0, 2.0),
      [&](const StepStamp& s) {
        if (s.name == "set_pressure") stop.request_stop();
      },
      stop.get_token());
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_EQ(shot.failure_reason, "cancelled while the pressure settled");
  EXPECT_TRUE(hasStep(shot, "safe_stop", "valves closed"));
  EXPECT_TRUE(simValves(rig).log().empty());
}

TEST(SequencerSim, CancelAfterArmingNeverFiresAndKeepsThePreTriggerFrames) {
  Rig rig = rigFrom(simProfileText());
  std::stop_source stop;
  const Shot shot = Sequencer(rig).fire(
      ShotRequest::atSpeeds(2.0, 2.0),
      [&](const StepStamp& s) {
        if (s.name == "trigger") stop.request_stop();
      },
      stop.get_token());
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_EQ(shot.failure_reason, "cancelled before firing");
  EXPECT_TRUE(simValves(rig).log().empty());
  EXPECT_FALSE(shot.burst.complete);
  EXPECT_EQ(rig.camera->state(), DeviceState::Configured);
}

TEST(SequencerSim, SpeedOutsideTheCalibrationIsRefusedBeforeAnythingMoves) {
  Rig rig = rigFrom(simProfileText());
  const Shot shot = Sequencer(rig).fire(ShotRequest::atSpeeds(2.0, 50.0));
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_THAT(shot.failure_reason, HasSubstr("launcher right: "));
  EXPECT_THAT(shot.failure_reason, HasSubstr("50"));
  EXPECT_TRUE(simValves(rig).log().empty());
  EXPECT_TRUE(hasStep(shot, "safe_stop", "nothing was running"));
}

TEST(SequencerSim, PressureAboveTheLimitsIsRefusedByTheRegulator) {
  Rig rig = rigFrom(simProfileText());
  const Shot shot = Sequencer(rig).fire(ShotRequest::atPressures(60.0, 240.0));
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  EXPECT_THAT(shot.failure_reason, HasSubstr("240 kPa on channel 1 is outside the limits 0..200"));
  EXPECT_TRUE(simValves(rig).log().empty());
}
