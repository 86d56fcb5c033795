// Results JSON: every field survives the round trip, unknowns are null (not
// invented numbers), the headline keys feed the catalog summary, and bad JSON
// is rejected with the key named.
#include "app/report/results_json.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "app/report/results_summary.hpp"

namespace collide::app {
namespace {

vision::ShotAnalysis sample() {
  vision::ShotAnalysis a;
  a.pixel_size_m = 2.1e-4;
  double k = 1;
  auto next = [&] { return k += 0.37; };
  for (auto& s : a.sphere) {
    for (Estimate3* e : {&s.velocity_before_m_s, &s.velocity_after_m_s, &s.spin_before_rad_s,
                         &s.spin_after_rad_s}) {
      e->value = Vec3(next(), -next(), next());
      e->sigma = Vec3(next(), next(), next()) * 1e-3;
    }
    s.frames_before = static_cast<int>(next());
    s.frames_after = static_cast<int>(next());
    s.spin_before_prior_directions = static_cast<int>(next()) % 4;
  }
  auto& c = a.collision;
  for (vision::Measured* m : {&c.e, &c.beta, &c.beta_from_spins, &c.beta_from_impulse, &c.f,
                              &c.gamma_deg, &c.vn_m_s, &c.vs_m_s, &c.vs_after_m_s, &c.t_collision_s,
                              &c.kinetic_energy_change_J, &c.line_of_centres_z})
    *m = {next(), next() * 1e-3};
  c.beta_spin_weight = 0.25;
  c.t_collision_before_s = next();
  c.t_collision_after_s = next();
  a.quality_flags = {"few_frames_after", "beta_untrustworthy_geometry"};
  a.radius_scatter_px = next() * 1e-2;
  a.radius_systematic_px = next() * 1e-2;
  a.kink_gap = {next() * 1e-6, next() * 1e-6, next() * 1e-9};
  a.notes = {"sphere 1, after the impact: no dots", "the outlines' radii scatter"};
  return a;
}

TEST(ResultsJson, RoundTripKeepsEveryField) {
  const auto a = sample();
  auto r = parseResultsJson(resultsToJson(a));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->error.has_value());
  EXPECT_DOUBLE_EQ(r->pixel_size_m, a.pixel_size_m);
  EXPECT_EQ(r->quality_flags, a.quality_flags);
  EXPECT_EQ(r->radius_scatter_px, a.radius_scatter_px);
  EXPECT_EQ(r->radius_systematic_px, a.radius_systematic_px);
  EXPECT_EQ(r->kink_gap.gap_s, a.kink_gap.gap_s);
  EXPECT_EQ(r->kink_gap.sigma_s, a.kink_gap.sigma_s);
  EXPECT_EQ(r->kink_gap.var_per_px2, a.kink_gap.var_per_px2);
  EXPECT_EQ(r->notes, a.notes);
  for (int s = 0; s < 2; ++s) {
    EXPECT_EQ(r->sphere[s].frames_before, a.sphere[s].frames_before);
    EXPECT_EQ(r->sphere[s].frames_after, a.sphere[s].frames_after);
    EXPECT_EQ(r->sphere[s].spin_before_prior_directions, a.sphere[s].spin_before_prior_directions);
    EXPECT_EQ(r->sphere[s].velocity_before_m_s.value, a.sphere[s].velocity_before_m_s.value);
    EXPECT_EQ(r->sphere[s].velocity_after_m_s.sigma, a.sphere[s].velocity_after_m_s.sigma);
    EXPECT_EQ(r->sphere[s].spin_before_rad_s.value, a.sphere[s].spin_before_rad_s.value);
    EXPECT_EQ(r->sphere[s].spin_after_rad_s.sigma, a.sphere[s].spin_after_rad_s.sigma);
  }
  const auto& c = r->collision;
  EXPECT_EQ(c.e.value, a.collision.e.value);
  EXPECT_EQ(c.e.sigma, a.collision.e.sigma);
  EXPECT_EQ(c.beta.value, a.collision.beta.value);
  EXPECT_EQ(c.beta_from_impulse.sigma, a.collision.beta_from_impulse.sigma);
  EXPECT_EQ(c.beta_from_spins.value, a.collision.beta_from_spins.value);
  EXPECT_EQ(c.beta_from_spins.sigma, a.collision.beta_from_spins.sigma);
  EXPECT_EQ(c.beta_spin_weight, a.collision.beta_spin_weight);
  EXPECT_EQ(c.f.value, a.collision.f.value);
  EXPECT_EQ(c.gamma_deg.value, a.collision.gamma_deg.value);
  EXPECT_EQ(c.vn_m_s.sigma, a.collision.vn_m_s.sigma);
  EXPECT_EQ(c.vs_m_s.value, a.collision.vs_m_s.value);
  EXPECT_EQ(c.vs_after_m_s.value, a.collision.vs_after_m_s.value);
  EXPECT_EQ(c.t_collision_s.value, a.collision.t_collision_s.value);
  EXPECT_EQ(c.t_collision_before_s, a.collision.t_collision_before_s);
  EXPECT_EQ(c.t_collision_after_s, a.collision.t_collision_after_s);
  EXPECT_EQ(c.kinetic_energy_change_J.value, a.collision.kinetic_energy_change_J.value);
  EXPECT_EQ(c.line_of_centres_z.value, a.collision.line_of_centres_z.value);
  EXPECT_EQ(c.line_of_centres_z.sigma, a.collision.line_of_centres_z.sigma);
}

// A count that is not one (negative, or beyond what an int holds) is named,
// not converted.
TEST(ResultsJson, CountsOutOfRangeAreNamed) {
  for (const double bad : {-1.0, 1e300}) {
    auto j = nlohmann::json::parse(resultsToJson(sample()));
    j["sphere2"]["spin_before_prior_directions"] = bad;
    auto r = parseResultsJson(j.dump());
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().message.find("sphere2.spin_before_prior_directions"), std::string::npos)
        << r.error().message;
  }
}

