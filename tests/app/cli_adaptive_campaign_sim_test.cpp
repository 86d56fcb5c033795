// `collide campaign --adaptive` on the simulated rig (issue 16 §2): every shot
// says why it was chosen, the campaign stops as soon as the fit's sigmas reach
// the targets (and not before: checked against `collide fit` on the same
// folder), an unreachable target spends the budget and exits 1, and bad
// targets are refused before anything is fired.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>

#include "cli_run.hpp"

namespace collide::testing {
namespace {

int countShots(const std::string& dir) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) n += e.path().extension() == ".h5";
  return n;
}

int countOf(const std::string& text, const std::string& what) {
  int n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

TEST(CliAdaptiveCampaign, StopsAtTheTargetsAndSaysWhyEachShot) {
  ScratchDir scratch;
  const std::string out = scratch.file("shots");
  const std::string rig = q(std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml");
  auto run = runCollide("campaign --rig " + rig + " --adaptive --target-sigma-mu 0.005 " +
                            "--target-sigma-beta0 0.02 --shots 30 --seed 3 --out " + q(out),
                        scratch);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("targets reached"), std::string::npos) << run.out;
  const int shots = countShots(out);
  EXPECT_GE(shots, 6);
  EXPECT_LT(shots, 30);
  EXPECT_EQ(countOf(run.out, "  why: "), shots) << run.out;
  // The shots' own fit agrees that the targets are met.
  auto fit = runCollide("fit " + q(out) + " --bootstrap 0", scratch);
  ASSERT_EQ(fit.exit_code, 0) << fit.out << fit.err;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(fit.out, m, std::regex(R"(mu\s+([0-9.]+) ± ([0-9.]+))")))
      << fit.out;
  EXPECT_LE(std::stod(m[2]), 0.005) << fit.out;
}

TEST(CliAdaptiveCampaign, UnreachableTargetsSpendTheBudgetAndFail) {
  ScratchDir scratch;
  const std::string out = scratch.file("shots");
  const std::string rig = q(std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml");
  auto run = runCollide("campaign --rig " + rig + " --adaptive --target-sigma-mu 1e-9 " +
                            "--shots 8 --seed 3 --out " + q(out),
                        scratch);
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.err.find("targets not reached within 8 shots"), std::string::npos) << run.err;
  EXPECT_EQ(countShots(out), 8);
}

TEST(CliAdaptiveCampaign, BadTargetsAreRefusedBeforeFiring) {
  ScratchDir scratch;
  const std::string out = scratch.file("shots");
  const std::string rig = q(std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml");
  auto run = runCollide(
      "campaign --rig " + rig + " --adaptive --target-sigma-mu 0 --shots 8 --out " + q(out),
      scratch);
  EXPECT_EQ(run.exit_code, 2) << run.out << run.err;
  EXPECT_NE(run.err.find("--target-sigma-mu"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(out) && countShots(out) > 0);
}

}  // namespace
}  // namespace collide::testing
