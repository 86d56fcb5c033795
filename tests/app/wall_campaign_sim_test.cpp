// Sphere-on-wall shots from the simulated rig (config/sim-wall.toml): a
// campaign fires them at swept incidences and stores them; each is analysed
// as a wall shot and checked against the simulator's truth (issue 13: e within
// 0.005, beta within 0.03); the campaign fits give mu and beta_0 back.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../../bench/truth_at_contact.hpp"
#include "analysis/campaign.hpp"
#include "analysis/walton.hpp"
#include "app/campaign.hpp"
#include "app/report/results_json.hpp"
#include "app/report/wall_results_json.hpp"
#include "app/store/shot_file.hpp"
#include "app/wall_analyze.hpp"
#include "app/wall_campaign.hpp"
#include "hw/camera_sim.hpp"
#include "hw/launch_plan.hpp"
#include "hw/rig_profile.hpp"
#include "shot_fixtures.hpp"
#include "vision/wall_shot_analysis.hpp"

namespace collide::app {
namespace {

hw::RigProfile wallProfile() {
  auto p = hw::loadRigProfile(std::string(COLLIDE_SOURCE_DIR) + "/config/sim-wall.toml");
  EXPECT_TRUE(p.ok()) << p.error().message;
  return *p;
}

// The truth just before and after the impact: the last sample before contact
// and the first after, flown on to the contact (bench/truth_at_contact.hpp).
struct TrueImpact {
  Sphere before, after;
};
TrueImpact trueImpact(const hw::Shot& shot) {
  std::array<Sphere, 2> before, after;
  EXPECT_TRUE(bench::truthAtContact(shot, before, after, 1)) << "no impact in the truth";
  return {before[0], after[0]};
}

TEST(WallCampaignSim, AimingTurnsThePlateToThePlannedIncidence) {
  const hw::RigProfile p = wallProfile();
  ASSERT_TRUE(p.wall);
  for (const double deg : {10.0, 45.0, 75.0}) {
    auto aimed = aimWallForIncidence(p, deg, 2.0);
    ASSERT_TRUE(aimed) << aimed.error().message;
    auto plan = hw::planLaunch(*aimed, {2.0, 2.0});
    ASSERT_TRUE(plan);
    const double c = -plan->relative_velocity_m_s.normalized().dot(plan->contact_normal);
    EXPECT_NEAR(std::acos(c) * 180.0 / M_PI, deg, 1e-6);
    // The recorded text carries the turned plate.
    auto reread = hw::parseRigProfile(aimed->text, "aimed");
    ASSERT_TRUE(reread);
    EXPECT_NEAR((reread->wall->normal - aimed->wall->normal).norm(), 0.0, 1e-8);
  }
}

TEST(WallCampaignSim, ShotsAnalysedAsWallShotsMatchTheTruthAndTheFitsGiveTheMaterial) {
  testing::ScratchDir dir;
  const hw::RigProfile profile = wallProfile();
  CampaignOptions options;
  options.shots = 16;
  options.out_dir = dir.path();
  options.seed = 5;
  options.angle_min_deg = 5;
  options.angle_max_deg = 75;
  auto report = runCampaign(profile, options);
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->ok, options.shots)
      << (report->failures.empty() ? "" : report->failures.front());

