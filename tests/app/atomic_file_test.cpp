#include "app/store/atomic_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <thread>

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

namespace {

using collide::app::writeTextFile;

TEST(AtomicFile, CommitIfAbsentNeverReplacesAnExistingFile) {
  ScratchDir dir;
  const std::string path = dir.file("shot.h5");
  { std::ofstream(path) << "first"; }
  {
    auto file = AtomicFile::create(path);
    ASSERT_TRUE(file.ok());
    { std::ofstream(file->tempPath()) << "second"; }
    auto outcome = file->commitIfAbsent();
    ASSERT_TRUE(outcome.ok()) << outcome.error().message;
    EXPECT_EQ(*outcome, AtomicFile::Outcome::NameTaken);
    EXPECT_EQ(readAll(path), "first");
  }
  auto other = AtomicFile::create(dir.file("other.h5"));
  ASSERT_TRUE(other.ok());
  auto outcome = other->commitIfAbsent();
  ASSERT_TRUE(outcome.ok());
  EXPECT_EQ(*outcome, AtomicFile::Outcome::Committed);
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"other.h5", "shot.h5"}))
      << "the refused temporary file is gone";
}

TEST(WriteTextFile, NewAndRegularFilesAreWrittenWhole) {
  ScratchDir dir;
  const std::string path = dir.file("out.json");
  ASSERT_TRUE(writeTextFile(path, "one\n").ok());
  EXPECT_EQ(readAll(path), "one\n");
  ASSERT_TRUE(writeTextFile(path, "two\n").ok());
  EXPECT_EQ(readAll(path), "two\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.json"});
}

TEST(WriteTextFile, ASymlinkStaysALinkAndItsTargetIsWritten) {
  ScratchDir dir;
  const std::string target = dir.file("real.json");
  const std::string link = dir.file("link.json");
  { std::ofstream(target) << "old"; }
  std::filesystem::create_symlink("real.json", link);  // relative, as users make them
  ASSERT_TRUE(writeTextFile(link, "new\n").ok());
  EXPECT_TRUE(std::filesystem::is_symlink(link));
  EXPECT_EQ(readAll(target), "new\n");
  // A dangling link gets its target created, as a shell's `>` does.
  const std::string dangling = dir.file("dangling.json");
  std::filesystem::create_symlink("made.json", dangling);
  ASSERT_TRUE(writeTextFile(dangling, "x\n").ok());
  EXPECT_TRUE(std::filesystem::is_symlink(dangling));
  EXPECT_EQ(readAll(dir.file("made.json")), "x\n");
}

TEST(WriteTextFile, DevicesAndFifosAreWrittenThroughNotReplaced) {
  ScratchDir dir;
  // /dev/null takes the text and stays a device.
  ASSERT_TRUE(writeTextFile("/dev/null", "text\n").ok());
  struct stat st {};
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  // /dev/full reports a full disk, named.
  const auto full = writeTextFile("/dev/full", "text\n");
  ASSERT_FALSE(full.ok());
  EXPECT_THAT(full.error().message, AllOf(HasSubstr("no space left"), HasSubstr("/dev/full")));
  ASSERT_EQ(::stat("/dev/full", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode)) << "/dev/full was replaced by a file";
  // A FIFO is written through to its reader.
  const std::string fifo = dir.file("pipe");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  std::thread reader([&] { received = readAll(fifo); });
  const auto written = writeTextFile(fifo, "through the pipe\n");
  reader.join();
  ASSERT_TRUE(written.ok()) << written.error().message;
  EXPECT_EQ(received, "through the pipe\n");
  ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
}

TEST(WriteTextFile, AFolderIsRefusedWithAFileNameToUse) {
  ScratchDir dir;
  const auto s = writeTextFile(dir.path(), "x");
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message,
              AllOf(HasSubstr(dir.path() + " is a folder"), HasSubstr("give a file name")));
}

}  // namespace
