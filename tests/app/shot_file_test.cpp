#include "app/store/shot_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <tuple>

#include "tests/app/shot_fixtures.hpp"

namespace {

using collide::app::readShot;
using collide::app::storeResults;
using collide::app::WriteOutcome;
using collide::app::writeShot;
using collide::app::writeShotIfAbsent;
using collide::vision::PixelFormat;
using namespace collide::testing;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

// ------------------------------------------------------------ round trip

struct RoundTripCase {
  PixelFormat format;
  bool compress;
  bool truth_and_results;
};

class ShotFileRoundTrip : public ::testing::TestWithParam<std::tuple<PixelFormat, bool, bool>> {};

TEST_P(ShotFileRoundTrip, EveryFieldAndEveryPixelSurvives) {
  const auto [format, compress, extras] = GetParam();
  ScratchDir dir;
  ShotSpec spec;
  spec.format = format;
  spec.truth = extras;
  spec.results = extras;
  const collide::hw::Shot shot = makeShot(spec);
  const std::string path = dir.file(shot.id + ".h5");

  const auto written = writeShot(path, shot, {.compress = compress});
  ASSERT_TRUE(written.ok()) << written.error().message;
  const auto read = readShot(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameShot(shot, *read);
  // Only the file itself: the temporary name is gone.
  EXPECT_EQ(dir.entries(), std::vector<std::string>{shot.id + ".h5"});
}

INSTANTIATE_TEST_SUITE_P(FormatsCompressionExtras, ShotFileRoundTrip,
                         ::testing::Combine(::testing::Values(PixelFormat::Mono8,
                                                              PixelFormat::Mono12,
                                                              PixelFormat::Mono16),
                                            ::testing::Bool(), ::testing::Bool()),
                         [](const auto& info) {
                           return std::string(collide::vision::toString(std::get<0>(info.param))) +
                                  (std::get<1>(info.param) ? "_Deflate" : "_Raw") +
                                  (std::get<2>(info.param) ? "_TruthResults" : "_Plain");
                         });

TEST(ShotFile, ReadingWithoutFramesKeepsEverythingElse) {
  ScratchDir dir;
  const auto shot = makeShot();
  const std::string path = dir.file("s.h5");
  ASSERT_TRUE(writeShot(path, shot).ok());
  const auto read = readShot(path, {.frames = false});
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameShot(shot, *read, /*images=*/false);
}

TEST(ShotFile, FailedShotWithoutFramesRoundTrips) {
  ScratchDir dir;
  ShotSpec spec;
  spec.frames = 0;
  spec.truth = false;
  spec.results = false;
  spec.status = collide::hw::ShotStatus::Failed;
  const auto shot = makeShot(spec);
  ASSERT_FALSE(shot.failure_reason.empty());
  const std::string path = dir.file("failed.h5");
  const auto written = writeShot(path, shot);
  ASSERT_TRUE(written.ok()) << written.error().message;
  const auto read = readShot(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameShot(shot, *read);
}

TEST(ShotFile, CompressionShrinksCompressibleFrames) {
  ScratchDir dir;
  ShotSpec spec;
  spec.width = 320;
  spec.height = 240;
  spec.smooth_images = true;
  const auto shot = makeShot(spec);
  ASSERT_TRUE(writeShot(dir.file("raw.h5"), shot, {.compress = false}).ok());
  ASSERT_TRUE(writeShot(dir.file("zip.h5"), shot, {.compress = true}).ok());
  const auto raw = std::filesystem::file_size(dir.file("raw.h5"));
  const auto zip = std::filesystem::file_size(dir.file("zip.h5"));
  // Five stored frames of 76.8 kB of ramps: raw is at least their size, deflate
  // packs a ramp to a small fraction of it.
  EXPECT_GE(raw, 5u * 320u * 240u);
  EXPECT_LT(zip * 4, raw);
}

TEST(ShotFile, WritingNeverReplacesAnEarlierFileOfTheSameName) {
  ScratchDir dir;
  const std::string path = dir.file("s.h5");
  ShotSpec first;
  first.rig_name = "first";
  const auto original = makeShot(first);
  ASSERT_TRUE(writeShot(path, original).ok());
  ShotSpec second;
  second.rig_name = "second";
  second.seed = 99;
  const auto written = writeShot(path, makeShot(second));
  ASSERT_FALSE(written.ok());
  EXPECT_THAT(written.error().message,
              AllOf(HasSubstr(path + " already exists"), HasSubstr("never replaced")));
  const auto read = readShot(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameShot(original, *read);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"s.h5"}) << "no temporary file left";
}

TEST(ShotFile, WriteIfAbsentReportsATakenNameAndWritesNothing) {
  ScratchDir dir;
  const std::string path = dir.file("s.h5");
  const auto original = makeShot();
  auto first = writeShotIfAbsent(path, original);
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_EQ(*first, WriteOutcome::Written);
  ShotSpec other;
  other.seed = 3;
  auto second = writeShotIfAbsent(path, makeShot(other));
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_EQ(*second, WriteOutcome::NameTaken);
  const auto read = readShot(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameShot(original, *read);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"s.h5"});
}

// ------------------------------------------------------------ read errors

TEST(ShotFileErrors, MissingFileIsNamed) {
  ScratchDir dir;
  const std::string path = dir.file("nope.h5");
  const auto read = readShot(path);
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message, AllOf(HasSubstr("no such shot file"), HasSubstr(path)));
}

