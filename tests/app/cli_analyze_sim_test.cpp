// collide campaign -> analyze -> fit on the simulated rig, and analyze
// --frames on exported footage, through the built program as a user runs
// them, checked against the simulation's ground truth stored in each file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "app/report/results_json.hpp"
#include "app/store/shot_file.hpp"
#include "tests/app/cli_run.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

namespace fs = std::filesystem;
using namespace collide::testing;
using ::testing::AnyOf;
using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kRig = std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml";

std::vector<std::string> shotFiles(const std::string& dir) {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".h5") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

// One campaign shared by the tests of this file (firing is the slow part).
class CliAnalyze : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scratch_ = new ScratchDir;
    dir_ = scratch_->file("campaign");
    campaign_ =
        new CommandRun(runCollide("campaign --rig " + q(kRig) + " --shots 8 --seed 3 --out " +
                                      q(dir_) + " --angle-min-deg 10 --angle-max-deg 70",
                                  *scratch_));
  }
  static void TearDownTestSuite() {
    delete campaign_;
    delete scratch_;
  }
  static ScratchDir* scratch_;
  static std::string dir_;
  static CommandRun* campaign_;
};
ScratchDir* CliAnalyze::scratch_ = nullptr;
std::string CliAnalyze::dir_;
CommandRun* CliAnalyze::campaign_ = nullptr;

TEST_F(CliAnalyze, CampaignAnalyzeFitRecoversTheSimulatedMaterial) {
  ASSERT_EQ(campaign_->exit_code, 0) << campaign_->err;
  auto analyze = runCollide("analyze " + q(dir_), *scratch_);
  EXPECT_EQ(analyze.exit_code, 0) << analyze.out << analyze.err;
  const auto files = shotFiles(dir_);
  ASSERT_EQ(files.size(), 8u);
  for (const auto& file : files) {
    auto shot = collide::app::readShot(file, {.frames = false});
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    ASSERT_TRUE(shot->truth.has_value());
    ASSERT_FALSE(shot->results_json.empty()) << file;
    auto r = collide::app::parseResultsJson(shot->results_json);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_FALSE(r->error.has_value()) << *r->error;
    const auto& c = r->collision;
    const double e_true = shot->truth->material.e;
    EXPECT_GT(c.e.sigma, 0.0) << file;
    EXPECT_LT(c.e.sigma, 0.02) << file;
    EXPECT_LT(std::abs(c.e.value - e_true), 4 * c.e.sigma + 1e-3)
        << file << ": e " << c.e.value << " +- " << c.e.sigma << ", truth " << e_true;
    // Contact instant from the first frame; half a frame covers where in the
    // exposure a timestamp is taken.
    EXPECT_NEAR(c.t_collision_s.value, shot->truth->t_collision_s - shot->truth->t_s.front(),
                0.5 / shot->camera.fps)
        << file;
  }
  auto shots = runCollide("shots " + q(dir_) + " --json", *scratch_);
  ASSERT_EQ(shots.exit_code, 0) << shots.err;
  for (const auto& row : nlohmann::json::parse(shots.out)) EXPECT_TRUE(row["e"].is_number());

  auto fit = runCollide("fit " + q(dir_) + " --bootstrap 20", *scratch_);
  ASSERT_EQ(fit.exit_code, 0) << fit.out << fit.err;
  EXPECT_THAT(fit.out, HasSubstr("mu"));
  const std::string out = dir_ + "/fit";
  for (const char* name : {"beta_vs_cot", "tangent_form", "f_vs_tan", "e_vs_tan", "e_vs_vn"}) {
    EXPECT_TRUE(fs::exists(out + "/" + name + ".png")) << name;
    EXPECT_TRUE(fs::exists(out + "/" + name + ".svg")) << name;
  }
  std::ifstream in(out + "/fit.json");
  const auto j = nlohmann::json::parse(in);
  const double mu = j["material"]["mu"]["value"], mu_sigma = j["material"]["mu"]["sigma"];
  EXPECT_GT(mu_sigma, 0.0);
  EXPECT_LT(std::abs(mu - 0.176), 4 * mu_sigma) << "mu " << mu << " +- " << mu_sigma;
}

