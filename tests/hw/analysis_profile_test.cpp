// The rig profile's optional [analysis] table: the alignment a user states
// for their rig, the analysis' priors for the out-of-plane parts.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "hw/rig_profile.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using collide::hw::testing::simProfileText;
using ::testing::HasSubstr;

namespace {

// config/sim.toml without its own [analysis] table (it states its alignment).
std::string withoutAnalysisTable() {
  std::string text = simProfileText();
  const auto begin = text.find("\n[analysis]\n");
  if (begin == std::string::npos) return text;
  const auto end = text.find("\n[", begin + 1);
  return text.erase(begin + 1, end == std::string::npos ? std::string::npos : end - begin);
}

collide::Result<RigProfile> withAnalysis(const std::string& table) {
  return parseRigProfile(withoutAnalysisTable() + "\n[analysis]\n" + table, "config/sim.toml");
}

}  // namespace

TEST(AnalysisProfile, AbsentGivesTodaysPriors) {
  const auto r = parseRigProfile(withoutAnalysisTable(), "config/sim.toml");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(withoutAnalysisTable().find("[analysis]"), std::string::npos);
  // sin(0.573 deg) = 0.0100: the z part of the line of centres the analysis assumed before.
  EXPECT_NEAR(std::sin(r->analysis.line_of_centres_tilt_deg * M_PI / 180), 0.0100, 1e-5);
  EXPECT_DOUBLE_EQ(r->analysis.launch_out_of_plane_fraction, 0.005);
  EXPECT_DOUBLE_EQ(r->analysis.launch_spin_rad_s, 50.0);
  EXPECT_DOUBLE_EQ(r->analysis.contact_distance_sigma_px, 0.0);
  EXPECT_DOUBLE_EQ(r->analysis.radius_systematic_px, 0.1);
  EXPECT_DOUBLE_EQ(r->analysis.centre_offset_px, 0.0);
  EXPECT_DOUBLE_EQ(r->analysis.blur_offset_per_px2, 0.0);
}

TEST(AnalysisProfile, StatedAlignmentIsRead) {
  const auto r = withAnalysis(
      "line_of_centres_tilt_deg = 3.0\nlaunch_out_of_plane_fraction = 0.03\n"
      "contact_distance_sigma_px = 0.2\nradius_systematic_px = 0.02\nlaunch_spin_rad_s = 12.5\n"
      "centre_offset_px = 0.03\nblur_offset_onset_px = 2.5\nblur_offset_per_px2 = 0.05\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_DOUBLE_EQ(r->analysis.launch_spin_rad_s, 12.5);
  EXPECT_DOUBLE_EQ(r->analysis.line_of_centres_tilt_deg, 3.0);
  EXPECT_DOUBLE_EQ(r->analysis.launch_out_of_plane_fraction, 0.03);
  EXPECT_DOUBLE_EQ(r->analysis.contact_distance_sigma_px, 0.2);
  EXPECT_DOUBLE_EQ(r->analysis.radius_systematic_px, 0.02);
  EXPECT_DOUBLE_EQ(r->analysis.centre_offset_px, 0.03);
  EXPECT_DOUBLE_EQ(r->analysis.blur_offset_onset_px, 2.5);
  EXPECT_DOUBLE_EQ(r->analysis.blur_offset_per_px2, 0.05);
}

TEST(AnalysisProfile, TheSimulatedRigStatesItsLaunchScatter) {
  // config/sim.toml's launchers scatter 0.002 rad per axis; its [analysis]
  // table says so, so the analysis' v_z prior is the simulated truth's.
  const auto r = parseRigProfile(simProfileText(), "config/sim.toml");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_DOUBLE_EQ(r->analysis.launch_out_of_plane_fraction, r->simulation.direction_scatter_rad);
}

TEST(AnalysisProfile, TheSimulatedRigStatesItsLaunchSpin) {
  // Its launchers spin the spheres at a size uniform in [a, b] about a random
  // axis: each component's mean square is E[w^2] / 3 = (a^2 + ab + b^2) / 9.
  const auto r = parseRigProfile(simProfileText(), "config/sim.toml");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto [a, b] = r->simulation.spin_at_exit_rad_s;
  ASSERT_GT(b, 0.0);
  EXPECT_NEAR(r->analysis.launch_spin_rad_s, std::sqrt((a * a + a * b + b * b) / 9), 0.05);
}

TEST(AnalysisProfile, ImpossibleOrUnknownValuesAreRefusedByName) {
  for (const char* bad :
       {"line_of_centres_tilt_deg = 0.0\n", "line_of_centres_tilt_deg = 45.0\n",
        "launch_out_of_plane_fraction = -0.01\n", "contact_distance_sigma_px = -0.1\n",
        "contact_distance_sigma_px = 9.0\n", "radius_systematic_px = -0.01\n",
        "radius_systematic_px = 3.0\n", "centre_offset_px = -0.01\n", "centre_offset_px = 3.0\n",
        "blur_offset_onset_px = -1.0\n", "blur_offset_per_px2 = 2.0\n", "launch_spin_rad_s = 0.0\n",
        "launch_spin_rad_s = 5000.0\n"}) {
    const auto r = withAnalysis(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_THAT(r.error().message, HasSubstr(std::string(bad).substr(0, 20))) << bad;
  }
  const auto typo = withAnalysis("line_of_centre_tilt_deg = 1.0\n");
  ASSERT_FALSE(typo.ok());
  EXPECT_THAT(typo.error().message, HasSubstr("line_of_centre_tilt_deg"));
}
