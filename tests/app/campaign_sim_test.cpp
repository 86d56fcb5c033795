// collide campaign on the simulated rig: the planned incidence angles are the
// ones the simulated spheres really meet at, every shot ends up as a file and a
// catalog row, and bad requests or a cancel are handled before anything fires.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <regex>
#include <set>
#include <stop_token>

#include "app/campaign.hpp"
#include "app/store/catalog.hpp"
#include "app/store/shot_file.hpp"
#include "hw/rig_profile.hpp"
#include "shot_fixtures.hpp"

namespace collide::app {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The default profile with no shot-to-shot scatter: the flight is then fully
// determined by the plan, so the angle the spheres meet at can be compared
// with the planned one without a statistical tolerance.
hw::RigProfile exactProfile() {
  std::string text(hw::defaultRigProfileText());
  text = std::regex_replace(text, std::regex(R"(speed_scatter\s*=\s*[0-9.eE+-]+)"),
                            "speed_scatter = 0.0");
  text = std::regex_replace(text, std::regex(R"(direction_scatter_rad\s*=\s*[0-9.eE+-]+)"),
                            "direction_scatter_rad = 0.0");
  auto p = hw::parseRigProfile(text, "sim.toml (no scatter)");
  EXPECT_TRUE(p.ok()) << p.error().message;
  return *p;
}

// Incidence angle (degrees, 0 = head-on) at the true contact instant, from the
// ground truth alone: both spheres fall with the same g, so their relative
// motion is a straight line and the last frame before contact extrapolates
// exactly to the contact.
double trueIncidenceDeg(const hw::TruthRecord& truth) {
  std::size_t k = 0;
  for (std::size_t i = 0; i < truth.t_s.size(); ++i)
    if (truth.t_s[i] <= truth.t_collision_s) k = i;
  const auto& s = truth.states.at(k);
  const Vec3 v_rel = s[0].velocity_m_s - s[1].velocity_m_s;  // sphere 1 relative to 2
  const Vec3 r = (s[1].position_m - s[0].position_m) -
                 v_rel * (truth.t_collision_s - truth.t_s[k]);  // 1 -> 2 at contact
  const double c = r.normalized().dot(v_rel.normalized());
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / kPi;
}

TEST(CampaignSim, SpheresMeetAtThePlannedAnglesAndEveryShotIsSaved) {
  testing::ScratchDir dir;
  CampaignOptions options;
  options.shots = 4;
  options.out_dir = dir.path();
  options.seed = 11;
  options.angle_min_deg = 5;
  options.angle_max_deg = 65;
  const auto plan = planCampaign(options);
  ASSERT_EQ(plan.size(), 4u);

  int progress_calls = 0;
  auto report = runCampaign(exactProfile(), options, [&](int done, int total, const hw::Shot&) {
    ++progress_calls;
    EXPECT_EQ(done, progress_calls);
    EXPECT_EQ(total, 4);
  });
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->fired, 4);
  EXPECT_EQ(report->ok, 4) << (report->failures.empty() ? "" : report->failures.front());
  EXPECT_EQ(progress_calls, 4);
  ASSERT_EQ(report->files.size(), 4u);

  std::set<std::string> ids;
  for (std::size_t i = 0; i < report->files.size(); ++i) {
    auto shot = readShot(report->files[i]);
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    ASSERT_TRUE(shot->truth.has_value());
    EXPECT_EQ(shot->status, hw::ShotStatus::Ok);
    EXPECT_FALSE(shot->burst.frames.empty());
    ids.insert(shot->id);
    // Shots are fired in plan order.
    EXPECT_NEAR(trueIncidenceDeg(*shot->truth), plan[i].incidence_deg, 0.5) << "shot " << i;
  }
  EXPECT_EQ(ids.size(), 4u) << "shot ids must be unique";

  auto catalog = Catalog::open(options.out_dir, Catalog::Mode::OpenExisting);
  ASSERT_TRUE(catalog.ok()) << catalog.error().message;
  auto rows = catalog->query();
  ASSERT_TRUE(rows.ok()) << rows.error().message;
  ASSERT_EQ(rows->size(), 4u);
  for (const auto& row : *rows) EXPECT_TRUE(ids.count(row.id)) << row.id;
}

TEST(CampaignSim, PlanIsReproducibleAndCoversTheRange) {
  CampaignOptions o;
  o.shots = 10;
  o.angle_min_deg = 10;
  o.angle_max_deg = 70;
  const auto a = planCampaign(o), b = planCampaign(o);
  ASSERT_EQ(a.size(), 10u);
  double lo = 90, hi = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].incidence_deg, b[i].incidence_deg);
    EXPECT_EQ(a[i].speed_m_s, b[i].speed_m_s);
    lo = std::min(lo, a[i].incidence_deg);
    hi = std::max(hi, a[i].incidence_deg);
    for (double v : a[i].speed_m_s) {
      EXPECT_GE(v, o.speed_min_m_s);
      EXPECT_LE(v, o.speed_max_m_s);
    }
  }
  // Evenly spread: the extremes are half a cell (3 degrees) inside the range.
  EXPECT_NEAR(lo, 13.0, 1e-9);
  EXPECT_NEAR(hi, 67.0, 1e-9);
  o.seed = 2;
  EXPECT_NE(planCampaign(o)[0].speed_m_s, a[0].speed_m_s);
}

TEST(CampaignSim, CancelBeforeStartFiresNothing) {
  testing::ScratchDir dir;
  CampaignOptions options;
  options.shots = 3;
  options.out_dir = dir.path();
  std::stop_source stop;
  stop.request_stop();
  auto report = runCampaign(exactProfile(), options, {}, stop.get_token());
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_TRUE(report->cancelled);
  EXPECT_EQ(report->fired, 0);
  EXPECT_TRUE(report->files.empty());
}

TEST(CampaignSim, BadOptionsAreRejectedBeforeFiring) {
  testing::ScratchDir dir;
  CampaignOptions options;
  options.out_dir = dir.path();
  options.shots = 0;
  auto r = runCampaign(exactProfile(), options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("--shots"), std::string::npos) << r.error().message;

  options.shots = 2;
  options.angle_max_deg = 95;
  r = runCampaign(exactProfile(), options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("degrees"), std::string::npos) << r.error().message;
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(CampaignSim, AnAngleNoSlidePositionGivesIsAnError) {
  auto r = aimForIncidence(exactProfile(), 89.9, {2.0, 2.0});
  ASSERT_FALSE(r.ok());
  EXPECT_FALSE(r.error().message.empty());
  // A reachable angle returns a profile whose second exit moved.
  double dy = 0;
  auto ok = aimForIncidence(exactProfile(), 30.0, {2.0, 2.0}, &dy);
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_GT(std::abs(dy), 1e-4);
  EXPECT_NE(ok->text, exactProfile().text);
}

}  // namespace
}  // namespace collide::app