// Results written before beta combined the spins' and the impulse's: beta
// was the spins' alone (weight 1).
TEST(ResultsJson, BetaFromEarlierResultsIsTheSpinsAlone) {
  auto j = nlohmann::json::parse(resultsToJson(sample()));
  j["collision"].erase("beta_from_spins");
  j["uncertainty"].erase("beta_from_spins");
  j["collision"].erase("beta_spin_weight");
  auto r = parseResultsJson(j.dump());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->collision.beta_spin_weight, 1.0);
  EXPECT_EQ(r->collision.beta_from_spins.value, r->collision.beta.value);
  EXPECT_EQ(r->collision.beta_from_spins.sigma, r->collision.beta.sigma);
}

// Results written before the kinks' gaps: none (NaN, not usable); a gap
// that is not a number is named.
TEST(ResultsJson, KinkGapIsOptionalAndCheckedByName) {
  auto j = nlohmann::json::parse(resultsToJson(sample()));
  j.erase("kink_gap");
  auto r = parseResultsJson(j.dump());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(std::isnan(r->kink_gap.gap_s));
  EXPECT_FALSE(r->kink_gap.usable());
  j["kink_gap"] = {{"gap_s", "soon"}};
  r = parseResultsJson(j.dump());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("kink_gap.gap_s"), std::string::npos) << r.error().message;
}

// The out-of-plane measurements: written when measured, null when not.
TEST(ResultsJson, OutOfPlaneMeasurementsAreWrittenWhenMeasured) {
  auto a = sample();
  a.sphere[0].vz_from_size_m_s = {vision::Measured{0.012, 0.004}, std::nullopt};
  a.collision.line_of_centres_z_from_size = vision::Measured{0.031, 0.006};
  const auto j = nlohmann::json::parse(resultsToJson(a));
  EXPECT_EQ(j["sphere1"]["vz_from_size_m_s"][0], 0.012);
  EXPECT_TRUE(j["sphere1"]["vz_from_size_m_s"][1].is_null());
  EXPECT_EQ(j["uncertainty"]["sphere1"]["vz_from_size_m_s"][0], 0.004);
  EXPECT_TRUE(j["sphere2"]["vz_from_size_m_s"][0].is_null());
  EXPECT_EQ(j["collision"]["line_of_centres_z_from_size"], 0.031);
  EXPECT_EQ(j["uncertainty"]["line_of_centres_z_from_size"], 0.006);
  a.collision.line_of_centres_z_from_size.reset();
  EXPECT_FALSE(
      nlohmann::json::parse(resultsToJson(a))["collision"].contains("line_of_centres_z_from_size"));
}

TEST(ResultsJson, IssueKeysArePresentAndFeedTheCatalogSummary) {
  const auto a = sample();
  const auto j = nlohmann::json::parse(resultsToJson(a));
  for (const char* key :
       {"velocity_before_m_s", "velocity_after_m_s", "spin_before_rad_s", "spin_after_rad_s"}) {
    EXPECT_TRUE(j["sphere1"].contains(key)) << key;
    EXPECT_TRUE(j["sphere2"].contains(key)) << key;
  }
  for (const char* key : {"e", "beta", "f", "gamma_deg", "vn_m_s", "vs_m_s", "t_collision_s"}) {
    EXPECT_TRUE(j["collision"].contains(key)) << key;
    EXPECT_TRUE(j["uncertainty"].contains(key)) << key;
  }
  auto summary = summarizeResults(resultsToJson(a));
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  EXPECT_EQ(summary->e, a.collision.e.value);
  EXPECT_EQ(summary->beta, a.collision.beta.value);
  EXPECT_EQ(summary->vs_m_s, a.collision.vs_m_s.value);
  EXPECT_EQ(summary->quality_flags, a.quality_flags);
}

