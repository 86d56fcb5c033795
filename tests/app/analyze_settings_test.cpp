// The analysis settings a recorded shot implies (app/analyze.hpp
// analysisSettingsFor): what its rig profile's [analysis] table states
// reaches the analysis.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "app/analyze.hpp"

namespace collide::app {
namespace {

std::string profileText(const std::string& relative) {
  std::ifstream in(std::string(COLLIDE_SOURCE_DIR) + "/" + relative);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

hw::Shot shotFiledWith(const std::string& profile) {
  hw::Shot shot;
  shot.id = "20260101-120000-0001";
  shot.rig_profile_toml = profileText(profile);
  shot.camera.fps = 1000;
  return shot;
}

TEST(AnalysisSettingsFor, TheProfilesStatedPriorsReachTheAnalysis) {
  // sim-lab states its one-sided light's contact distance scatter and its
  // measured radius bias changes; the backlit profile its silhouettes' small
  // radius bias; sim.toml neither.
  const auto lab = analysisSettingsFor(shotFiledWith("config/sim-lab.toml"));
  EXPECT_DOUBLE_EQ(lab.contact_distance_sigma_px, 0.2);
  EXPECT_DOUBLE_EQ(lab.radius_systematic_px, 0.05);
  const auto backlit = analysisSettingsFor(shotFiledWith("config/sim-backlit.toml"));
  EXPECT_DOUBLE_EQ(backlit.radius_systematic_px, 0.02);
  EXPECT_DOUBLE_EQ(backlit.out_of_plane_speed_fraction, 0.002);
  // Its launchers' spin (0..30 rad/s, random axis): 10 rad/s per axis.
  EXPECT_DOUBLE_EQ(backlit.unknown_spin_sigma_rad_s, 10.0);
  const auto plain = analysisSettingsFor(shotFiledWith("config/sim.toml"));
  EXPECT_DOUBLE_EQ(plain.radius_systematic_px, 0.1);
  EXPECT_DOUBLE_EQ(plain.contact_distance_sigma_px, 0.0);
}

}  // namespace
}  // namespace collide::app
