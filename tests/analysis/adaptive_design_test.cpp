// The adaptive campaign's design (analysis/adaptive_design.hpp) on shots drawn
// from Walton's model with known material and noise: where it aims (near the
// regime switch, worked out here from the material), that it stops when the
// fit's sigmas reach the targets, that it needs fewer shots than an even
// sweep, and that what it then reports covers the truth.
#include "analysis/adaptive_design.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <vector>

namespace collide {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;
const Material kNylon{0.97, 0.176, 0.44};

// psi0 of the material: x0 = (1 + beta0) / ((1 + 1/K)(1 + e) mu), psi0 = atan(1/x0).
double switchAngleDeg(const Material& m) {
  const double x0 = (1 + m.beta0) / ((1 + 1 / 0.4) * (1 + m.e) * m.mu);
  return std::atan(1 / x0) * kDeg;
}

TEST(AdaptiveDesign, SpreadsTheFirstShotsOverTheRange) {
  AdaptiveOptions o;
  std::vector<CampaignShot> shots;
  std::mt19937_64 rng(1);
  std::set<int> seen;
  for (int i = 0; i < o.initial_shots; ++i) {
    const AdaptiveStatus st = assessCampaign(shots, o);
    auto next = chooseNextShot(shots, st, o);
    ASSERT_TRUE(next.ok()) << next.error().message;
    EXPECT_GE(next->incidence_deg, o.angle_min_deg);
    EXPECT_LE(next->incidence_deg, o.angle_max_deg);
    EXPECT_NE(next->why.find("initial spread"), std::string::npos) << next->why;
    seen.insert(static_cast<int>(std::lround(next->incidence_deg)));
    shots.push_back(synthesizeShot(kNylon, next->incidence_deg, {}, rng));
  }
  EXPECT_EQ(seen.size(), static_cast<std::size_t>(o.initial_shots));
  EXPECT_LT(*seen.begin(), 20);
  EXPECT_GT(*seen.rbegin(), 70);
}

TEST(AdaptiveDesign, AimsNearTheSwitchOnceThereIsAFit) {
  // The most telling shots lie just either side of the switch: on the sliding
  // side x is largest (the slope is best seen), on the rolling side sigma_beta
  // is smallest (the plateau is best seen).
  for (const Material& m : {kNylon, Material{0.9, 0.1, 0.3}, Material{0.8, 0.4, 0.1}}) {
    std::mt19937_64 rng(3);
    ShotNoise noise;
    noise.sigma_beta_at_90 = 0.03;
    AdaptiveOptions o;
    std::vector<CampaignShot> shots;
    for (int i = 0; i < 20; ++i)
      shots.push_back(synthesizeShot(m, 10 + 70.0 * (i + 0.5) / 20, noise, rng));
    const AdaptiveStatus st = assessCampaign(shots, o);
    ASSERT_TRUE(st.friction.has_value()) << st.fit_error;
    auto next = chooseNextShot(shots, st, o);
    ASSERT_TRUE(next.ok());
    EXPECT_NEAR(next->incidence_deg, switchAngleDeg(m), 12.0) << "mu " << m.mu;
    EXPECT_NE(next->why.find("switch at"), std::string::npos) << next->why;
    // It expects the shot to help.
    EXPECT_LT(std::max(next->expected_sigma_mu / o.target_sigma_mu,
                       next->expected_sigma_beta0 / o.target_sigma_beta0),
              std::max(st.friction->mu.sigma / o.target_sigma_mu,
                       st.friction->beta0.sigma / o.target_sigma_beta0));
  }
}

// 20 shots over the angles at speeds 2-6 m/s, with velocity errors that grow
// as speed^exponent, and the design's choice after them.
Result<NextShot> afterSpreadSpeeds(double exponent, bool one_speed = false) {
  std::mt19937_64 rng(5);
  ShotNoise noise;
  noise.sigma_beta_at_90 = 0.03;
  noise.speed_exponent = exponent;
  AdaptiveOptions o;
  o.speed_min_m_s = 2.0;
  o.speed_max_m_s = 6.0;
  std::vector<CampaignShot> shots;
  for (int i = 0; i < 20; ++i) {
    noise.relative_speed_m_s = one_speed ? 4.0 : 2.0 + (i % 5);
    shots.push_back(synthesizeShot(kNylon, 10 + 70.0 * (i + 0.5) / 20, noise, rng));
  }
  const AdaptiveStatus st = assessCampaign(shots, o);
  if (!st.friction) return fail("no fit: " + st.fit_error);
  return chooseNextShot(shots, st, o);
}

TEST(AdaptiveDesign, ChoosesTheFastestSpeedWhenVelocityErrorsDoNotGrowWithIt) {
  // sigma_beta ~ sigma_v / v_s: with sigma_v flat, a faster shot tells more.
  auto next = afterSpreadSpeeds(0.0);
  ASSERT_TRUE(next.ok()) << next.error().message;
  EXPECT_DOUBLE_EQ(next->speed_m_s, 6.0) << next->why;
  EXPECT_NE(next->why.find("the fastest in the rig's range"), std::string::npos) << next->why;
  EXPECT_NE(next->why.find("speed^-1.0"), std::string::npos) << next->why;  // the law it found
}

TEST(AdaptiveDesign, ChoosesTheSlowestSpeedWhenVelocityErrorsGrowFasterThanIt) {
  // Blur-limited: sigma_v ~ v^2, so sigma_beta ~ v and a slow shot tells more.
  auto next = afterSpreadSpeeds(2.0);
  ASSERT_TRUE(next.ok()) << next.error().message;
  EXPECT_DOUBLE_EQ(next->speed_m_s, 2.0) << next->why;
  EXPECT_NE(next->why.find("the slowest in the rig's range"), std::string::npos) << next->why;
  EXPECT_NE(next->why.find("speed^1.0"), std::string::npos) << next->why;
}

TEST(AdaptiveDesign, GoesToTheFarEndOfTheSpeedRangeUntilItKnowsHowTheNoiseScales) {
  // Every shot so far at 4 m/s: nothing tells how sigma_beta scales with
  // speed, so the next shot goes where it will (6 m/s is 1.5 x away, 2 m/s 2 x).
  auto next = afterSpreadSpeeds(0.0, true);
  ASSERT_TRUE(next.ok()) << next.error().message;
  EXPECT_DOUBLE_EQ(next->speed_m_s, 2.0) << next->why;
  EXPECT_NE(next->why.find("the slowest in the rig's range, to learn how sigma_beta scales with "
                           "speed (20 usable shots at "),
            std::string::npos)
      << next->why;
}

// Shots until both sigmas are at their targets, adaptive or swept evenly.
struct CampaignRun {
  int shots = 0;
  FrictionFit fit;
};

CampaignRun campaign(bool adaptive, std::uint64_t seed, const ShotNoise& noise, int budget = 400) {
  AdaptiveOptions o;
  std::mt19937_64 rng(seed);
  std::vector<double> sweep;
  for (int i = 0; i < budget; ++i) sweep.push_back(10 + 70.0 * (i + 0.5) / budget);
  std::shuffle(sweep.begin(), sweep.end(), rng);
  std::vector<CampaignShot> shots;
  for (int i = 0; i < budget; ++i) {
    const AdaptiveStatus st = assessCampaign(shots, o);
    if (st.targets_met) {
      // The stopping rule is the fit's own sigmas against the targets.
      EXPECT_LE(st.friction->mu.sigma, o.target_sigma_mu);
      EXPECT_LE(st.friction->beta0.sigma, o.target_sigma_beta0);
      return {i, *st.friction};
    }
    double psi = sweep[i];
    if (adaptive) {
      auto next = chooseNextShot(shots, st, o);
      EXPECT_TRUE(next.ok());
      psi = next->incidence_deg;
    }
    shots.push_back(synthesizeShot(kNylon, psi, noise, rng));
  }
  ADD_FAILURE() << "targets not met in " << budget << " shots";
  return {budget, {}};
}

TEST(AdaptiveDesign, StopsAtTheTargetsWithFewerShotsThanASweepAndCoversTheTruth) {
  ShotNoise noise;
  noise.sigma_beta_at_90 = 0.03;
  std::vector<int> adaptive, uniform;
  int covered = 0, runs = 10;
  for (int seed = 1; seed <= runs; ++seed) {
    const CampaignRun a = campaign(true, seed, noise);
    adaptive.push_back(a.shots);
    uniform.push_back(campaign(false, seed, noise).shots);
    covered += std::abs(a.fit.mu.value - kNylon.mu) <= 3 * a.fit.mu.sigma &&
               std::abs(a.fit.beta0.value - kNylon.beta0) <= 3 * a.fit.beta0.sigma;
  }
  std::sort(adaptive.begin(), adaptive.end());
  std::sort(uniform.begin(), uniform.end());
  const double med_a = adaptive[runs / 2], med_u = uniform[runs / 2];
  EXPECT_LE(med_a, 0.5 * med_u) << "adaptive " << med_a << ", uniform " << med_u;
  EXPECT_GE(covered, runs - 1);
}

TEST(AdaptiveDesign, RefusesBadRangesAndTargets) {
  AdaptiveOptions o;
  o.angle_min_deg = 50;
  o.angle_max_deg = 40;
  EXPECT_FALSE(chooseNextShot({}, {}, o).ok());
  o = {};
  o.target_sigma_mu = 0;
  auto r = chooseNextShot({}, {}, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("--target-sigma-mu"), std::string::npos);
}

}  // namespace
}  // namespace collide