  std::vector<CampaignShot> shots;
  double worst_e = 0, worst_beta = 0, worst_line = 0;
  for (const std::string& file : report->files) {
    auto shot = readShot(file);
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    ASSERT_TRUE(shot->truth);
    auto json = analyzeWallShot(*shot);
    ASSERT_TRUE(json.has_value()) << file << ": not taken for a wall shot";
    ASSERT_TRUE(json->ok()) << file << ": " << json->error().message;
    EXPECT_NE(json->value().find("\"target\": \"wall\""), std::string::npos);
    auto results = parseResultsJson(json->value());
    ASSERT_TRUE(results.ok()) << results.error().message;

    auto settings = wallAnalysisSettingsFor(*shot);
    ASSERT_TRUE(settings);
    // The plate's face found in the frames with no hint (Hough, the edge
    // nearest the sphere, then the sub-pixel edge fit) is the profile's line.
    {
      vision::WallAnalysisSettings unhinted = *settings;
      unhinted.wall_line.reset();
      auto found = vision::analyzeWallBurst(shot->burst, unhinted);
      ASSERT_TRUE(found.ok()) << found.error().message;
      EXPECT_TRUE(found->wall_found_in_image);
      const vision::WallLine& truth_line = *settings->wall_line;
      const double off =
          truth_line.distancePx(found->wall_line.point_px.x(), found->wall_line.point_px.y());
      EXPECT_NEAR(off, 0.0, 0.05);
      EXPECT_NEAR(std::abs(found->wall_line.normal.dot(truth_line.normal)), 1.0, 1e-6);
      worst_line = std::max(worst_line, std::abs(off));
    }
    auto reread = hw::parseRigProfile(shot->rig_profile_toml, "shot");
    ASSERT_TRUE(reread);
    const TrueImpact truth = trueImpact(*shot);
    auto m = measureWallCollision(truth.before, truth.after, *reread->wall);
    ASSERT_TRUE(m) << m.error().message;
    EXPECT_NEAR(m->e, shot->truth->material.e, 1e-9);  // the truth is self-consistent
    const auto& c = results->collision;
    EXPECT_NEAR(c.e.value, m->e, 0.005) << file;
    EXPECT_NEAR(c.beta.value, m->beta, 0.03) << file << " gamma " << c.gamma_deg.value;
    std::printf(
        "gamma %.2f deg: e %.4f (truth %.4f, sigma %.4f)  beta %.4f (truth %.4f, sigma %.4f) vs "
        "%.3f spin %.1f\n",
        c.gamma_deg.value, c.e.value, m->e, c.e.sigma, c.beta.value, m->beta, c.beta.sigma,
        m->before.v_s_m_s, truth.before.spin_rad_s.norm());
    EXPECT_NEAR(c.gamma_deg.value, m->before.gamma_rad * 180.0 / M_PI, 0.5) << file;
    // Honest shots conserve angular momentum about the contact point.
    const auto& flags = results->quality_flags;
    EXPECT_EQ(std::count(flags.begin(), flags.end(), "spin_impulse_disagree"), 0) << file;
    worst_e = std::max(worst_e, std::abs(c.e.value - m->e));
    worst_beta = std::max(worst_beta, std::abs(c.beta.value - m->beta));
    auto cs = toCampaignShot(*results);
    ASSERT_TRUE(cs.ok()) << cs.error().message;
    shots.push_back(*cs);
  }
  std::printf(
      "worst |e - truth| = %.4f, worst |beta - truth| = %.4f, wall line found %.4f px off, over "
      "%zu shots\n",
      worst_e, worst_beta, worst_line, shots.size());
  auto e = fitRestitutionMean(shots);
  ASSERT_TRUE(e.ok()) << e.error().message;
  auto fr = fitFriction(shots, e->e);
  ASSERT_TRUE(fr.ok()) << fr.error().message;
  const Material truth = profile.spheres.material;
  std::printf("campaign: e = %.4f +- %.4f, mu = %.4f +- %.4f, beta0 = %.4f +- %.4f\n", e->e.value,
              e->e.sigma, fr->mu.value, fr->mu.sigma, fr->beta0.value, fr->beta0.sigma);
  EXPECT_NEAR(e->e.value, truth.e, 0.005);
  EXPECT_NEAR(fr->mu.value, truth.mu, 0.005);
  EXPECT_NEAR(fr->beta0.value, truth.beta0, 0.02);
}

// A shot of a wall campaign analysed as `collide analyze` analyses it, with
// the truth's impact measured by Walton's wall operator.
struct AnalysedWallShot {
  std::string file;
  vision::WallAnalysisSettings settings;
  vision::WallShotAnalysis analysis;
  TrueImpact impact;
  WaltonMeasurement truth;
};

// Fires four shots of `profile` (incidence 15 to 60 degrees, `seed`) into
// `dir` and analyses each (fatal failures on the way).
void fireAndAnalyse(const hw::RigProfile& profile, std::uint64_t seed,
                    const testing::ScratchDir& dir, std::vector<AnalysedWallShot>& out) {
  CampaignOptions options;
  options.shots = 4;
  options.out_dir = dir.path();
  options.seed = seed;
  options.angle_min_deg = 15;
  options.angle_max_deg = 60;
  auto report = runCampaign(profile, options);
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->ok, options.shots)
      << (report->failures.empty() ? "" : report->failures.front());
  for (const std::string& file : report->files) {
    auto shot = readShot(file);
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    auto settings = wallAnalysisSettingsFor(*shot);
    ASSERT_TRUE(settings);
    auto a = vision::analyzeWallBurst(shot->burst, *settings);
    ASSERT_TRUE(a.ok()) << file << ": " << a.error().message;
    auto reread = hw::parseRigProfile(shot->rig_profile_toml, "shot");
    ASSERT_TRUE(reread);
    const TrueImpact impact = trueImpact(*shot);
    auto m = measureWallCollision(impact.before, impact.after, *reread->wall);
    ASSERT_TRUE(m) << m.error().message;
    out.push_back({file, *settings, *a, impact, *m});
  }
}

