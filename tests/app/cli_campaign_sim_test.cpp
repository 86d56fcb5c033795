// `collide campaign` run as a user runs it, several times into one folder:
// every shot fired is kept (issue 15, item 1: shot ids are the UTC second plus
// a per-campaign counter, so campaigns in the same second used to overwrite
// each other's files and catalog rows).
#include <gtest/gtest.h>

#include <filesystem>
#include <future>
#include <regex>
#include <set>

#include "app/store/catalog.hpp"
#include "app/store/shot_file.hpp"
#include "tests/app/cli_run.hpp"

namespace collide::testing {
namespace {

const std::string kRig = std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml";

// Every shot file holds the shot its name says; one catalog row per file.
std::size_t keptShots(const std::string& dir) {
  std::set<std::string> ids;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() != ".h5") continue;
    const auto shot = app::readShot(e.path().string(), {.frames = false});
    EXPECT_TRUE(shot.ok()) << shot.error().message;
    if (!shot) continue;
    EXPECT_EQ(shot->id + ".h5", e.path().filename().string());
    ids.insert(shot->id);
  }
  auto rows = app::Catalog::open(dir)->query();
  EXPECT_TRUE(rows.ok());
  std::set<std::string> row_ids;
  for (const auto& r : *rows) {
    EXPECT_EQ(r.file, r.id + ".h5");
    row_ids.insert(r.id);
  }
  EXPECT_EQ(row_ids, ids) << "catalog rows and files differ";
  return ids.size();
}

// config/sim.toml with the first `from` replaced by `to`, written to
// `scratch`/`name`; empty when `from` is not in the profile.
std::string editedRig(const ScratchDir& scratch, const std::string& from, const std::string& to,
                      const std::string& name) {
  std::string text = readAll(kRig);
  const auto at = text.find(from);
  if (at == std::string::npos) return "";
  text.replace(at, from.size(), to);
  const std::string rig = scratch.file(name);
  writeAll(rig, text);
  return rig;
}

// Shots a campaign says it fired ("N shots fired (...)"); failed shots are
// saved too, so every one of them must be in the folder. On a loaded machine
// (the sanitizer build) the simulated camera can miss its deadline and a shot
// fails: it still counts, and must still be kept.
int firedShots(const CommandRun& run) {
  std::smatch m;
  static const std::regex fired(R"((\d+) shots? fired)");
  return std::regex_search(run.out, m, fired) ? std::stoi(m[1]) : -1;
}

TEST(CliCampaign, ThreeCampaignsIntoOneFolderKeepAllSixShots) {
  ScratchDir scratch;
  const std::string out = scratch.file("shots");
  int fired = 0;
  for (int seed = 1; seed <= 3; ++seed) {
    const auto run = runCollide("campaign --rig " + q(kRig) + " --shots 2 --out " + q(out) +
                                    " --seed " + std::to_string(seed),
                                scratch);
    ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 1) << run.out << run.err;
    ASSERT_GE(firedShots(run), 0) << run.out;
    fired += firedShots(run);
  }
  EXPECT_EQ(fired, 6) << "a campaign stopped early";
  EXPECT_EQ(keptShots(out), static_cast<std::size_t>(fired));
}

TEST(CliCampaign, TwoCampaignsAtOnceIntoOneFolderKeepEveryShot) {
  ScratchDir scratch;
  const std::string out = scratch.file("shots");
  ScratchDir logs[2];  // each run's stderr in its own folder
  auto campaign = [&](int seed) {
    return runCollide("campaign --rig " + q(kRig) + " --shots 4 --out " + q(out) + " --seed " +
                          std::to_string(seed),
                      logs[seed - 1]);
  };
  auto a = std::async(std::launch::async, campaign, 1);
  auto b = std::async(std::launch::async, campaign, 2);
  const auto ra = a.get(), rb = b.get();
  for (const auto* r : {&ra, &rb}) {
    ASSERT_TRUE(r->exit_code == 0 || r->exit_code == 1) << r->out << r->err;
    ASSERT_GE(firedShots(*r), 1) << r->out;
  }
  EXPECT_EQ(keptShots(out), static_cast<std::size_t>(firedShots(ra) + firedShots(rb)));
}

