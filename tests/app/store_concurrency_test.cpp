// Storing results from several processes into one shot folder at once (a
// cluster's array tasks), and stores killed midway: the file and its catalog
// row always agree, nothing is lost, and no temporary file outlives a retry.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <map>

#include "app/report/results_summary.hpp"
#include "app/store/atomic_file.hpp"
#include "app/store/catalog.hpp"
#include "app/store/save.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

namespace fs = std::filesystem;
using namespace collide::app;
using namespace collide::testing;

std::string resultsWithE(double e) {
  return R"({"e": )" + std::to_string(e) + R"(, "beta": 0.4, "quality_flags": []})";
}

std::vector<std::string> leftovers(const std::string& dir) {
  auto contents = listShotFolder(dir);
  EXPECT_TRUE(contents.ok());
  return contents ? contents->leftovers : std::vector<std::string>{};
}

std::vector<std::string> saveShots(const std::string& dir, int n) {
  std::vector<std::string> ids;
  for (int i = 0; i < n; ++i) {
    ShotSpec spec;
    spec.id = "20260314-101500-" + std::to_string(1000 + i);
    spec.results = false;
    spec.width = 160;
    spec.height = 120;
    auto id = saveShot(dir, makeShot(spec));
    EXPECT_TRUE(id.ok()) << id.error().message;
    ids.push_back(*id);
  }
  return ids;
}

TEST(StoreConcurrency, ProcessesStoringIntoOneFolderLeaveEveryFileAgreeingWithItsRow) {
  ScratchDir dir;
  const auto ids = saveShots(dir.path(), 6);
  constexpr int kTasks = 4, kRounds = 3;
  std::vector<pid_t> children;
  for (int t = 0; t < kTasks; ++t) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      int failures = 0;
      for (int round = 0; round < kRounds; ++round)
        for (std::size_t k = 0; k < ids.size(); ++k) {
          // Each task its own order and its own results, so that a file and a
          // row written by different tasks would show.
          const auto& id = ids[(k + t) % ids.size()];
          if (!saveResults(dir.path(), id, resultsWithE(0.5 + 0.1 * t))) ++failures;
        }
      _exit(failures);
    }
    children.push_back(pid);
  }
  for (pid_t pid : children) {
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "a task failed to store";
  }
  auto catalog = Catalog::open(dir.path());
  ASSERT_TRUE(catalog.ok()) << catalog.error().message;
  auto rows = catalog->query();
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows->size(), ids.size());
  for (const auto& row : *rows) {
    auto shot = readShot(dir.file(row.id + ".h5"), {.frames = true});
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    auto stored = summarizeResults(shot->results_json);
    ASSERT_TRUE(stored.ok()) << row.id << ": " << shot->results_json;
    ASSERT_TRUE(stored->e.has_value());
    EXPECT_TRUE(row.analysed);
    EXPECT_EQ(row.results.e, stored->e) << row.id << ": the row and the file disagree";
  }
  EXPECT_TRUE(leftovers(dir.path()).empty());
}

TEST(StoreConcurrency, AStoreKilledMidwayLeavesTheShotAndARetryRemovesItsTemporaryCopy) {
  ScratchDir dir;
  const auto ids = saveShots(dir.path(), 1);
  const std::string path = dir.file(ids[0] + ".h5");
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    // A store caught between copying the file and renaming the copy.
    auto temp = AtomicFile::createCopyOf(path, path);
    const char c = temp.ok() ? 'y' : 'n';
    (void)!write(ready[1], &c, 1);
    pause();
    _exit(0);
  }
  close(ready[1]);
  char c = 0;
  ASSERT_EQ(read(ready[0], &c, 1), 1);
  close(ready[0]);
  ASSERT_EQ(c, 'y');
  kill(pid, SIGKILL);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_EQ(leftovers(dir.path()).size(), 1u) << "the killed store left its copy";
  auto untouched = readShot(path);
  ASSERT_TRUE(untouched.ok()) << untouched.error().message;
  EXPECT_TRUE(untouched->results_json.empty());

  ASSERT_TRUE(saveResults(dir.path(), ids[0], resultsWithE(0.9)).ok());
  EXPECT_TRUE(leftovers(dir.path()).empty()) << "the retry did not remove the abandoned copy";
  auto stored = readShot(path, {.frames = false});
  ASSERT_TRUE(stored.ok());
  EXPECT_NE(stored->results_json.find("0.9"), std::string::npos);
}

TEST(StoreConcurrency, AWriteInProgressIsNotTakenForAnAbandonedOne) {
  ScratchDir dir;
  const auto ids = saveShots(dir.path(), 1);
  const std::string path = dir.file(ids[0] + ".h5");
  {
    auto temp = AtomicFile::createCopyOf(path, path);
    ASSERT_TRUE(temp.ok());
    EXPECT_EQ(removeAbandonedTemps(path), 0);
    EXPECT_TRUE(fs::exists(temp->tempPath())) << "a live write's copy was removed";
  }
  EXPECT_TRUE(leftovers(dir.path()).empty());
  // An empty leftover may be a write between creating and locking its file:
  // only removed once old. A non-empty one whose writer is gone goes at once.
  const std::string fresh = dir.file("." + ids[0] + ".h5.tmp-abcdef");
  { std::ofstream(fresh).flush(); }
  EXPECT_EQ(removeAbandonedTemps(path), 0);
  { std::ofstream(fresh) << "half a copy"; }
  EXPECT_EQ(removeAbandonedTemps(path), 1);
  EXPECT_FALSE(fs::exists(fresh));
}

TEST(StoreConcurrency, TheStoreLockExcludesAnotherProcess) {
  ScratchDir dir;
  const std::string lock_path = storeLockPath(dir.path());
  auto held = FileLock::acquire(lock_path);
  ASSERT_TRUE(held.ok()) << held.error().message;
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    alarm(2);  // SIGALRM ends the child if it waits (the expected case)
    auto second = FileLock::acquire(lock_path);
    _exit(second.ok() ? 3 : 4);
  }
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM)
      << "another process took the lock while it was held";
}

}  // namespace
