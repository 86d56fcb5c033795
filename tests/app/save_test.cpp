#include "app/store/save.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <set>

#include "app/store/catalog.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

using collide::app::Catalog;
using collide::app::saveShot;
using namespace collide::testing;
using ::testing::AllOf;
using ::testing::HasSubstr;

std::size_t catalogRows(const std::string& dir) {
  auto catalog = Catalog::open(dir);
  EXPECT_TRUE(catalog.ok()) << catalog.error().message;
  auto rows = catalog->query();
  EXPECT_TRUE(rows.ok());
  return rows->size();
}

ShotSpec bigShot(const std::string& id) {
  ShotSpec spec;
  spec.id = id;
  spec.width = 320;
  spec.height = 240;
  spec.frames = 10;  // ~600 kB of frames
  return spec;
}

TEST(SaveShot, WritesTheFileThenItsRow) {
  ScratchDir dir;
  const auto shot = makeShot();
  const std::string folder = dir.file("new/shots");  // created on demand
  const auto s = saveShot(folder, shot);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_TRUE(std::filesystem::is_regular_file(folder + "/" + shot.id + ".h5"));
  auto rows = Catalog::open(folder)->query();
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows->size(), 1u);
  EXPECT_EQ((*rows)[0].id, shot.id);
  EXPECT_EQ((*rows)[0].file, shot.id + ".h5");
}

// Every file in `dir` holds the shot its name says, and the catalog has
// exactly one row per file, pointing at it: nothing was overwritten.
void expectEveryShotKept(const std::string& dir, std::size_t expected) {
  std::set<std::string> ids;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() != ".h5") continue;
    const auto shot = collide::app::readShot(e.path().string(), {.frames = false});
    ASSERT_TRUE(shot.ok()) << shot.error().message;
    EXPECT_EQ(shot->id + ".h5", e.path().filename().string()) << "file holds another shot";
    ids.insert(shot->id);
  }
  EXPECT_EQ(ids.size(), expected);
  auto rows = Catalog::open(dir)->query();
  ASSERT_TRUE(rows.ok()) << rows.error().message;
  std::set<std::string> row_ids;
  for (const auto& r : *rows) {
    EXPECT_EQ(r.file, r.id + ".h5");
    row_ids.insert(r.id);
  }
  EXPECT_EQ(row_ids, ids);
}

TEST(SaveShot, ASecondShotWithTheSameIdTakesTheNextIdAndReplacesNothing) {
  ScratchDir dir;
  ShotSpec a_spec;
  a_spec.rig_name = "first";
  const auto a = makeShot(a_spec);
  ShotSpec b_spec;  // same id, different content
  b_spec.rig_name = "second";
  b_spec.seed = 11;
  const auto b = makeShot(b_spec);
  ASSERT_EQ(a.id, b.id);
  const auto saved_a = saveShot(dir.path(), a);
  ASSERT_TRUE(saved_a.ok()) << saved_a.error().message;
  EXPECT_EQ(*saved_a, a.id);
  const auto saved_b = saveShot(dir.path(), b);
  ASSERT_TRUE(saved_b.ok()) << saved_b.error().message;
  EXPECT_EQ(*saved_b, "20260314-101500-0002");
  const auto read_a = collide::app::readShot(dir.file(a.id + ".h5"));
  ASSERT_TRUE(read_a.ok());
  expectSameShot(a, *read_a);
  const auto read_b = collide::app::readShot(dir.file(*saved_b + ".h5"));
  ASSERT_TRUE(read_b.ok());
  EXPECT_EQ(read_b->id, *saved_b);
  EXPECT_EQ(read_b->rig_name, "second");
  expectEveryShotKept(dir.path(), 2);
}

TEST(SaveShot, TwoProcessesSavingTheSameIdsIntoOneFolderKeepEveryShot) {
  ScratchDir dir;
  constexpr int kWriters = 2, kShots = 12;
  std::vector<pid_t> children;
  for (int w = 0; w < kWriters; ++w) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      int failures = 0;
      for (int i = 0; i < kShots; ++i) {
        ShotSpec spec;  // both writers use the same ids, as two campaigns in one second do
        spec.id = "20260314-101500-" + std::to_string(1000 + i);
        spec.seed = static_cast<unsigned>(100 * w + i);
        if (!saveShot(dir.path(), makeShot(spec)).ok()) ++failures;
      }
      _exit(failures);
    }
    children.push_back(pid);
  }
  for (pid_t pid : children) {
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "a writer failed to save";
  }
  expectEveryShotKept(dir.path(), kWriters * kShots);
}

TEST(SaveShot, DiskFillingUpGivesAClearErrorAndLeavesNoFileNorRow) {
  ScratchDir dir;
  // One shot saved before the disk fills: it must come through untouched.
  const auto earlier = makeShot();
  ASSERT_TRUE(saveShot(dir.path(), earlier).ok());
  const auto before = dir.entries();

  const auto shot = makeShot(bigShot("20260314-101501-0002"));
  const std::string path = dir.file(shot.id + ".h5");
  // The first ~200 kB fit, then writes fail with EFBIG, as on a full disk.
  const std::string message = runWithFileSizeLimit(200 * 1024, [&] {
    const auto s = saveShot(dir.path(), shot);
    return s.ok() ? std::string("saved") : s.error().message;
  });
  EXPECT_THAT(message, AllOf(HasSubstr("file too large"), HasSubstr("writing " + path),
                             HasSubstr("choose another folder")));
  EXPECT_EQ(message.find('\n'), std::string::npos) << "one line: " << message;
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_EQ(dir.entries(), before) << "no temporary file left either";
  EXPECT_EQ(catalogRows(dir.path()), 1u);
  const auto still = collide::app::readShot(dir.file(earlier.id + ".h5"));
  ASSERT_TRUE(still.ok()) << still.error().message;
  expectSameShot(earlier, *still);
}