TEST_F(CliAnalyze, FootageRecordedElsewhereGivesTheSameKinematics) {
  ASSERT_EQ(campaign_->exit_code, 0) << campaign_->err;
  const auto files = shotFiles(dir_);
  ASSERT_FALSE(files.empty());
  const std::string png = scratch_->file("png");
  auto exported = runCollide("export " + q(files[0]) + " --png " + q(png), *scratch_);
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  auto shot = collide::app::readShot(files[0], {.frames = false});
  ASSERT_TRUE(shot.ok());
  const std::string json = scratch_->file("footage.json");
  auto run =
      runCollide("analyze --frames " + q(png) + " --fps " + std::to_string(shot->camera.fps) +
                     " --diameter-mm 25.4 --json " + q(json),
                 *scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  std::ifstream in(json);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto r = collide::app::parseResultsJson(text);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto& c = r->collision;
  EXPECT_LT(std::abs(c.e.value - shot->truth->material.e), 4 * c.e.sigma + 1e-3);
  // The pixel scale came from the measured radius and the given diameter.
  EXPECT_NEAR(r->pixel_size_m, shot->scene.pixel_size_m, 0.01 * shot->scene.pixel_size_m);
  const auto j = nlohmann::json::parse(text);
  for (const char* key :
       {"velocity_before_m_s", "velocity_after_m_s", "spin_before_rad_s", "spin_after_rad_s"})
    EXPECT_EQ(j["sphere1"][key].size(), 3u) << key;
}

// --error-budget: each shot's sigmas of e, beta and gamma split by source,
// printed under its summary and stored with its results; they add up in
// quadrature to the stated sigmas (each from 300 Monte Carlo draws, known to
// about 4 %, so to 20 % at 3.5 standard deviations of the difference).
// Without it, results carry none; with --wall it is refused, not ignored.
TEST_F(CliAnalyze, ErrorBudgetSaysWhatEachSigmaIsMadeOf) {
  ASSERT_EQ(campaign_->exit_code, 0) << campaign_->err;
  const auto files = shotFiles(dir_);
  ASSERT_GE(files.size(), 3u);
  const std::string dir = scratch_->file("budget");
  fs::create_directories(dir);
  const std::string file = dir + "/copied-shot.h5";  // not <id>.h5: stored in the file only
  fs::copy_file(files[2], file);
  auto run = runCollide("analyze " + q(file) + " --error-budget", *scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_THAT(run.out, HasSubstr("sigma by source"));
  EXPECT_THAT(run.out, HasSubstr("trajectory_fits"));
  auto shot = collide::app::readShot(file, {.frames = false});
  ASSERT_TRUE(shot.ok()) << shot.error().message;
  auto r = collide::app::parseResultsJson(shot->results_json);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->error_budget.size(), 8u);
  double e2 = 0, g2 = 0;
  for (const auto& row : r->error_budget) e2 += row.e * row.e, g2 += row.gamma_deg * row.gamma_deg;
  const auto& c = r->collision;
  EXPECT_NEAR(std::sqrt(e2), c.e.sigma, 0.2 * c.e.sigma);
  EXPECT_NEAR(std::sqrt(g2), c.gamma_deg.sigma, 0.2 * c.gamma_deg.sigma);
  EXPECT_EQ(r->error_budget.front().source, "trajectory_fits");
  EXPECT_GT(r->error_budget.front().e, 0.0);

  auto plain = runCollide("analyze " + q(file), *scratch_);
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_THAT(plain.out, Not(HasSubstr("sigma by source")));
  shot = collide::app::readShot(file, {.frames = false});
  ASSERT_TRUE(shot.ok());
  r = collide::app::parseResultsJson(shot->results_json);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->error_budget.empty());

  const std::string png = scratch_->file("png-budget");
  ASSERT_EQ(runCollide("export " + q(file) + " --png " + q(png), *scratch_).exit_code, 0);
  run = runCollide("analyze --frames " + q(png) +
                       " --fps 1000 --diameter-mm 25.4 --wall "
                       "--error-budget",
                   *scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("--error-budget"));
}

