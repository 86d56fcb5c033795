#include "app/atomic_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cerrno>
#include <filesystem>

#include "tests/app/shot_fixtures.hpp"

namespace {

using collide::app::AtomicFile;
using collide::app::ioError;
using namespace collide::testing;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::StartsWith;

TEST(IoError, NamesTheCauseThePathAndTheRemedy) {
  EXPECT_EQ(ioError(ENOSPC, "writing", "shots/x.h5").message,
            "no space left on device writing shots/x.h5: free space or choose another folder "
            "(--out)");
  EXPECT_THAT(ioError(EFBIG, "writing", "shots/x.h5").message,
              AllOf(StartsWith("file too large"), HasSubstr("shots/x.h5"), HasSubstr("ulimit")));
  EXPECT_THAT(ioError(EACCES, "creating", "shots/x.h5").message,
              AllOf(StartsWith("permission denied creating shots/x.h5"), HasSubstr("permissions")));
  // Anything else still names the action and the path.
  EXPECT_THAT(ioError(ENOTDIR, "reading", "a/b").message, HasSubstr("reading a/b"));
}

TEST(AtomicFile, NothingAppearsUntilCommitAndTheTemporaryFileGoesAway) {
  ScratchDir dir;
  const std::string path = dir.file("shot.h5");
  {
    auto file = AtomicFile::create(path);
    ASSERT_TRUE(file.ok()) << file.error().message;
    EXPECT_THAT(std::filesystem::path(file->tempPath()).filename().string(),
                StartsWith(".shot.h5.tmp-"));
    writeAll(file->tempPath(), "half a shot");
    EXPECT_FALSE(std::filesystem::exists(path));
  }  // abandoned: removed
  EXPECT_TRUE(dir.entries().empty());

  auto file = AtomicFile::create(path);
  ASSERT_TRUE(file.ok());
  writeAll(file->tempPath(), "a whole shot");
  const auto committed = file->commit();
  ASSERT_TRUE(committed.ok()) << committed.error().message;
  EXPECT_EQ(readAll(path), "a whole shot");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"shot.h5"});
}

TEST(AtomicFile, FilesGetTheUsersUmaskNotMkstemps0600) {
  ScratchDir dir;
  const mode_t old_mask = umask(022);
  auto file = AtomicFile::create(dir.file("s.h5"));
  umask(old_mask);
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE(file->commit().ok());
  struct stat st {};
  ASSERT_EQ(stat(dir.file("s.h5").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0644u);
}

TEST(AtomicFile, CopyStartsFromTheSourceBytes) {
  ScratchDir dir;
  std::string bytes(3 << 20, '\0');  // larger than one read/write block
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>(i * 31 % 251);
  writeAll(dir.file("s.h5"), bytes);
  auto copy = AtomicFile::createCopyOf(dir.file("s.h5"), dir.file("s.h5"));
  ASSERT_TRUE(copy.ok()) << copy.error().message;
  EXPECT_EQ(readAll(copy->tempPath()), bytes);
}

TEST(AtomicFile, MissingFolderIsNamed) {
  ScratchDir dir;
  auto file = AtomicFile::create(dir.file("nope/s.h5"));
  ASSERT_FALSE(file.ok());
  EXPECT_THAT(file.error().message,
              AllOf(StartsWith("no such file or folder"), HasSubstr(dir.file("nope/s.h5"))));
}

}  // namespace
