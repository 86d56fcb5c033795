// collide manifest -> analyze --manifest (as batch tasks) -> fit --manifest on
// a small simulated campaign split over two folders, through the built
// program: the chunks cover every shot once, SLURM_ARRAY_TASK_ID picks the
// chunk, errors name the manifest's line, and the exit status says whether
// any shot of the chunk failed. (The same against a real Slurm:
// slurm_cluster_test.cpp, which needs root.)
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"
#include "tests/app/cli_run.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

namespace fs = std::filesystem;
using namespace collide::testing;
using ::testing::HasSubstr;

const std::string kRig = std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml";

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

TEST(CliManifest, TasksOfAManifestAnalyseEveryShotOnceAndFitTheCampaign) {
  unsetenv("SLURM_ARRAY_TASK_ID");  // when the suite itself runs under Slurm
  ScratchDir scratch;
  for (const char* part : {"a", "b"}) {
    auto fired = runCollide("campaign --rig " + q(kRig) +
                                " --shots 5 --angle-min-deg 10 --angle-max-deg 70 --seed " +
                                (part[0] == 'a' ? "5" : "6") + " --out " + q(scratch.file(part)),
                            scratch);
    ASSERT_EQ(fired.exit_code, 0) << fired.err;
  }
  const std::string list = scratch.file("all.list");
  auto made = runCollide("manifest " + q(scratch.file("a")) + " " + q(scratch.file("b")) +
                             " --out " + q(list) + " --chunk 4",
                         scratch);
  ASSERT_EQ(made.exit_code, 0) << made.err;
  EXPECT_THAT(made.err,
              HasSubstr("10 shot files from 2 folders: 3 tasks of 4 (sbatch --array=0-2)"));
  const auto paths = lines(readAll(list));
  ASSERT_EQ(paths.size(), 10u);
  for (const auto& p : paths) EXPECT_TRUE(fs::path(p).is_absolute()) << p;

  // Three tasks of 4, 4 and 2 shots, the second through SLURM_ARRAY_TASK_ID
  // as under Slurm.
  for (int i = 0; i < 3; ++i) {
    const std::string index = i == 1 ? "" : " --index " + std::to_string(i);
    auto task = runCollide("analyze --manifest " + q(list) + " --chunk 4" + index + " --jobs 1",
                           scratch, i == 1 ? "SLURM_ARRAY_TASK_ID=1 " : "");
    EXPECT_EQ(task.exit_code, 0) << task.out << task.err;
    const int first = 4 * i, last = std::min(first + 3, 9);
    EXPECT_THAT(task.out, HasSubstr("task " + std::to_string(i) + " (shots " +
                                    std::to_string(first) + "-" + std::to_string(last) +
                                    " of 10): " + std::to_string(last - first + 1) + " analysed"));
    EXPECT_THAT(task.out, HasSubstr(list + ":" + std::to_string(first + 1) + ": "));
  }
  for (const auto& p : paths) {
    auto shot = collide::app::readShot(p, {.frames = false});
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    EXPECT_FALSE(shot->results_json.empty()) << p << " was not analysed";
  }

  // The reduce step over the manifest, and over the two folders.
  auto fit = runCollide(
      "fit --manifest " + q(list) + " --out " + q(scratch.file("fit")) + " --bootstrap 0", scratch);
  EXPECT_EQ(fit.exit_code, 0) << fit.out << fit.err;
  EXPECT_THAT(fit.out, HasSubstr(" of 10 shots used"));
  auto fit2 = runCollide("fit " + q(scratch.file("a")) + " " + q(scratch.file("b")) + " --out " +
                             q(scratch.file("fit2")) + " --bootstrap 0",
                         scratch);
  EXPECT_EQ(fit2.exit_code, 0) << fit2.out << fit2.err;
  EXPECT_THAT(fit2.out, HasSubstr(" of 10 shots used"));
  EXPECT_TRUE(fs::exists(scratch.file("fit2/fit.json")));
  auto no_out = runCollide("fit " + q(scratch.file("a")) + " " + q(scratch.file("b")), scratch);
  EXPECT_EQ(no_out.exit_code, 2);
  EXPECT_THAT(no_out.err, HasSubstr("--out"));

  // Errors: past the end (exit 2), a shot gone (exit 1, naming its line),
  // --chunk without an index, a bad SLURM_ARRAY_TASK_ID.
  auto past = runCollide("analyze --manifest " + q(list) + " --chunk 4 --index 3", scratch);
  EXPECT_EQ(past.exit_code, 2);
  EXPECT_THAT(past.err, HasSubstr("--array=0-2"));
  fs::rename(paths[8], paths[8] + ".moved");
  auto gone = runCollide("analyze --manifest " + q(list) + " --chunk 4 --index 2", scratch);
  EXPECT_EQ(gone.exit_code, 1) << gone.out << gone.err;
  EXPECT_THAT(gone.out, HasSubstr(list + ":9: "));
  EXPECT_THAT(gone.out, HasSubstr(paths[8]));
  EXPECT_THAT(gone.out,
              HasSubstr("1 analysed, 0 without a measurable collision, 1 could not be analysed"));
  auto no_index = runCollide("analyze --manifest " + q(list) + " --chunk 4", scratch);
  EXPECT_EQ(no_index.exit_code, 2);
  EXPECT_THAT(no_index.err, HasSubstr("SLURM_ARRAY_TASK_ID"));
  auto bad_env = runCollide("analyze --manifest " + q(list), scratch, "SLURM_ARRAY_TASK_ID=x ");
  EXPECT_EQ(bad_env.exit_code, 2);
  EXPECT_THAT(bad_env.err, HasSubstr("'x' is not a task index"));
}

