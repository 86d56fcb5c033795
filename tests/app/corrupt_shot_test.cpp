// Shot files damaged in ways that crash libhdf5 itself: folder scans report
// the file and go on (issue 15, item 3). The damage is one byte, the length of
// a string in the file's global heap, which HDF5 1.10 trusts and reads past.
// Since session 19 the reader's file driver (app/store/heap_check_driver.*)
// refuses such a heap before the library parses it; the contained read
// (reader_process_test.cpp) stays for damage nobody has seen yet.
// heap-loop.h5 and heap-overflow.h5 below are files that did loop and crash
// the library before the driver.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/store/catalog.hpp"
#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"
#include "tests/app/cli_run.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace collide::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

// Flips byte `which` (0-7) of the first global-heap object's length (the
// layout: "GCOL", version, 3 reserved, 8-byte collection size, then per object
// a 2-byte index, 2-byte reference count, 4 reserved and an 8-byte size).
void damageGlobalHeap(const std::string& path, int which) {
  std::string bytes = readAll(path);
  const auto at = bytes.find("GCOL");
  ASSERT_NE(at, std::string::npos) << "no global heap in " << path;
  bytes[at + 16 + 8 + which] = static_cast<char>(bytes[at + 16 + 8 + which] ^ 0xff);
  writeAll(path, bytes);
}

class CorruptShot : public ::testing::Test {
 protected:
  void SetUp() override {
    ShotSpec good_spec;
    good_spec.id = "20260314-101500-0001";
    ASSERT_TRUE(app::saveShot(dir.path(), makeShot(good_spec)).ok());
    ShotSpec bad_spec;
    bad_spec.id = "20260314-101500-0002";
    ASSERT_TRUE(app::saveShot(dir.path(), makeShot(bad_spec)).ok());
    bad = dir.file("20260314-101500-0002.h5");
    // The top byte of the first object's length: it then claims more than
    // 2^56 bytes, which libhdf5 1.10 would copy past its buffer (SIGSEGV).
    damageGlobalHeap(bad, 7);
  }
  ScratchDir dir;
  std::string bad;
};

TEST_F(CorruptShot, AReadNamesTheFileAndTheDamageInsteadOfCrashing) {
  for (bool contained : {true, false}) {
    const auto read = app::readShot(bad, {.frames = false, .contained = contained});
    ASSERT_FALSE(read.ok());
    EXPECT_THAT(read.error().message, AllOf(HasSubstr(bad), HasSubstr("corrupt global heap"),
                                            HasSubstr("past the collection's end")))
        << (contained ? "contained" : "not contained");
  }
}

TEST_F(CorruptShot, CatalogRebuildSkipsItAndKeepsTheOthers) {
  auto report = app::rebuildCatalog(dir.path());
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->shots, 1u);
  ASSERT_EQ(report->unreadable.size(), 1u);
  EXPECT_EQ(report->unreadable[0].file, "20260314-101500-0002.h5");
  EXPECT_THAT(report->unreadable[0].message, HasSubstr("corrupt"));
}

TEST_F(CorruptShot, TheCommandsThatScanAFolderReportItAndFinish) {
  auto rebuild = runCollide("catalog rebuild " + q(dir.path()), dir);
  EXPECT_EQ(rebuild.exit_code, 1) << rebuild.err;
  EXPECT_THAT(rebuild.err, HasSubstr("skipped 20260314-101500-0002.h5"));
  EXPECT_THAT(rebuild.out, HasSubstr("1 shot, 1 unreadable file skipped"));
  auto analyze = runCollide("analyze " + q(dir.path()), dir);
  EXPECT_NE(analyze.exit_code, 139) << "analyze crashed";
  EXPECT_THAT(analyze.out + analyze.err, HasSubstr("corrupt global heap"));
  EXPECT_THAT(analyze.out + analyze.err, HasSubstr("20260314-101500-0001"))
      << "the good shot was not reached";
}

}  // namespace
}  // namespace collide::testing

namespace collide::testing {
namespace {

// Found by shot_file_fuzz: a shot file whose damaged global heap (a
// free-space object of size 0) makes libhdf5 1.10 loop for ever in H5HG_read.
// Before session 19 the contained read gave up after its time limit (30 s);
// the driver now refuses the heap at once and says what is wrong.
TEST(CorruptShotHang, AHeapTheLibraryLoopsOnIsRefusedAtOnceAndNamed) {
  ScratchDir dir;
  const std::string path = dir.file("heap-loop.h5");
  writeAll(path, readAll(std::string(COLLIDE_TEST_DATA_DIR) + "/corrupt/heap-loop.h5"));
  for (bool contained : {true, false}) {
    const auto read = app::readShot(path, {.frames = false, .contained = contained});
    ASSERT_FALSE(read.ok());
    EXPECT_THAT(read.error().message,
                AllOf(HasSubstr(path), HasSubstr("corrupt global heap"), HasSubstr("has size 0")));
    EXPECT_THAT(read.error().message, Not(HasSubstr("did not finish")));
  }
}

// Found by shot_file_fuzz: a vlen string attribute whose global-heap object
// claims more bytes than its collection holds; libhdf5 1.10 copies past its
// buffer in H5HG_read (SIGSEGV, or a non-zero exit under AddressSanitizer,
// and silently in some layouts). The driver refuses the heap first.
TEST(CorruptShotHeapOverflow, AnObjectPastItsCollectionIsRefusedBeforeTheLibraryReadsIt) {
  ScratchDir dir;
  const std::string path = dir.file("heap-overflow.h5");
  writeAll(path, readAll(std::string(COLLIDE_TEST_DATA_DIR) + "/corrupt/heap-overflow.h5"));
  for (bool contained : {true, false}) {
    const auto read = app::readShot(path, {.frames = false, .contained = contained});
    ASSERT_FALSE(read.ok());
    EXPECT_THAT(read.error().message,
                AllOf(HasSubstr(path), HasSubstr("corrupt global heap"),
                      HasSubstr("object 2 at byte 1136 declares 26475 bytes")));
  }
}

}  // namespace
}  // namespace collide::testing
