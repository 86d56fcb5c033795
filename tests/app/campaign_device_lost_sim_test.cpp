// A device that stops answering mid-campaign (hw/device_health.hpp): the
// campaign's next shot is refused at once, without asking anything of any
// device (the simulated hardware counts the requests it left unanswered), no
// valve fires, the shots already saved are intact, and the campaign says why
// it stopped.
#include <gtest/gtest.h>

#include <filesystem>
#include <utility>
#include <vector>

#include "app/campaign.hpp"
#include "app/store/shot_file.hpp"
#include "hw/rig_profile.hpp"
#include "hw/sim_silence.hpp"
#include "shot_fixtures.hpp"
#include "tests/hw/profile_text.hpp"

namespace collide::app {
namespace {

// The default profile with `keys` (key, TOML value) set in `section`.
hw::RigProfile editedProfile(const std::string& section,
                             const std::vector<std::pair<std::string, std::string>>& keys) {
  std::string text(hw::defaultRigProfileText());
  for (const auto& [key, value] : keys) text = hw::testing::withKey(text, section, key, value);
  auto p = hw::parseRigProfile(text, "sim.toml (edited)");
  EXPECT_TRUE(p.ok()) << p.error().message;
  return *p;
}

// Every file the campaign reports is there and reads back whole, frames and
// all; returns how many are ok shots.
int intactOkShots(const CampaignReport& report) {
  int ok = 0;
  for (const std::string& file : report.files) {
    auto shot = readShot(file);
    EXPECT_TRUE(shot.ok()) << file << ": " << shot.error().message;
    if (!shot) continue;
    if (shot->status == hw::ShotStatus::Ok) {
      ++ok;
      EXPECT_FALSE(shot->burst.frames.empty()) << file;
    }
  }
  return ok;
}

// Valve openings recorded in the shots (the "fired" step is stamped only once
// the valves have opened).
int firedSteps(const CampaignReport& report) {
  int fired = 0;
  for (const std::string& file : report.files) {
    auto shot = readShot(file, {.frames = false});
    if (!shot) continue;
    for (const auto& step : shot->steps) fired += step.name == "fired";
  }
  return fired;
}

TEST(CampaignDeviceLost, ARegulatorSilentMidCampaignStopsItBeforeTheNextShot) {
  testing::ScratchDir dir;
  const hw::RigProfile profile =
      editedProfile("regulator", {{"device", "\"campaign-lost-regulator\""},
                                  {"fault", "\"silent\""},
                                  {"silent_after_setpoints", "4"},
                                  {"silent_timeout_ms", "50"}});
  CampaignOptions options;
  options.shots = 6;
  options.out_dir = dir.path();
  options.seed = 3;
  auto report = runCampaign(profile, options);
  ASSERT_TRUE(report) << report.error().message;

  // Shots 1 and 2 spend the 4 setpoints; shot 3's first one goes unanswered.
  EXPECT_EQ(report->fired, 3);
  EXPECT_EQ(report->ok, 2);
  EXPECT_EQ(report->failed, 1);
  EXPECT_EQ(report->not_fired, 3);
  EXPECT_FALSE(report->cancelled);
  EXPECT_EQ(report->stopped_because.rfind("the next shot was refused: regulator "
                                          "\"campaign-lost-regulator\" is lost (no answer",
                                          0),
            0u)
      << report->stopped_because;
  EXPECT_NE(report->stopped_because.find("retrying will not help"), std::string::npos);
  ASSERT_EQ(report->failures.size(), 1u);
  EXPECT_NE(report->failures[0].find("is lost"), std::string::npos) << report->failures[0];

  const auto hardware = hw::SimSilence::find("regulator \"campaign-lost-regulator\"");
  ASSERT_NE(hardware, nullptr);
  EXPECT_EQ(hardware->unanswered(), 1) << "one request timed out; nothing asked it again";
  ASSERT_EQ(report->files.size(), 3u);
  EXPECT_EQ(intactOkShots(*report), 2);
  EXPECT_EQ(firedSteps(*report), 2) << "valves fired in the two good shots only";
}

TEST(CampaignDeviceLost, ACameraSilentMidCampaignStopsItBeforeTheNextShot) {
  testing::ScratchDir dir;
  const hw::RigProfile profile = editedProfile(
      "camera", {{"device", "\"campaign-lost-camera\""}, {"silent_after_bursts", "2"}});
  CampaignOptions options;
  options.shots = 5;
  options.out_dir = dir.path();
  options.seed = 4;
  auto report = runCampaign(profile, options);
  ASSERT_TRUE(report) << report.error().message;

  EXPECT_EQ(report->fired, 3);
  EXPECT_EQ(report->ok, 2);
  EXPECT_EQ(report->failed, 1);
  EXPECT_EQ(report->not_fired, 2);
  EXPECT_EQ(report->stopped_because.rfind(
                "the next shot was refused: camera \"campaign-lost-camera\" is lost (it "
                "delivered no frame after the trigger",
                0),
            0u)
      << report->stopped_because;
  const auto hardware = hw::SimSilence::find("camera \"campaign-lost-camera\"");
  ASSERT_NE(hardware, nullptr);
  EXPECT_EQ(hardware->unanswered(), 1) << "the lost camera was not armed again";
  ASSERT_EQ(report->files.size(), 3u);
  EXPECT_EQ(intactOkShots(*report), 2);
  // The valves fired in the shot that lost the camera (it went silent during
  // the burst), never after.
  EXPECT_EQ(firedSteps(*report), 3);
}

}  // namespace
}  // namespace collide::app