TEST(ResultsJson, UnknownNumbersAreNullNotInvented) {
  auto a = sample();
  a.collision.beta = {std::numeric_limits<double>::quiet_NaN(), 0.1};  // head-on: no beta
  const auto j = nlohmann::json::parse(resultsToJson(a));
  EXPECT_TRUE(j["beta"].is_null());
  EXPECT_TRUE(j["collision"]["beta"].is_null());
  auto r = parseResultsJson(resultsToJson(a));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(std::isnan(r->collision.beta.value));
  auto summary = summarizeResults(resultsToJson(a));
  ASSERT_TRUE(summary.ok());
  EXPECT_FALSE(summary->beta.has_value());
}

TEST(ResultsJson, FailedAnalysisKeepsTheReason) {
  auto r = parseResultsJson(failedResultsJson("only one sphere in 40 of 70 frames"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_TRUE(r->error.has_value());
  EXPECT_EQ(*r->error, "only one sphere in 40 of 70 frames");
  EXPECT_EQ(r->quality_flags, std::vector<std::string>{"analysis_failed"});
  auto shot = toCampaignShot(*r);
  ASSERT_FALSE(shot.ok());
  EXPECT_NE(shot.error().message.find("only one sphere"), std::string::npos);
}

TEST(ResultsJson, BadJsonNamesTheProblem) {
  EXPECT_FALSE(parseResultsJson("{not json").ok());
  EXPECT_FALSE(parseResultsJson("[1, 2]").ok());
  auto r = parseResultsJson(R"({"collision": {"e": "high"}})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("collision.e"), std::string::npos) << r.error().message;
  r = parseResultsJson(R"({"sphere2": {"spin_after_rad_s": [1, 2]}})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("sphere2.spin_after_rad_s"), std::string::npos)
      << r.error().message;
  r = parseResultsJson(R"({"notes": ["fine", 3]})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("notes"), std::string::npos) << r.error().message;
  r = parseResultsJson(R"({"radius_scatter_px": "0.1"})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("radius_scatter_px"), std::string::npos) << r.error().message;
  r = parseResultsJson(R"({"schema": "collide.results/99"})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("collide analyze"), std::string::npos) << r.error().message;
}

// The error budget: written in its order when the analysis made one, read
// back row by row (NaN as null), absent otherwise; a malformed one is named.
TEST(ResultsJson, ErrorBudgetIsWrittenWhenAskedForAndReadBack) {
  auto a = sample();
  EXPECT_FALSE(nlohmann::json::parse(resultsToJson(a)).contains("error_budget"));
  auto r = parseResultsJson(resultsToJson(a));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->error_budget.empty());

  const double nan = std::numeric_limits<double>::quiet_NaN();
  a.error_budget = {{kFitNoise, "trajectory_fits", 0.0021, 0.013, 0.15},
                    {kSpins, "spins", 1e-5, nan, 0.42}};
  const auto j = nlohmann::json::parse(resultsToJson(a));
  ASSERT_EQ(j["error_budget"].size(), 2u);
  EXPECT_EQ(j["error_budget"][0]["source"], "trajectory_fits");
  EXPECT_TRUE(j["error_budget"][1]["beta"].is_null());
  r = parseResultsJson(resultsToJson(a));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->error_budget.size(), 2u);
  EXPECT_EQ(r->error_budget[0].source, "trajectory_fits");
  EXPECT_EQ(r->error_budget[0].e, 0.0021);
  EXPECT_EQ(r->error_budget[0].beta, 0.013);
  EXPECT_EQ(r->error_budget[0].gamma_deg, 0.15);
  EXPECT_EQ(r->error_budget[1].source, "spins");
  EXPECT_TRUE(std::isnan(r->error_budget[1].beta));
  EXPECT_EQ(r->error_budget[1].gamma_deg, 0.42);

  for (const char* bad : {R"({"error_budget": {"spins": 1}})", R"({"error_budget": [{"e": 1}]})",
                          R"({"error_budget": [{"source": "spins", "e": "big"}]})"}) {
    r = parseResultsJson(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().message.find("error_budget"), std::string::npos) << r.error().message;
  }
}

TEST(ResultsJson, CampaignShotCarriesTheSigmas) {
  auto a = sample();
  a.collision.vn_m_s = {-1.2, 0.01};
  a.collision.vs_m_s = {0.8, 0.02};
  auto r = parseResultsJson(resultsToJson(a));
  ASSERT_TRUE(r.ok());
  auto s = toCampaignShot(*r);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->v_n_m_s, -1.2);
  EXPECT_EQ(s->v_s_sigma_m_s, 0.02);
  EXPECT_EQ(s->e, a.collision.e.value);
  EXPECT_EQ(s->beta_sigma, a.collision.beta.sigma);
  EXPECT_DOUBLE_EQ(s->tanIncidence(), 0.8 / 1.2);
}

}  // namespace
}  // namespace collide::app