TEST(ShotFileErrors, NonHdf5FileIsNamed) {
  ScratchDir dir;
  const std::string path = dir.file("notes.h5");
  writeAll(path, "these are lab notes, not a shot\n");
  const auto read = readShot(path);
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message, AllOf(HasSubstr("not an HDF5 file"), HasSubstr(path)));
}

TEST(ShotFileErrors, FolderIsNotAShot) {
  ScratchDir dir;
  const auto read = readShot(dir.path());
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message, AllOf(HasSubstr("is a folder"), HasSubstr(dir.path())));
}

TEST(ShotFileErrors, TruncatedFileIsReportedAsCorrupt) {
  ScratchDir dir;
  const std::string path = dir.file("cut.h5");
  ASSERT_TRUE(writeShot(path, makeShot()).ok());
  const std::string bytes = readAll(path);
  writeAll(path, bytes.substr(0, bytes.size() / 2));
  ::testing::internal::CaptureStderr();
  const auto read = readShot(path);
  const std::string printed = ::testing::internal::GetCapturedStderr();
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message, AllOf(HasSubstr(path), HasSubstr("truncated or corrupt")));
  EXPECT_EQ(read.error().message.find('\n'), std::string::npos) << "one line";
  // HDF5's own error stack printing is silenced: the message is the report.
  EXPECT_EQ(printed, "");
}

/// Renames the first occurrence of `name` in the file's bytes to `renamed` (same
/// length): HDF5 keeps link names and string attribute values as plain bytes,
/// so this makes a file that lacks `name` without needing the HDF5 library.
void patchBytes(const std::string& path, const std::string& name, const std::string& renamed) {
  ASSERT_EQ(name.size(), renamed.size());
  std::string bytes = readAll(path);
  const auto at = bytes.find(name);
  ASSERT_NE(at, std::string::npos) << name << " not found in " << path;
  ASSERT_EQ(bytes.find(name, at + 1), std::string::npos) << name << " occurs twice";
  bytes.replace(at, name.size(), renamed);
  writeAll(path, bytes);
}

// One byte changed inside a group's header (a dataset's name): the 1.10
// format's header checksum catches it, and the message says the file is
// corrupt, not that something is missing. (A dataset really missing is named:
// h5py_test, which can delete one without our code.)
TEST(ShotFileErrors, AByteChangedInAHeaderIsReportedAsCorrupt) {
  ScratchDir dir;
  const std::string path = dir.file("damaged.h5");
  ASSERT_TRUE(writeShot(path, makeShot()).ok());
  patchBytes(path, "timestamp_ns", "timestamp_nX");
  const auto read = readShot(path, {.frames = false});
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message, AllOf(HasSubstr(path), HasSubstr("corrupt")));
  EXPECT_THAT(read.error().message, Not(HasSubstr("lacks")));
}

TEST(ShotFileErrors, OtherHdf5FileIsNotAShot) {
  ScratchDir dir;
  const std::string path = dir.file("other.h5");
  ASSERT_TRUE(writeShot(path, makeShot()).ok());
  patchBytes(path, "collide-shot", "someone-else");
  const auto read = readShot(path);
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message, AllOf(HasSubstr(path), HasSubstr("not a collide shot file")));
}

// ------------------------------------------------------------ write errors

TEST(ShotFileErrors, FramesOfDifferentSizesLeaveNoFile) {
  ScratchDir dir;
  auto shot = makeShot();
  shot.burst.frames[4].image = cv::Mat(10, 10, CV_8UC1, cv::Scalar(0));
  const std::string path = dir.file("bad.h5");
  const auto written = writeShot(path, shot);
  ASSERT_FALSE(written.ok());
  EXPECT_THAT(written.error().message,
              AllOf(HasSubstr(path), HasSubstr("frame 4 is 10x10"), HasSubstr("one size")));
  EXPECT_TRUE(dir.entries().empty());
}

TEST(ShotFileErrors, FrameTypeMustMatchPixelFormat) {
  ScratchDir dir;
  auto shot = makeShot();
  shot.burst.format = PixelFormat::Mono16;  // frames are 8-bit
  const auto written = writeShot(dir.file("bad.h5"), shot);
  ASSERT_FALSE(written.ok());
  EXPECT_THAT(written.error().message, HasSubstr("Mono16"));
  EXPECT_TRUE(dir.entries().empty());
}

