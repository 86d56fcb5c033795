// The storage subcommands (shots, export, catalog rebuild) through the built
// `collide` program, as a user runs them.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "app/store/save.hpp"
#include "tests/app/cli_run.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

using namespace collide::testing;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

std::size_t lineCount(const std::string& s) {
  return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n'));
}

class CliStorage : public ::testing::Test {
 protected:
  void SetUp() override {
    ShotSpec nylon;  // analysed (results)
    ShotSpec teflon;
    teflon.id = "20260314-101600-0002";
    teflon.wall_time_unix_ns += 60'000'000'000LL;
    teflon.material = "teflon";
    teflon.results = false;
    ShotSpec failed;
    failed.id = "20260314-101700-0003";
    failed.wall_time_unix_ns += 120'000'000'000LL;
    failed.status = collide::hw::ShotStatus::Failed;
    failed.results = false;
    for (const auto& spec : {nylon, teflon, failed}) {
      shots.push_back(makeShot(spec));
      const auto s = collide::app::saveShot(folder(), shots.back());
      ASSERT_TRUE(s.ok()) << s.error().message;
    }
  }
  std::string folder() const { return scratch.file("shots"); }

  ScratchDir scratch;
  std::vector<collide::hw::Shot> shots;
};

TEST_F(CliStorage, ShotsListsTheCatalogAsATable) {
  const CommandRun run = runCollide("shots " + q(folder()), scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.out, AllOf(HasSubstr(shots[0].id), HasSubstr(shots[1].id), HasSubstr(shots[2].id),
                             HasSubstr("3 shots")));
  // Header + 3 rows + count line.
  EXPECT_EQ(lineCount(run.out), 5u);
  // The analysed shot shows e = 0.93 and its flags; the failed one its reason.
  EXPECT_THAT(run.out, AllOf(HasSubstr("0.930"), HasSubstr("grazing,few_frames"),
                             HasSubstr(shots[2].failure_reason)));
}

// An emptied catalog (0 bytes) would show "0 shots" for a full folder: the
// listing says the catalog and the files disagree and how to fix it; rebuild
// names a temporary file left by an unfinished write.
TEST_F(CliStorage, AnEmptiedCatalogIsCalledOutAndRebuildNamesLeftovers) {
  for (const char* suffix : {"", "-wal", "-shm"})
    std::filesystem::remove(folder() + "/catalog.sqlite" + suffix);
  writeAll(folder() + "/catalog.sqlite", "");
  writeAll(folder() + "/.20260314-101800-0004.h5.tmp-abc123", "half a shot");
  CommandRun run = runCollide("shots " + q(folder()), scratch);
  EXPECT_THAT(run.err,
              AllOf(HasSubstr("the catalog lists 0 shots but " + folder() + " holds 3 shot files"),
                    HasSubstr("collide catalog rebuild")))
      << run.out;
  run = runCollide("catalog rebuild " + q(folder()), scratch);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.err, HasSubstr(".20260314-101800-0004.h5.tmp-abc123 is a temporary file of a "
                                 "write that never finished"));
  run = runCollide("shots " + q(folder()), scratch);
  EXPECT_THAT(run.out, HasSubstr("3 shots"));
  EXPECT_EQ(run.err, "") << "catalog and files agree again";
}

TEST_F(CliStorage, ShotsFiltersByMaterialAndStatus) {
  CommandRun run = runCollide("shots " + q(folder()) + " --material teflon", scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.out, AllOf(HasSubstr(shots[1].id), Not(HasSubstr(shots[0].id)),
                             Not(HasSubstr(shots[2].id)), HasSubstr("1 shot\n")));
  run = runCollide("shots " + q(folder()) + " --status failed", scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.out, AllOf(HasSubstr(shots[2].id), Not(HasSubstr(shots[0].id)),
                             Not(HasSubstr(shots[1].id))));
}

TEST_F(CliStorage, ShotsAsJsonCarriesEveryColumn) {
  const CommandRun run = runCollide("shots " + q(folder()) + " --json --status ok", scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  ASSERT_EQ(j.size(), 2u);
  EXPECT_EQ(j[0]["id"], shots[0].id);
  EXPECT_EQ(j[0]["file"], shots[0].id + ".h5");
  EXPECT_EQ(j[0]["material"], "nylon-6/6");
  EXPECT_EQ(j[0]["status"], "ok");
  EXPECT_EQ(j[0]["analysed"], true);
  EXPECT_EQ(j[0]["e"], 0.93);
  EXPECT_EQ(j[0]["gamma_deg"], 135.5);
  EXPECT_EQ(j[0]["commanded_kPa"][1], shots[0].launchers[1].commanded_kPa);
  EXPECT_EQ(j[0]["readback_kPa"][0], shots[0].launchers[0].readback_kPa);
  EXPECT_EQ(j[0]["wanted_speed_m_s"][0], 2.5);
  EXPECT_TRUE(j[0]["wanted_speed_m_s"][1].is_null());
  EXPECT_EQ(j[0]["frames"], 6);
  EXPECT_EQ(j[0]["wall_time_utc"], "2026-03-14T10:15:00Z");
  EXPECT_EQ(j[1]["analysed"], false);
  EXPECT_TRUE(j[1]["e"].is_null());
}

TEST_F(CliStorage, ShotsErrorsAreOneLineAndExit2) {
  CommandRun run = runCollide("shots " + q(scratch.file("elsewhere")), scratch);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr(scratch.file("elsewhere")));
  EXPECT_EQ(lineCount(run.err), 1u) << run.err;
  std::filesystem::create_directory(scratch.file("empty"));
  run = runCollide("shots " + q(scratch.file("empty")), scratch);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("collide catalog rebuild " + scratch.file("empty")));
  EXPECT_EQ(lineCount(run.err), 1u) << run.err;
  run = runCollide("shots " + q(folder()) + " --status maybe", scratch);
  EXPECT_EQ(run.exit_code, 2);
}