// Each in-plane velocity at contact and at separation lies within 4 of its
// stated sigmas of the truth (issue 12: none beyond 4).
void expectVelocitiesCovered(const AnalysedWallShot& w) {
  const vision::WallShotAnalysis& a = w.analysis;
  // In the image plane from the fits; along z the prior's before the impact
  // and the spin change's after it (appendix B): a post-impact v_z of 0.01
  // m/s from friction across the plate is common.
  for (int ax = 0; ax < 3; ++ax) {
    const double pull_before =
        (a.sphere_before.velocity_m_s[ax] - w.impact.before.velocity_m_s[ax]) /
        a.velocity_sigma_before[ax];
    const double pull_after = (a.sphere_after.velocity_m_s[ax] - w.impact.after.velocity_m_s[ax]) /
                              a.velocity_sigma_after[ax];
    std::printf("  axis %d: velocity pulls before %+.2f, after %+.2f\n", ax, pull_before,
                pull_after);
    EXPECT_LT(std::abs(pull_before), 4.0) << w.file << " axis " << ax;
    EXPECT_LT(std::abs(pull_after), 4.0) << w.file << " axis " << ax;
  }
  // The results file reports those velocities (it gave the orthographic
  // fit's v_z = 0 after the impact, 5 sigmas off on backlit shots).
  auto results = parseResultsJson(wallResultsToJson(a));
  ASSERT_TRUE(results) << results.error().message;
  for (int ax = 0; ax < 3; ++ax) {
    EXPECT_NEAR(results->sphere[0].velocity_before_m_s.value[ax], a.sphere_before.velocity_m_s[ax],
                1e-12)
        << w.file << " axis " << ax;
    EXPECT_NEAR(results->sphere[0].velocity_after_m_s.value[ax], a.sphere_after.velocity_m_s[ax],
                1e-12)
        << w.file << " axis " << ax;
  }
}

// bench/profiles/wall-backlit.toml (config/sim-wall.toml seen against a
// backlight: the sphere a silhouette on a bright field), with `ambient` room
// light on its face instead of the file's 0.25 (0: bare, black).
hw::RigProfile backlitWallProfile(double ambient) {
  std::ifstream in(std::string(COLLIDE_SOURCE_DIR) + "/bench/profiles/wall-backlit.toml");
  std::stringstream text;
  text << in.rdbuf();
  std::string toml = text.str();
  const std::string line = "\nambient = 0.25";
  const std::size_t at = toml.find(line);
  EXPECT_NE(at, std::string::npos) << "wall-backlit.toml no longer sets ambient = 0.25";
  if (at != std::string::npos)
    toml.replace(at, line.size(), "\nambient = " + std::to_string(ambient));
  auto p = hw::parseRigProfile(toml, "wall-backlit.toml");
  EXPECT_TRUE(p.ok()) << p.error().message;
  return *p;
}

// Backlit plate shots: with room light on the sphere's face its dots show and
// spins (so beta) are measured, as in the two-sphere analysis; a bare
// silhouette (black) is found all the same, gives e and says the spins are
// unknown (no beta guessed).
TEST(WallCampaignSim, BacklitShotsGiveEAndSpinsWhereTheDotsShow) {
  for (const double ambient : {0.25, 0.0}) {
    testing::ScratchDir dir;
    std::vector<AnalysedWallShot> shots;
    ASSERT_NO_FATAL_FAILURE(fireAndAnalyse(backlitWallProfile(ambient), 7, dir, shots));
    for (const AnalysedWallShot& w : shots) {
      const vision::WallShotAnalysis& a = w.analysis;
      const WaltonMeasurement& m = w.truth;
      const std::string& file = w.file;
      std::printf("backlit wall, ambient %.2f: e %.4f (truth %.4f), beta %.4f (truth %.4f)\n",
                  ambient, a.measured.e, m.e, a.measured.beta, m.beta);
      EXPECT_NEAR(a.measured.e, m.e, 0.005) << file;
      const auto& flags = a.quality_flags;
      const bool no_spin = std::count(flags.begin(), flags.end(), "no_spin_before") > 0;
      if (ambient > 0) {
        EXPECT_TRUE(a.spin_before_known && a.spin_after_known) << file;
        EXPECT_FALSE(no_spin) << file;
        EXPECT_NEAR(a.measured.beta, m.beta, 0.03) << file;
        // The dots' pull on the silhouette is in the velocity sigmas
        // (vision/shot_fits.hpp): without it they were half the errors
        // (pulls 6.2 and 8.3 here). Not asserted: that the angular-momentum
        // check stays quiet. It fired on 3 of 30 good wall-backlit shots
        // before and on none of those 30 after, but the spins' sigmas are
        // still optimistic on some shots (spin pulls up to 7), and the clang
        // build's draw of these four shots has one where it fires.
        expectVelocitiesCovered(w);
      } else {
        EXPECT_FALSE(a.spin_before_known || a.spin_after_known) << file;
        EXPECT_TRUE(no_spin) << file;
        EXPECT_TRUE(std::isnan(a.measured.beta)) << file;
      }
    }
  }
}