TEST(ShotFileErrors, MissingFolderIsNamed) {
  ScratchDir dir;
  const std::string path = dir.file("no/such/folder/s.h5");
  const auto written = writeShot(path, makeShot());
  ASSERT_FALSE(written.ok());
  EXPECT_THAT(written.error().message, AllOf(HasSubstr("no such file or folder"), HasSubstr(path)));
}

TEST(ShotFileErrors, DiskFullMidWriteLeavesNoHalfFile) {
  ScratchDir dir;
  ShotSpec spec;
  spec.width = 200;
  spec.height = 150;
  spec.frames = 12;  // ~300 kB of frames against a 100 kB limit
  const auto shot = makeShot(spec);
  const std::string path = dir.file("big.h5");
  const std::string message = runWithFileSizeLimit(100 * 1024, [&] {
    const auto written = writeShot(path, shot);
    return written.ok() ? std::string("written") : written.error().message;
  });
  EXPECT_THAT(message, AllOf(HasSubstr("file too large"), HasSubstr("writing " + path)));
  EXPECT_TRUE(dir.entries().empty()) << "left behind: " << ::testing::PrintToString(dir.entries());
}

TEST(ShotFileErrors, InvalidResultsJsonIsRefusedBeforeWriting) {
  ScratchDir dir;
  auto shot = makeShot();
  shot.results_json = "{\"e\": ";
  const auto written = writeShot(dir.file("s.h5"), shot);
  ASSERT_FALSE(written.ok());
  EXPECT_THAT(written.error().message, HasSubstr("not valid JSON"));
  EXPECT_TRUE(dir.entries().empty());
}

// ------------------------------------------------------------ storeResults

TEST(StoreResults, AddsReplacesAndRemovesResultsKeepingTheRecording) {
  ScratchDir dir;
  ShotSpec spec;
  spec.results = false;
  spec.format = PixelFormat::Mono16;
  auto shot = makeShot(spec);
  const std::string path = dir.file("s.h5");
  ASSERT_TRUE(writeShot(path, shot, {.compress = true}).ok());

  shot.results_json = collide::testing::sampleResultsJson();
  auto stored = storeResults(path, shot.results_json);
  ASSERT_TRUE(stored.ok()) << stored.error().message;
  auto read = readShot(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameShot(shot, *read);

  shot.results_json = R"({"e": 0.5, "quality_flags": []})";
  ASSERT_TRUE(storeResults(path, shot.results_json).ok());
  read = readShot(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameShot(shot, *read);

  shot.results_json.clear();
  ASSERT_TRUE(storeResults(path, "").ok());
  read = readShot(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameShot(shot, *read);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"s.h5"});
}

TEST(StoreResults, RefusesBadJsonAndLeavesTheFileAlone) {
  ScratchDir dir;
  const auto shot = makeShot();
  const std::string path = dir.file("s.h5");
  ASSERT_TRUE(writeShot(path, shot).ok());
  const std::string before = readAll(path);
  const auto stored = storeResults(path, R"({"e": "high"})");
  ASSERT_FALSE(stored.ok());
  EXPECT_THAT(stored.error().message, AllOf(HasSubstr(path), HasSubstr("\"e\"")));
  EXPECT_EQ(readAll(path), before);
}

TEST(StoreResults, RefusesFilesThatAreNotShots) {
  ScratchDir dir;
  const std::string path = dir.file("notes.h5");
  writeAll(path, "not hdf5");
  const auto stored = storeResults(path, "{}");
  ASSERT_FALSE(stored.ok());
  EXPECT_THAT(stored.error().message, AllOf(HasSubstr(path), HasSubstr("not an HDF5 file")));
  EXPECT_EQ(readAll(path), "not hdf5");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"notes.h5"});
}

TEST(StoreResults, DiskFullDuringTheCopyKeepsTheOriginal) {
  ScratchDir dir;
  ShotSpec spec;
  spec.width = 200;
  spec.height = 150;
  spec.frames = 12;
  const auto shot = makeShot(spec);
  const std::string path = dir.file("s.h5");
  ASSERT_TRUE(writeShot(path, shot).ok());
  const std::string before = readAll(path);
  const std::string message = runWithFileSizeLimit(100 * 1024, [&] {
    const auto stored = storeResults(path, R"({"e": 0.9})");
    return stored.ok() ? std::string("stored") : stored.error().message;
  });
  EXPECT_THAT(message, AllOf(HasSubstr("file too large"), HasSubstr(path)));
  EXPECT_EQ(readAll(path), before);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"s.h5"});
}

}  // namespace
