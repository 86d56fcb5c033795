#include "hw/launch_plan.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

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

TEST(LaunchPlan, EqualSpeedsOnSymmetricTubesOpenTogetherAndMeetInTheMiddle) {
  const RigProfile p = profileFrom(simProfileText());
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

TEST(LaunchPlan, TheSlowerSphereIsLaunchedFirst) {
  const RigProfile p = profileFrom(simProfileText());
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