// The plate filmed as a lab camera films it (bench/profiles/wall-lab.toml: a
// 50 mm lens 0.53 m away, barrel distortion, one-sided light): the analysis
// takes centres, the face line and the dots through the recorded lens, and
// the post-impact track at the depth the impact sent it to. Taken
// orthographically, the spins were off by 3 to 5 rad/s and e by up to 0.0034.
TEST(WallCampaignSim, ShotsThroughALensAreMeasuredThroughIt) {
  testing::ScratchDir dir;
  auto profile =
      hw::loadRigProfile(std::string(COLLIDE_SOURCE_DIR) + "/bench/profiles/wall-lab.toml");
  ASSERT_TRUE(profile.ok()) << profile.error().message;
  std::vector<AnalysedWallShot> shots;
  ASSERT_NO_FATAL_FAILURE(fireAndAnalyse(*profile, 4, dir, shots));
  for (const AnalysedWallShot& w : shots) {
    EXPECT_TRUE(w.settings.camera) << "the recorded lens did not reach the analysis";
    const vision::WallShotAnalysis& a = w.analysis;
    const WaltonMeasurement& m = w.truth;
    const TrueImpact& truth = w.impact;
    const std::string& file = w.file;
    const double spin_err = std::max((a.sphere_before.spin_rad_s - truth.before.spin_rad_s).norm(),
                                     (a.sphere_after.spin_rad_s - truth.after.spin_rad_s).norm());
    std::printf(
        "wall through a lens: e %.4f +- %.4f (truth %.4f), beta %.4f (truth %.4f), spin error "
        "%.2f rad/s\n",
        a.measured.e, a.e_sigma, m.e, a.measured.beta, m.beta, spin_err);
    EXPECT_NEAR(a.measured.e, m.e, 0.002) << file;
    // The stated sigma covers the error (issue 12: none beyond 4), the
    // post-impact depth's share included: under a lens the centres after the
    // impact are taken at the depth the spins' v_z gives, so the spins'
    // error moves the post-impact velocity too.
    EXPECT_LT(std::abs(a.measured.e - m.e), 4 * a.e_sigma) << file;
    EXPECT_NEAR(a.measured.beta, m.beta, 0.01) << file;
    EXPECT_LT(spin_err, 1.0) << file;
    // The velocity sigmas reported are the ones propagated: the fits' own,
    // widened for correlated residuals and the dots' drift (so never below
    // them), and the out-of-plane prior along z; the results file says the
    // same.
    const Vec3 fit_before = a.before->velocityAt_m_s(a.t_contact_s).sigma;
    const Vec3 fit_after = a.after->velocityAt_m_s(a.t_separation_s).sigma;
    for (int ax = 0; ax < 2; ++ax) {
      EXPECT_GE(a.velocity_sigma_before[ax], fit_before[ax]) << file;
      EXPECT_GE(a.velocity_sigma_after[ax], fit_after[ax]) << file;
    }
    EXPECT_GT(a.velocity_sigma_before.z(), 0) << file;
    // Under the lens the one-sided lamp's pull on the outline changes as the
    // sphere crosses the field (its lit limb seen from a changing angle): the
    // profile's radius_systematic_px over each track's span is in the
    // sigmas (without it wall-lab's velocity pulls were 2.3 over 30 shots).
    EXPECT_EQ(w.settings.radius_systematic_px, profile->analysis.radius_systematic_px);
    const double lamp_before = w.settings.radius_systematic_px * a.pixel_size_m /
                               (a.before->tLast_s() - a.before->tFirst_s());
    const double lamp_after = w.settings.radius_systematic_px * a.pixel_size_m /
                              (a.after->tLast_s() - a.after->tFirst_s());
    for (int ax = 0; ax < 2; ++ax) {
      EXPECT_GE(a.velocity_sigma_before[ax], lamp_before) << file;
      EXPECT_GE(a.velocity_sigma_after[ax], lamp_after) << file;
    }
    // ... and they cover the true velocities: under the lens the unseen v_z
    // before the impact (the rig's stated alignment) moves a centre x off the
    // optical axis by x v_z (t - t_c) / Z0, and the pre-impact velocity with
    // it (without that share the pulls reached 15 on 30 wall-lab shots).
    expectVelocitiesCovered(w);
    auto results = parseResultsJson(wallResultsToJson(a));
    ASSERT_TRUE(results) << results.error().message;
    for (int ax = 0; ax < 3; ++ax) {
      EXPECT_NEAR(results->sphere[0].velocity_before_m_s.sigma[ax], a.velocity_sigma_before[ax],
                  1e-12)
          << file;
      EXPECT_NEAR(results->sphere[0].velocity_after_m_s.sigma[ax], a.velocity_sigma_after[ax],
                  1e-12)
          << file;
    }
  }
}

}  // namespace
}  // namespace collide::app