// A regulator whose link fails on every shot: the campaign stops after three
// failures in a row instead of firing on, keeps what it fired, and exits 1.
TEST(CliCampaign, RepeatedDeviceFailuresStopTheCampaignWithExitCode1) {
  ScratchDir scratch;
  const std::string rig =
      editedRig(scratch, "fault = \"none\"            # \"none\" | \"never_settles\"",
                "fault = \"error\" # \"none\" | \"never_settles\"", "broken-regulator.toml");
  ASSERT_FALSE(rig.empty()) << "sim.toml changed: update this test";
  const std::string out = scratch.file("shots");
  const auto run =
      runCollide("campaign --rig " + q(rig) + " --shots 8 --out " + q(out) + " --seed 1", scratch);
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.err.find("3 shots in a row failed"), std::string::npos) << run.err;
  EXPECT_NE(run.out.find("3 shots fired (0 ok, 3 failed)"), std::string::npos) << run.out;
  EXPECT_EQ(keptShots(out), 3u) << "every fired shot is saved, failed ones included";
}

// A regulator that stops answering mid-campaign (after 2 shots' setpoints):
// it is lost, the next shot is refused at once, the campaign stops with the
// device, what to check and that retrying will not help, exits 1, and every
// shot fired is kept.
TEST(CliCampaign, ARegulatorThatGoesSilentStopsTheCampaignAtOnceWithExitCode1) {
  ScratchDir scratch;
  const std::string rig =
      editedRig(scratch, "fault = \"none\"            # \"none\" | \"never_settles\"",
                "fault = \"silent\"\nsilent_after_setpoints = 4\nsilent_timeout_ms = 50 #",
                "silent-regulator.toml");
  ASSERT_FALSE(rig.empty()) << "sim.toml changed: update this test";
  const std::string out = scratch.file("shots");
  const auto run =
      runCollide("campaign --rig " + q(rig) + " --shots 6 --out " + q(out) + " --seed 1", scratch);
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.err.find("stopped after 3 of 6 shots: the next shot was refused: regulator "
                         "\"sim-regulator\" is lost (no answer within 50 ms"),
            std::string::npos)
      << run.err;
  EXPECT_NE(run.err.find("retrying will not help"), std::string::npos) << run.err;
  EXPECT_NE(run.out.find("3 shots fired (2 ok, 1 failed)"), std::string::npos) << run.out;
  EXPECT_EQ(keptShots(out), 3u) << "every fired shot is saved, the failed one included";
}

TEST(CliCampaign, ABadProfileIsRefusedAtLoadWithExitCode2BeforeAnyShot) {
  ScratchDir scratch;
  const std::string rig =
      editedRig(scratch, "backend = \"sim\"\ndevice = \"sim-regulator\"",
                "backend = \"nonesuch\"\ndevice = \"sim-regulator\"", "bad-backend.toml");
  ASSERT_FALSE(rig.empty()) << "sim.toml changed: update this test";
  const std::string out = scratch.file("shots");
  const auto run =
      runCollide("campaign --rig " + q(rig) + " --shots 2 --out " + q(out) + " --seed 1", scratch);
  EXPECT_EQ(run.exit_code, 2) << run.out << run.err;
  EXPECT_NE(run.err.find("nonesuch"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(out) && !std::filesystem::is_empty(out))
      << "nothing fired or saved";
}

// The disk fills up (here: a file size limit) while a shot is written: a clear
// message and exit status 1, not a crash in HDF5's clean-up at exit (status
// 139), and no half file or temporary file left.
TEST(CliCampaign, AWriteThatFailsMidwayEndsWithAMessageNotACrash) {
  ScratchDir scratch;
  const std::string out = scratch.file("shots");
  const auto run =
      runCollide("campaign --rig " + q(kRig) + " --shots 1 --out " + q(out) + " --seed 1", scratch,
                 "ulimit -f 2000; ");
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.err.find("file too large"), std::string::npos) << run.err;
  std::size_t left = 0;
  for (const auto& e : std::filesystem::directory_iterator(out))
    if (e.path().filename().string().find(".h5") != std::string::npos) ++left;
  EXPECT_EQ(left, 0u) << "a half-written shot or its temporary file was left in " << out;
}

// --out that cannot take shots is refused before anything is fired.
TEST(CliCampaign, AnOutThatIsAFileIsRefusedBeforeFiring) {
  ScratchDir scratch;
  const std::string out = scratch.file("not-a-folder");
  writeAll(out, "x");
  const auto run =
      runCollide("campaign --rig " + q(kRig) + " --shots 2 --out " + q(out) + " --seed 1", scratch);
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.err.find(out + " is not a folder"), std::string::npos) << run.err;
  EXPECT_EQ(run.out.find("fired"), std::string::npos) << "a shot was fired: " << run.out;
}

}  // namespace
}  // namespace collide::testing