// A shot with no collision to measure (here: frames with no sphere at all; on
// the rig, spheres that miss each other) is a verdict on the shot, stored as
// its results, not a failed task: the task exits 0, so a reduce step queued
// with --dependency=afterok still runs, and says how many such shots there were.
TEST(CliManifest, AShotWithNoCollisionIsStoredAndDoesNotFailTheTask) {
  unsetenv("SLURM_ARRAY_TASK_ID");
  ScratchDir scratch;
  const std::string dir = scratch.file("odd");
  fs::create_directories(dir);
  ShotSpec spec;
  spec.results = false;
  auto id = collide::app::saveShot(dir, makeShot(spec));
  ASSERT_TRUE(id.ok()) << id.error().message;
  const std::string file = dir + "/" + *id + ".h5";
  const std::string list = scratch.file("odd.list");
  ASSERT_EQ(runCollide("manifest " + q(dir) + " --out " + q(list), scratch).exit_code, 0);
  auto task = runCollide("analyze --manifest " + q(list) + " --index 0", scratch);
  EXPECT_EQ(task.exit_code, 0) << task.out << task.err;
  EXPECT_THAT(task.out, HasSubstr("no measurable collision (stored as its results)"));
  EXPECT_THAT(task.out,
              HasSubstr("0 analysed, 1 without a measurable collision, 0 could not be analysed"));
  auto shot = collide::app::readShot(file, {.frames = false});
  ASSERT_TRUE(shot.ok()) << shot.error().message;
  EXPECT_THAT(shot->results_json, HasSubstr("\"error\""));
  // The same verdict from a folder and from the file itself.
  auto folder = runCollide("analyze " + q(dir), scratch);
  EXPECT_EQ(folder.exit_code, 0) << folder.out << folder.err;
  EXPECT_THAT(folder.out, HasSubstr("1 without a measurable collision"));
  auto one = runCollide("analyze " + q(file), scratch);
  EXPECT_EQ(one.exit_code, 0) << one.out << one.err;
  EXPECT_THAT(one.out, HasSubstr("no measurable collision"));
}

}  // namespace