TEST_F(CliAnalyze, BadFootageGetsAClearMessage) {
  const std::string empty = scratch_->file("not-frames");
  fs::create_directories(empty);
  std::ofstream(empty + "/notes.txt") << "not an image";
  auto run =
      runCollide("analyze --frames " + q(empty) + " --fps 1000 --diameter-mm 25.4", *scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("not-frames"));

  run = runCollide("analyze --frames " + q(empty) + " --fps 1000", *scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("--diameter-mm is required"));

  // Given, but not a value the option can mean: named as such, not "required".
  for (const char* args : {" --fps nan --diameter-mm 25.4", " --fps 1000 --diameter-mm 0",
                           " --fps -3 --diameter-mm 25.4", " --fps 1000 --diameter-mm nan"}) {
    run = runCollide("analyze --frames " + q(empty) + args, *scratch_);
    EXPECT_EQ(run.exit_code, 2) << args;
    EXPECT_THAT(run.err, Not(HasSubstr("required"))) << args << ": " << run.err;
    EXPECT_THAT(run.err, AnyOf(HasSubstr("--fps "), HasSubstr("--diameter-mm "))) << args;
  }

  const std::string video = scratch_->file("broken.avi");
  std::ofstream(video) << "RIFF....AVI garbage, not a decodable video";
  run = runCollide("analyze --frames " + q(video) + " --diameter-mm 25.4", *scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("broken.avi"));

  run = runCollide("analyze " + q(scratch_->file("missing.h5")), *scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("missing.h5"));

  run = runCollide(
      "analyze --frames " + q(empty) + " --fps 1000 --diameter-mm 25.4 --gravity-dir sideways",
      *scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("--gravity-dir"));
}

TEST_F(CliAnalyze, AWrongDiameterIsFlaggedOrRefusedNeverSilent) {
  ASSERT_EQ(campaign_->exit_code, 0) << campaign_->err;
  const auto files = shotFiles(dir_);
  const std::string png = scratch_->file("png-wrong");
  ASSERT_EQ(runCollide("export " + q(files[1]) + " --png " + q(png), *scratch_).exit_code, 0);
  const std::string json = scratch_->file("wrong.json");
  // 10 mm instead of 25.4: every length (and g) is off by 2.5 times.
  auto run = runCollide(
      "analyze --frames " + q(png) + " --fps 1000 --diameter-mm 10 --json " + q(json), *scratch_);
  if (run.exit_code == 0) {
    std::ifstream in(json);
    const auto j = nlohmann::json::parse(in);
    EXPECT_FALSE(j["quality_flags"].empty()) << "a 2.5x wrong scale went unnoticed";
  } else {
    EXPECT_FALSE(run.err.empty());
  }
}

// What the analysis has to say beyond the numbers reaches the user: under a
// noisy sensor (sim.toml's camera at 40 grey levels of noise, a profile
// bounding the radius bias at 0.02 px) the outlines scatter by more, and the
// radius bias allowed for is widened; the note saying so is
// printed under the shot's line and stored with its results. The quiet
// campaign's shots print no such note.
TEST_F(CliAnalyze, TheAnalysisNotesArePrintedAndStored) {
  ASSERT_EQ(campaign_->exit_code, 0) << campaign_->err;
  std::ifstream in(kRig);
  std::string rig((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string quiet = "noise_grey = 1.5";
  const auto at = rig.find(quiet);
  ASSERT_NE(at, std::string::npos) << "sim.toml's camera noise moved";
  rig.replace(at, quiet.size(), "noise_grey = 40.0");
  // The profile's own bound below what such outlines scatter by.
  const auto analysis = rig.find("[analysis]\n");
  ASSERT_NE(analysis, std::string::npos);
  rig.insert(analysis + 11, "radius_systematic_px = 0.02\n");
  const std::string noisy_rig = scratch_->file("noisy.toml");
  std::ofstream(noisy_rig) << rig;
  const std::string dir = scratch_->file("noisy-shots");
  auto fired = runCollide("campaign --rig " + q(noisy_rig) + " --shots 1 --seed 5 --out " + q(dir),
                          *scratch_);
  ASSERT_EQ(fired.exit_code, 0) << fired.err;
  auto run = runCollide("analyze " + q(dir), *scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_THAT(run.out, HasSubstr("\n    note: the outlines' radii scatter by"));
  const auto files = shotFiles(dir);
  ASSERT_EQ(files.size(), 1u);
  auto shot = collide::app::readShot(files[0], {.frames = false});
  ASSERT_TRUE(shot.ok()) << shot.error().message;
  auto r = collide::app::parseResultsJson(shot->results_json);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_GT(r->radius_systematic_px, 0.02) << "scatter " << r->radius_scatter_px;
  ASSERT_FALSE(r->notes.empty());
  EXPECT_THAT(r->notes, Contains(HasSubstr("radius_systematic_px says")));

  auto quiet_run = runCollide("analyze " + q(shotFiles(dir_)[0]), *scratch_);
  ASSERT_EQ(quiet_run.exit_code, 0) << quiet_run.err;
  EXPECT_THAT(quiet_run.out, Not(HasSubstr("radii scatter")));
}

}  // namespace