class CliExport : public ::testing::TestWithParam<collide::vision::PixelFormat> {};

TEST_P(CliExport, WritesOnePngPerFrameWithTheFramesPixels) {
  ScratchDir scratch;
  ShotSpec spec;
  spec.format = GetParam();
  const auto shot = makeShot(spec);
  const std::string path = scratch.file(shot.id + ".h5");
  ASSERT_TRUE(collide::app::writeShot(path, shot).ok());
  const std::string png = scratch.file("png");
  const CommandRun run = runCollide("export " + q(path) + " --png " + q(png), scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // Frame 1 failed in transport and has no image: 5 of 6 frames.
  EXPECT_THAT(run.out,
              AllOf(HasSubstr("wrote 5 PNG files"), HasSubstr("skipped 1 without image data")));
  std::size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(png))
    files += e.path().extension() == ".png";
  EXPECT_EQ(files, 5u);

  // Mono12 is scaled by 16 for viewing; the others are stored as they are.
  const double scale = GetParam() == collide::vision::PixelFormat::Mono12 ? 16.0 : 1.0;
  for (int i : {0, 3}) {
    const auto& frame = shot.burst.frames[i];
    char name[64];
    std::snprintf(name, sizeof name, "frame_%04d_id%lld.png", i, static_cast<long long>(frame.id));
    const cv::Mat read = cv::imread(png + "/" + name, cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(read.empty()) << name;
    cv::Mat expected;
    frame.image.convertTo(
        expected, GetParam() == collide::vision::PixelFormat::Mono8 ? CV_8U : CV_16U, scale);
    expectSameImage(expected, read, name);
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, CliExport,
                         ::testing::Values(collide::vision::PixelFormat::Mono8,
                                           collide::vision::PixelFormat::Mono12,
                                           collide::vision::PixelFormat::Mono16),
                         [](const auto& info) { return collide::vision::toString(info.param); });

TEST(CliExportErrors, BadShotFilesAreNamedAndExit2) {
  ScratchDir scratch;
  CommandRun run = runCollide(
      "export " + q(scratch.file("none.h5")) + " --png " + q(scratch.file("png")), scratch);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("no such shot file: " + scratch.file("none.h5")));
  EXPECT_EQ(lineCount(run.err), 1u) << run.err;
  writeAll(scratch.file("text.h5"), "hello");
  run = runCollide("export " + q(scratch.file("text.h5")) + " --png " + q(scratch.file("png")),
                   scratch);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, AllOf(HasSubstr(scratch.file("text.h5")), HasSubstr("not an HDF5 file")));
  EXPECT_EQ(lineCount(run.err), 1u) << run.err;
  EXPECT_FALSE(std::filesystem::exists(scratch.file("png")));
}

TEST_F(CliStorage, CatalogRebuildRecreatesTheCatalogFromTheFiles) {
  for (const char* suffix : {"", "-wal", "-shm"})
    std::filesystem::remove(folder() + "/catalog.sqlite" + suffix);
  CommandRun run = runCollide("catalog rebuild " + q(folder()), scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.out, HasSubstr("3 shots"));
  EXPECT_EQ(run.err, "");
  run = runCollide("shots " + q(folder()) + " --json", scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  ASSERT_EQ(j.size(), 3u);
  EXPECT_EQ(j[0]["id"], shots[0].id);
  EXPECT_EQ(j[0]["e"], 0.93);
}

TEST_F(CliStorage, CatalogRebuildReportsUnreadableFilesAndExits1) {
  writeAll(folder() + "/junk.h5", "not a shot");
  const CommandRun run = runCollide("catalog rebuild " + q(folder()), scratch);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.out, AllOf(HasSubstr("3 shots"), HasSubstr("1 unreadable file")));
  EXPECT_THAT(run.err, AllOf(HasSubstr("skipped junk.h5"), HasSubstr("not an HDF5 file")));
  EXPECT_EQ(lineCount(run.err), 1u) << run.err;
}

TEST(CliCatalogErrors, MissingFolderExits2) {
  ScratchDir scratch;
  const CommandRun run = runCollide("catalog rebuild " + q(scratch.file("gone")), scratch);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr(scratch.file("gone")));
  EXPECT_EQ(lineCount(run.err), 1u) << run.err;
}

}  // namespace
