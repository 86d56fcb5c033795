#include "app/manifest.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "app/store/save.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

using namespace collide::app;
using collide::testing::ScratchDir;
using ::testing::HasSubstr;

std::string writeList(const ScratchDir& dir, const std::string& text) {
  const std::string path = dir.file("shots.list");
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

TEST(Manifest, ReadsPathsSkippingCommentsAndBlankLinesAndKeepsLineNumbers) {
  ScratchDir dir;
  const auto list = writeList(dir, "# campaign\n/data/a.h5\n\n  /data/b.h5  \r\nsub/c.h5\n");
  auto m = readManifest(list);
  ASSERT_TRUE(m.ok()) << m.error().message;
  ASSERT_EQ(m->size(), 3u);
  EXPECT_EQ((*m)[0].path, "/data/a.h5");
  EXPECT_EQ((*m)[0].line, 2);
  EXPECT_EQ((*m)[1].path, "/data/b.h5");
  EXPECT_EQ((*m)[1].line, 4);
  // Relative to the manifest's folder, not to where the task runs.
  EXPECT_EQ((*m)[2].path, (std::filesystem::path(dir.path()) / "sub/c.h5").string());
  EXPECT_EQ((*m)[2].line, 5);
}

TEST(Manifest, RefusesAMissingEmptyOrBinaryManifestNamingIt) {
  ScratchDir dir;
  auto missing = readManifest(dir.file("nope.list"));
  ASSERT_FALSE(missing.ok());
  EXPECT_THAT(missing.error().message, HasSubstr("nope.list"));
  auto empty = readManifest(writeList(dir, "# nothing\n\n"));
  ASSERT_FALSE(empty.ok());
  EXPECT_THAT(empty.error().message, HasSubstr("lists no shot files"));
  auto binary = readManifest(writeList(dir, "/a.h5\nHDF\x01\x02\n"));
  ASSERT_FALSE(binary.ok());
  EXPECT_THAT(binary.error().message, HasSubstr("shots.list:2"));
  auto folder = readManifest(dir.path());
  ASSERT_FALSE(folder.ok());
  EXPECT_THAT(folder.error().message, HasSubstr("collide manifest"));
}

TEST(Manifest, ChunksCoverEveryShotOnceAndTheLastMayBeShort) {
  std::vector<ManifestEntry> entries;
  for (int i = 0; i < 23; ++i) entries.push_back({"/s/" + std::to_string(i) + ".h5", i + 1});
  EXPECT_EQ(tasksFor(23, 10), 3);
  EXPECT_EQ(tasksFor(20, 10), 2);
  std::vector<std::string> seen;
  for (long i = 0; i < 3; ++i) {
    auto c = manifestChunk(entries, "L", i, 10);
    ASSERT_TRUE(c.ok()) << c.error().message;
    EXPECT_EQ(c->size(), i < 2 ? 10u : 3u);
    for (const auto& e : *c) seen.push_back(e.path);
  }
  ASSERT_EQ(seen.size(), entries.size());
  for (std::size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], entries[i].path);
}

TEST(Manifest, AnIndexPastTheEndSaysHowManyTasksTheManifestMakes) {
  std::vector<ManifestEntry> entries(100, {"/s/x.h5", 1});
  auto past = manifestChunk(entries, "campaign.list", 10, 10);
  ASSERT_FALSE(past.ok());
  EXPECT_THAT(past.error().message, HasSubstr("campaign.list"));
  EXPECT_THAT(past.error().message, HasSubstr("--array=0-9"));
  EXPECT_FALSE(manifestChunk(entries, "L", -1, 10).ok());
  auto zero = manifestChunk(entries, "L", 0, 0);
  ASSERT_FALSE(zero.ok());
  EXPECT_THAT(zero.error().message, HasSubstr("--chunk"));
}

TEST(Manifest, ListsTheShotFilesOfSeveralFoldersAsAbsolutePaths) {
  ScratchDir dir;
  for (const char* sub : {"a", "b"}) {
    collide::testing::ShotSpec spec;
    spec.id = std::string("20260314-10150") + (sub[0] == 'a' ? "0" : "1") + "-0001";
    ASSERT_TRUE(saveShot(dir.file(sub), collide::testing::makeShot(spec)).ok());
  }
  auto files = listShotFiles({dir.file("a"), dir.file("b")});
  ASSERT_TRUE(files.ok()) << files.error().message;
  ASSERT_EQ(files->size(), 2u);
  EXPECT_EQ((*files)[0], dir.file("a") + "/20260314-101500-0001.h5");
  EXPECT_EQ((*files)[1], dir.file("b") + "/20260314-101501-0001.h5");
  EXPECT_TRUE(std::filesystem::path((*files)[0]).is_absolute());
  auto missing = listShotFiles({dir.file("c")});
  ASSERT_FALSE(missing.ok());
  EXPECT_THAT(missing.error().message, HasSubstr(dir.file("c")));
}

}  // namespace
