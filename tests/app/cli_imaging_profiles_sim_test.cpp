// `collide campaign` on each realistic-imaging profile (issue 11): the lab,
// the thesis and the backlit rig run end to end, and every shot file keeps the
// imaging it was filmed with (the profile text, [camera.imaging] included) and
// its ground truth.
#include <gtest/gtest.h>

#include <filesystem>

#include "app/store/shot_file.hpp"
#include "tests/app/cli_run.hpp"

namespace collide::testing {
namespace {

class CliImagingProfiles : public ::testing::TestWithParam<std::string> {};

TEST_P(CliImagingProfiles, CampaignRunsAndShotsKeepTheirImagingAndTruth) {
  const std::string rig = std::string(COLLIDE_SOURCE_DIR) + "/config/" + GetParam();
  const std::string profile_text = readAll(rig);
  const auto header = profile_text.find("\n[camera.imaging]\n");
  ASSERT_NE(header, std::string::npos);
  const auto begin = header + 1;
  const std::string imaging = profile_text.substr(begin, profile_text.find("\n[", begin) - begin);
  ASSERT_GT(imaging.size(), 100u);
  ScratchDir scratch;
  const std::string out = scratch.file("shots");
  const auto run = runCollide("campaign --rig " + q(rig) + " --shots 2 --out " + q(out), scratch);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  int shots = 0;
  for (const auto& e : std::filesystem::directory_iterator(out)) {
    if (e.path().extension() != ".h5") continue;
    const auto shot = app::readShot(e.path().string());
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    // The profile as used (the campaign moves the second muzzle for each
    // incidence angle), with the imaging table exactly as written.
    EXPECT_NE(shot->rig_profile_toml.find(imaging), std::string::npos);
    ASSERT_TRUE(shot->truth.has_value());
    EXPECT_EQ(shot->truth->states.size(), shot->burst.frames.size());
    EXPECT_FALSE(shot->burst.frames.empty());
    ++shots;
  }
  EXPECT_EQ(shots, 2);
}

INSTANTIATE_TEST_SUITE_P(Profiles, CliImagingProfiles,
                         ::testing::Values("sim-lab.toml", "sim-thesis.toml", "sim-backlit.toml"),
                         [](const auto& info) {
                           std::string name = info.param.substr(0, info.param.find('.'));
                           for (char& c : name)
                             if (c == '-') c = '_';
                           return name;
                         });

}  // namespace
}  // namespace collide::testing
