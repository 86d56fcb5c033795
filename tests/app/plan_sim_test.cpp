// `collide plan` (app/plan.hpp) against the simulated rig: plans fired on it
// land where they were asked to (the incidence and speeds the analysis
// measures, and the truth), wishes the rig cannot fire are refused with a
// nearest shot that it can fire, and the command line says so in its exit code.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <regex>

#include "app/analyze.hpp"
#include "app/campaign.hpp"
#include "app/plan.hpp"
#include "app/rig_setup.hpp"
#include "app/wall_analyze.hpp"
#include "cli_run.hpp"
#include "hw/rig_profile.hpp"
#include "vision/shot_analysis.hpp"
#include "vision/wall_shot_analysis.hpp"

namespace collide::app {
namespace {

// The default profile without launch scatter or spin: what lands where is then
// the planner's doing alone (scatter moves a shot by its own spread, which no
// planner can take back).
hw::RigProfile exactProfile(const std::string& extra_launcher2 = "") {
  std::string text(hw::defaultRigProfileText());
  for (const char* key : {"speed_scatter", "direction_scatter_rad"})
    text = std::regex_replace(text, std::regex(std::string(key) + R"(\s*=\s*[0-9.eE+-]+)"),
                              std::string(key) + " = 0.0");
  text = std::regex_replace(text, std::regex(R"(spin_at_exit_rad_s\s*=\s*\[[^\]]*\])"),
                            "spin_at_exit_rad_s = [0.0, 0.0]");
  if (!extra_launcher2.empty())
    text =
        std::regex_replace(text, std::regex(R"(slide_travel_m\s*=\s*\[[^\]]*\])"), extra_launcher2);
  auto p = hw::parseRigProfile(text, "sim.toml (exact)");
  EXPECT_TRUE(p.ok()) << p.error().message;
  return *p;
}

TEST(Plan, ShotsLandOnTheWantedIncidenceAndSpeed) {
  const hw::RigProfile profile = exactProfile();
  for (const double incidence : {10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0}) {
    PlanRequest req;
    req.incidence_deg = incidence;
    req.speed_m_s = {2.0, 2.0};
    auto plan = planShot(profile, req);
    ASSERT_TRUE(plan.ok()) << incidence << ": " << plan.error().message;
    EXPECT_NEAR(plan->incidence_deg, incidence, 1e-3);
    auto shot = fireShot(
        plan->aimed, hw::ShotRequest::atSpeeds(plan->exit_speed_m_s[0], plan->exit_speed_m_s[1]),
        "plan");
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    ASSERT_EQ(shot->status, hw::ShotStatus::Ok) << shot->failure_reason;
    auto r = vision::analyzeBurst(shot->burst, analysisSettingsFor(*shot));
    ASSERT_TRUE(r.ok()) << r.error().message;
    // No spin: the contact-point incidence is the centres' incidence.
    EXPECT_NEAR(180.0 - r->collision.gamma_deg.value, incidence, 1.0) << incidence;
    for (int s = 0; s < 2; ++s)
      EXPECT_NEAR(r->sphere[s].velocity_before_m_s.value.norm(), 2.0, 0.04)
          << incidence << " deg, sphere " << s + 1;
  }
}

// A sphere-on-wall rig: the plate is turned instead of the slide moved, only
// launcher 1 fires, and the shot lands where it was asked to (the analysis'
// incidence against the plate, the speed at contact), with Walton's wall
// prediction on the planned contact.
TEST(Plan, WallShotsLandOnTheWantedIncidenceAndSpeed) {
  auto profile = hw::loadRigProfile(std::string(COLLIDE_SOURCE_DIR) + "/config/sim-wall.toml");
  ASSERT_TRUE(profile.ok()) << profile.error().message;
  for (const double incidence : {15.0, 45.0, 70.0}) {
    PlanRequest req;
    req.incidence_deg = incidence;
    req.speed_m_s = {2.0, 2.0};
    auto plan = planShot(*profile, req);
    ASSERT_TRUE(plan.ok()) << incidence << ": " << plan.error().message;
    EXPECT_TRUE(plan->isWall());
    EXPECT_NEAR(plan->incidence_deg, incidence, 1e-3);
    EXPECT_NEAR(plan->speed_at_contact_m_s[0], 2.0, 1e-4);
    const std::string text = describePlan(*plan);
    EXPECT_NE(text.find("plate: turned to normal"), std::string::npos) << text;
    EXPECT_NE(text.find("is not fired"), std::string::npos) << text;
    // Walton's wall limit on the planned state: v_n' = -e v_n.
    const Vec3 n = plan->prediction.contact.before.normal;
    EXPECT_NEAR(plan->prediction.after[0].velocity_m_s.dot(n),
                -profile->spheres.material.e * plan->launch.before_contact[0].velocity_m_s.dot(n),
                1e-9);
    auto shot = fireShot(
        plan->aimed, hw::ShotRequest::atSpeeds(plan->exit_speed_m_s[0], plan->exit_speed_m_s[1]),
        "wall-plan");
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    ASSERT_EQ(shot->status, hw::ShotStatus::Ok) << shot->failure_reason;
    const auto settings = wallAnalysisSettingsFor(*shot);
    ASSERT_TRUE(settings);
    auto r = vision::analyzeWallBurst(shot->burst, *settings);
    ASSERT_TRUE(r.ok()) << r.error().message;
    // The centre's incidence: the launch spin (up to 20 rad/s) moves the
    // contact point's by more, so the velocity against the plate is compared.
    const Vec3 v = r->sphere_before.velocity_m_s, nw = r->wall.normal.normalized();
    const double measured = std::acos(std::clamp(-v.dot(nw) / v.norm(), -1.0, 1.0)) * 180 / M_PI;
    std::printf("wall plan %.0f deg at 2 m/s: measured %.2f deg, %.3f m/s\n", incidence, measured,
                v.norm());
    EXPECT_NEAR(measured, incidence, 1.0) << incidence;
    EXPECT_NEAR(v.norm(), 2.0, 0.04) << incidence;
  }
}

TEST(Plan, PredictionIsWaltonOnThePlannedContact) {
  PlanRequest req;
  req.incidence_deg = 35;
  req.speed_m_s = {2.5, 1.8};
  req.material = Material{0.9, 0.25, 0.3};
  auto plan = planShot(exactProfile(), req);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_NEAR(plan->speed_at_contact_m_s[0], 2.5, 1e-3);
  EXPECT_NEAR(plan->speed_at_contact_m_s[1], 1.8, 1e-3);
  // Checked by hand from the contact states: e = -v_n'/v_n for the predicted
  // after-velocities, and gamma = 180 - incidence.
  const auto& b = plan->launch.before_contact;
  const auto& a = plan->prediction.after;
  const Vec3 n = (b[0].position_m - b[1].position_m).normalized();
  const double vn = (b[0].velocity_m_s - b[1].velocity_m_s).dot(n);
  const double vn_after = (a[0].velocity_m_s - a[1].velocity_m_s).dot(n);
  EXPECT_NEAR(-vn_after / vn, 0.9, 1e-9);
  EXPECT_NEAR(plan->prediction.contact.before.gamma_rad * 180 / 3.14159265358979323846, 180 - 35,
              1e-3);
  // Momentum is conserved by the prediction.
  const Vec3 p0 = b[0].mass_kg * b[0].velocity_m_s + b[1].mass_kg * b[1].velocity_m_s;
  const Vec3 p1 = a[0].mass_kg * a[0].velocity_m_s + a[1].mass_kg * a[1].velocity_m_s;
  EXPECT_LT((p1 - p0).norm(), 1e-12);
}

TEST(Plan, TooGrazingIsRefusedWithAFeasibleNearestAngle) {
  const hw::RigProfile profile = exactProfile();
  PlanRequest req;
  req.incidence_deg = 85;
  req.speed_m_s = {2.0, 2.0};
  Infeasible why;
  auto plan = planShot(profile, req, &why);
  ASSERT_FALSE(plan.ok());
  EXPECT_NE(plan.error().message.find("nearest shot the rig can fire"), std::string::npos);
  ASSERT_TRUE(why.nearest.has_value());
  EXPECT_LT(why.nearest->incidence_deg, 85);
  EXPECT_GT(why.nearest->incidence_deg, 60);
  EXPECT_TRUE(planShot(profile, *why.nearest).ok());
  // ... and it is the nearest: 0.5 degrees more cannot be fired.
  PlanRequest more = *why.nearest;
  more.incidence_deg += 0.5;
  EXPECT_FALSE(planShot(profile, more).ok());
}

TEST(Plan, SpeedsOutsideTheCalibrationAreRefused) {
  const hw::RigProfile profile = exactProfile();
  PlanRequest req;
  req.incidence_deg = 30;
  req.speed_m_s = {20.0, 20.0};
  Infeasible why;
  auto plan = planShot(profile, req, &why);
  ASSERT_FALSE(plan.ok());
  EXPECT_NE(why.reason.find("launch calibration"), std::string::npos) << why.reason;
  ASSERT_TRUE(why.nearest.has_value());
  auto nearest = planShot(profile, *why.nearest);
  ASSERT_TRUE(nearest.ok()) << nearest.error().message;
  const double v_max = profile.calibration.curve()->maxSpeed_m_s();
  for (const double v : nearest->exit_speed_m_s) EXPECT_LE(v, v_max);
  // Slow spheres fall out of the image before they meet: a faster shot.
  req.speed_m_s = {1.0, 1.0};
  ASSERT_FALSE(planShot(profile, req, &why).ok());
  ASSERT_TRUE(why.nearest.has_value());
  EXPECT_GT(why.nearest->speed_m_s[0], 1.0);
  EXPECT_TRUE(planShot(profile, *why.nearest).ok());
}

TEST(Plan, SlideTravelIsRespected) {
  const hw::RigProfile profile = exactProfile("slide_travel_m = [-0.005, 0.005]");
  ASSERT_TRUE(profile.launchers[1].slide_travel_m.has_value());
  PlanRequest req;
  req.incidence_deg = 45;  // needs the slide ~18 mm up
  req.speed_m_s = {2.0, 2.0};
  Infeasible why;
  auto plan = planShot(profile, req, &why);
  ASSERT_FALSE(plan.ok());
  EXPECT_NE(why.reason.find("slide_travel_m"), std::string::npos) << why.reason;
  ASSERT_TRUE(why.nearest.has_value());
  auto nearest = planShot(profile, *why.nearest);
  ASSERT_TRUE(nearest.ok()) << nearest.error().message;
  EXPECT_LE(std::abs(nearest->slide_offset_m), 0.005);
  EXPECT_LT(why.nearest->incidence_deg, 45);
}

TEST(Plan, BadRequestsNameTheOption) {
  PlanRequest req;
  req.incidence_deg = 95;
  req.speed_m_s = {2, 2};
  auto plan = planShot(exactProfile(), req);
  ASSERT_FALSE(plan.ok());
  EXPECT_NE(plan.error().message.find("--incidence-deg"), std::string::npos);
  req.incidence_deg = 30;
  req.speed_m_s = {2, -1};
  plan = planShot(exactProfile(), req);
  ASSERT_FALSE(plan.ok());
  EXPECT_NE(plan.error().message.find("--speed2-m-s"), std::string::npos);
}

// A sweep that asks for more than the rig can fire: the campaign fires the
// planner's nearest feasible shot instead of failing, and says so.
TEST(Plan, CampaignReplansWhatTheRigCannotFire) {
  collide::testing::ScratchDir scratch;
  CampaignOptions o;
  o.shots = 3;
  o.out_dir = scratch.file("shots");
  o.angle_min_deg = 85;
  o.angle_max_deg = 88;
  o.speed_min_m_s = 2.0;
  o.speed_max_m_s = 2.1;
  auto report = runCampaign(exactProfile(), o);
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->failed, 0) << (report->failures.empty() ? "" : report->failures[0]);
  EXPECT_EQ(report->ok, 3);
  ASSERT_EQ(report->replanned.size(), 3u);
  for (const std::string& r : report->replanned)
    EXPECT_NE(r.find("nearest shot the rig can fire"), std::string::npos) << r;
}

// The same on a wall rig: a sweep towards grazing would turn the plate so far
// that launcher 1 sits behind its face; those shots are replanned to the
// nearest incidence the plate allows, fired and saved, not lost.
TEST(Plan, WallCampaignReplansWhatThePlateCannotTake) {
  auto profile = hw::loadRigProfile(std::string(COLLIDE_SOURCE_DIR) + "/config/sim-wall.toml");
  ASSERT_TRUE(profile.ok()) << profile.error().message;
  PlanRequest far;
  far.incidence_deg = 86;
  far.speed_m_s = {2.0, 2.0};
  ASSERT_FALSE(planShot(*profile, far).ok()) << "86 deg should be beyond this plate";
  collide::testing::ScratchDir scratch;
  CampaignOptions o;
  o.shots = 2;
  o.out_dir = scratch.file("shots");
  o.angle_min_deg = 86;
  o.angle_max_deg = 88;
  o.speed_min_m_s = 2.0;
  o.speed_max_m_s = 2.1;
  auto report = runCampaign(*profile, o);
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->failed, 0) << (report->failures.empty() ? "" : report->failures[0]);
  EXPECT_EQ(report->ok, 2);
  ASSERT_EQ(report->replanned.size(), 2u);
  for (const std::string& r : report->replanned) {
    EXPECT_NE(r.find("nearest shot the rig can fire"), std::string::npos) << r;
    EXPECT_EQ(r.find(" and "), std::string::npos) << "one sphere, one speed: " << r;
  }
}

TEST(PlanCli, ExitCodesAndUnits) {
  using collide::testing::q;
  using collide::testing::runCollide;
  collide::testing::ScratchDir scratch;
  const std::string rig = q(std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml");
  auto ok = runCollide("plan --rig " + rig + " --incidence-deg 40 --speed-m-s 2", scratch);
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  for (const char* unit : {"kPa", "m/s", "mm", "ms", "deg", "rad/s"})
    EXPECT_NE(ok.out.find(unit), std::string::npos) << unit;
  auto json = runCollide("plan --rig " + rig + " --incidence-deg 40 --speed-m-s 2 --json", scratch);
  EXPECT_EQ(json.exit_code, 0) << json.err;
  EXPECT_NE(json.out.find("\"pressure_kpa\""), std::string::npos);
  auto far = runCollide("plan --rig " + rig + " --incidence-deg 88 --speed-m-s 2", scratch);
  EXPECT_EQ(far.exit_code, 1);
  EXPECT_NE(far.err.find("nearest shot the rig can fire"), std::string::npos) << far.err;
  auto bad = runCollide("plan --rig " + rig + " --incidence-deg -5 --speed-m-s 2", scratch);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--incidence-deg"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace collide::app