TEST(SaveShot, DiskFullBeforeAnyCatalogLeavesNothing) {
  ScratchDir dir;
  const auto shot = makeShot(bigShot("20260314-101501-0003"));
  const std::string message = runWithFileSizeLimit(64 * 1024, [&] {
    const auto s = saveShot(dir.path(), shot);
    return s.ok() ? std::string("saved") : s.error().message;
  });
  EXPECT_THAT(message, AllOf(HasSubstr("file too large"), HasSubstr(shot.id + ".h5")));
  EXPECT_TRUE(dir.entries().empty()) << ::testing::PrintToString(dir.entries());
}

TEST(SaveShot, AnIdThatIsNotAFileNameIsRefused) {
  ScratchDir dir;
  auto shot = makeShot();
  shot.id = "../escape";
  const auto s = saveShot(dir.path(), shot);
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("cannot name a file"));
  EXPECT_TRUE(dir.entries().empty());
}

TEST(SaveShot, CatalogFailureAfterTheFileSaysHowToRecover) {
  ScratchDir dir;
  // A folder where the catalog file should be: SQLite cannot open it.
  std::filesystem::create_directory(dir.file("catalog.sqlite"));
  const auto shot = makeShot();
  const auto s = saveShot(dir.path(), shot);
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, AllOf(HasSubstr("saved " + dir.file(shot.id + ".h5")),
                                       HasSubstr("collide catalog rebuild " + dir.path())));
  // The file is complete: rebuilding from it is the way back.
  EXPECT_TRUE(collide::app::readShot(dir.file(shot.id + ".h5")).ok());
}

TEST(SaveResults, UpdatesTheFileAndTheRow) {
  ScratchDir dir;
  ShotSpec spec;
  spec.results = false;
  const auto shot = makeShot(spec);
  ASSERT_TRUE(saveShot(dir.path(), shot).ok());
  const std::string json = R"({"e": 0.91, "gamma_deg": 150.0})";
  const auto s = collide::app::saveResults(dir.path(), shot.id, json);
  ASSERT_TRUE(s.ok()) << s.error().message;
  const auto read = collide::app::readShot(dir.file(shot.id + ".h5"), {.frames = false});
  ASSERT_TRUE(read.ok());
  EXPECT_EQ(read->results_json, json);
  auto rows = Catalog::open(dir.path())->query();
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows->size(), 1u);
  EXPECT_TRUE((*rows)[0].analysed);
  EXPECT_EQ((*rows)[0].results.e, 0.91);
  EXPECT_EQ((*rows)[0].results.gamma_deg, 150.0);
}

TEST(SaveNote, StoresTheNoteInTheFileAndTheRowAndKeepsTheResults) {
  ScratchDir dir;
  ShotSpec spec;
  spec.results = false;
  const auto shot = makeShot(spec);
  ASSERT_TRUE(saveShot(dir.path(), shot).ok());
  const std::string json = R"({"e": 0.91})";
  ASSERT_TRUE(collide::app::saveResults(dir.path(), shot.id, json).ok());
  const std::string note = "sphere 2 chipped after this shot; lamp moved 5 cm \u00b5";
  auto s = collide::app::saveNote(dir.path(), shot.id, note);
  ASSERT_TRUE(s.ok()) << s.error().message;
  auto read = collide::app::readShot(dir.file(shot.id + ".h5"));
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(read->note, note);
  EXPECT_EQ(read->results_json, json) << "the results stay";
  EXPECT_EQ(read->burst.frames.size(), shot.burst.frames.size()) << "the frames stay";
  auto rows = Catalog::open(dir.path())->query();
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows->size(), 1u);
  EXPECT_EQ((*rows)[0].note, note);
  EXPECT_EQ((*rows)[0].results.e, 0.91);
  // New results keep the note; an empty note removes it from both.
  ASSERT_TRUE(collide::app::saveResults(dir.path(), shot.id, R"({"e": 0.5})").ok());
  EXPECT_EQ(collide::app::readShot(dir.file(shot.id + ".h5"), {.frames = false})->note, note);
  ASSERT_TRUE(collide::app::saveNote(dir.path(), shot.id, "").ok());
  EXPECT_EQ(collide::app::readShot(dir.file(shot.id + ".h5"), {.frames = false})->note, "");
  EXPECT_EQ((*Catalog::open(dir.path())->query())[0].note, "");
  // A rebuilt catalog takes the note from the file.
  ASSERT_TRUE(collide::app::saveNote(dir.path(), shot.id, note).ok());
  ASSERT_TRUE(collide::app::rebuildCatalog(dir.path()).ok());
  EXPECT_EQ((*Catalog::open(dir.path())->query())[0].note, note);
}

TEST(SaveNote, UnknownShotIsNamed) {
  ScratchDir dir;
  const auto s = collide::app::saveNote(dir.path(), "20260101-000000-0000", "x");
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("20260101-000000-0000.h5"));
}

TEST(SaveResults, UnknownShotIsNamed) {
  ScratchDir dir;
  const auto s = collide::app::saveResults(dir.path(), "20260101-000000-0000", R"({"e": 1})");
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("20260101-000000-0000.h5"));
}

}  // namespace
