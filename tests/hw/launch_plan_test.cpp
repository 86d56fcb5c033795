#include "hw/launch_plan.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "analysis/air_drag.hpp"
#include "profile_text.hpp"

using namespace collide::hw;
using collide::Vec3;
using collide::hw::testing::simProfileText;
using collide::hw::testing::withKey;
using ::testing::HasSubstr;

namespace {

RigProfile profileFrom(const std::string& text) {
  auto p = parseRigProfile(text, "sim.toml");
  if (!p) throw std::runtime_error(p.error().message);
  return *p;
}

}  // namespace

TEST(LaunchPlan, MeetPointDefaultsToTheImageCentre) {
  const RigProfile p = profileFrom(simProfileText());
  // origin_px is the centre of the 640 x 480 image in sim.toml.
  EXPECT_LT(meetPoint(p).norm(), 1e-12);
  const auto px =
      worldToPixel(p, Vec3(p.geometry.pixel_size_m * 10, p.geometry.pixel_size_m * 5, 0));
  EXPECT_NEAR(px.x(), 319.5 + 10, 1e-9);
  EXPECT_NEAR(px.y(), 239.5 - 5, 1e-9);  // world y up, image v down
}

// In a vacuum ([analysis] air_density_kg_m3 = 0) the flight is a parabola.
TEST(LaunchPlan, EqualSpeedsOnSymmetricTubesOpenTogetherAndMeetInTheMiddle) {
  const RigProfile p =
      profileFrom(withKey(simProfileText(), "analysis", "air_density_kg_m3", "0.0"));
  const auto plan = planLaunch(p, {2.0, 2.0});
  ASSERT_TRUE(plan) << plan.error().message;
  EXPECT_DOUBLE_EQ(plan->valve_open_s[0], 0.0);
  EXPECT_DOUBLE_EQ(plan->valve_open_s[1], 0.0);
  // Each centre travels 85 mm - 12.7 mm at 2 m/s after the 8 ms exit delay.
  EXPECT_NEAR(plan->contact_s, 0.008 + (0.085 - 0.0127) / 2.0, 1e-6);
  EXPECT_NEAR(plan->contact_point_m.x(), 0.0, 1e-9);
  // Both fell for 36 ms from 6 mm up: they meet near the centre row.
  const double t = (0.085 - 0.0127) / 2.0;
  EXPECT_NEAR(plan->contact_point_m.y(), 0.006 - 0.5 * 9.80665 * t * t, 1e-9);
  EXPECT_NEAR(plan->contact_px.y(), 239.5, 5.0);
}

// Through air each sphere slows as dv/dx = -k v (k = rho C_D A / 2m, C_D at
// 2 m/s): it covers d in (e^(k d) - 1) / (k v0), about 17 us longer.
TEST(LaunchPlan, ThroughAirTheSpheresMeetLaterInTheMiddle) {
  const RigProfile p = profileFrom(simProfileText());
  ASSERT_DOUBLE_EQ(p.analysis.air_density_kg_m3, 1.204);  // the default: room air
  const auto plan = planLaunch(p, {2.0, 2.0});
  ASSERT_TRUE(plan) << plan.error().message;
  const double d = 0.085 - 0.0127, v0 = 2.0, m = p.spheres.mass_kg[0];
  const double re = 1.204 * v0 * 0.0254 / 1.81e-5;
  const double k =
      0.5 * 1.204 * collide::sphereDragCoefficient(re) * std::numbers::pi * 0.0254 * 0.0254 / 4 / m;
  EXPECT_NEAR(plan->contact_s, 0.008 + std::expm1(k * d) / (k * v0), 1e-6);
  EXPECT_GT(plan->contact_s, 0.008 + d / v0 + 1e-5);
  EXPECT_NEAR(plan->contact_point_m.x(), 0.0, 1e-9);
}

TEST(LaunchPlan, TheSlowerSphereIsLaunchedFirst) {
  const RigProfile p =
      profileFrom(withKey(simProfileText(), "analysis", "air_density_kg_m3", "0.0"));
  const auto plan = planLaunch(p, {3.0, 1.5});
  ASSERT_TRUE(plan) << plan.error().message;
  EXPECT_DOUBLE_EQ(plan->valve_open_s[1], 0.0);
  const double travel = 0.085 - 0.0127;
  EXPECT_NEAR(plan->valve_open_s[0], travel / 1.5 - travel / 3.0, 1e-12);
  EXPECT_NEAR(plan->contact_point_m.x(), 0.0, 1e-3);  // gravity changes little along x
}

TEST(LaunchPlan, AimsAtAGivenMeetPoint) {
  const RigProfile p =
      profileFrom(withKey(simProfileText(), "geometry", "meet_point_m", "[0.02, 0.0, 0.0]"));
  const auto plan = planLaunch(p, {2.0, 2.0});
  ASSERT_TRUE(plan) << plan.error().message;
  EXPECT_NEAR(plan->contact_point_m.x(), 0.02, 1e-6);
  EXPECT_GT(plan->valve_open_s[1], 0.0);  // the right sphere has less far to go
}

TEST(LaunchPlan, RefusesAMeetPointBehindAMuzzle) {
  const RigProfile p =
      profileFrom(withKey(simProfileText(), "geometry", "meet_point_m", "[-0.2, 0.0, 0.0]"));
  const auto plan = planLaunch(p, {2.0, 2.0});
  ASSERT_FALSE(plan);
  EXPECT_THAT(plan.error().message,
              HasSubstr("launcher left: the meet point lies behind its muzzle"));
}

TEST(LaunchPlan, RefusesSpheresThatWouldMissEachOther) {
  std::string text = withKey(simProfileText(), "launcher", "exit_m", "[0.085, 0.05, 0.0]", 2);
  const auto plan = planLaunch(profileFrom(text), {2.0, 2.0});
  ASSERT_FALSE(plan);
  EXPECT_THAT(plan.error().message, HasSubstr("the spheres would miss each other"));
}

TEST(LaunchPlan, RefusesAContactOutsideTheImage) {
  // Slow spheres fall far below the picture before they meet.
  std::string text = withKey(simProfileText(), "launcher", "exit_m", "[-0.085, -0.04, 0.0]", 1);
  text = withKey(text, "launcher", "exit_m", "[0.085, -0.04, 0.0]", 2);
  const auto plan = planLaunch(profileFrom(text), {1.0, 1.0});
  ASSERT_FALSE(plan);
  EXPECT_THAT(plan.error().message, HasSubstr("outside the 640x480 image"));
}
