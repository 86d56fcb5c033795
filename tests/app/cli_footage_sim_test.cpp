// `collide info` and `collide analyze --frames` on high-speed camera files,
// through the built program as a user runs them: a simulated shot is written
// as a Phantom CINE and as a Photron MRAW + .cihx (test-only writers), and
// the analysis of each is checked against the simulation's ground truth.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "app/report/results_json.hpp"
#include "app/store/shot_file.hpp"
#include "tests/app/cli_run.hpp"
#include "tests/app/shot_fixtures.hpp"
#include "tests/vision/footage_writers.hpp"

namespace {

namespace fs = std::filesystem;
using namespace collide::testing;
using ::testing::HasSubstr;

const std::string kRig = std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml";
const std::string kData = std::string(COLLIDE_TEST_DATA_DIR) + "/footage/";

std::string readText(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class CliFootage : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scratch_ = new ScratchDir;
    const std::string dir = scratch_->file("campaign");
    auto run = runCollide("campaign --rig " + q(kRig) + " --shots 1 --seed 5 --out " + q(dir) +
                              " --angle-min-deg 20 --angle-max-deg 50",
                          *scratch_);
    campaign_ok_ = run.exit_code == 0;
    campaign_err_ = run.err;
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".h5") {
        auto shot = collide::app::readShot(e.path().string());
        if (shot.ok()) shot_ = new collide::hw::Shot(std::move(*shot));
      }
  }
  static void TearDownTestSuite() {
    delete shot_;
    delete scratch_;
  }
  static ScratchDir* scratch_;
  static collide::hw::Shot* shot_;
  static bool campaign_ok_;
  static std::string campaign_err_;

  // The shot's frames must be consecutive ids to fit a camera file.
  static bool consecutive() {
    const auto& fr = shot_->burst.frames;
    for (std::size_t i = 1; i < fr.size(); ++i)
      if (fr[i].id != fr[i - 1].id + 1 || fr[i].image.empty()) return false;
    return !fr.empty() && !fr[0].image.empty();
  }

  collide::app::ShotResults analyze(const std::string& file, const std::string& extra,
                                    CommandRun* run_out = nullptr) {
    const std::string json = scratch_->file(fs::path(file).filename().string() + ".json");
    auto run = runCollide(
        "analyze --frames " + q(file) + " --diameter-mm 25.4 --json " + q(json) + extra, *scratch_);
    if (run_out) *run_out = run;
    EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
    auto r = collide::app::parseResultsJson(readText(json));
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
    return r.ok() ? *r : collide::app::ShotResults{};
  }
};
ScratchDir* CliFootage::scratch_ = nullptr;
collide::hw::Shot* CliFootage::shot_ = nullptr;
bool CliFootage::campaign_ok_ = false;
std::string CliFootage::campaign_err_;

TEST_F(CliFootage, InfoDescribesTheRealCameraFiles) {
  auto run =
      runCollide("info " + q(kData + "beam.cihx") + " " + q(kData + "cine_781.cine"), *scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.out, HasSubstr("Photron MRAW"));
  EXPECT_THAT(run.out, HasSubstr("1024 x 80 pixels"));
  EXPECT_THAT(run.out, HasSubstr("50000 frames/s"));
  EXPECT_THAT(run.out, HasSubstr("16 stored, 12 effective"));
  EXPECT_THAT(run.out, HasSubstr("Phantom CINE"));
  EXPECT_THAT(run.out, HasSubstr("256 x 256 pixels"));
  EXPECT_THAT(run.out, HasSubstr("frames        15"));
  EXPECT_THAT(run.out, HasSubstr("90000 frames/s"));
  EXPECT_THAT(run.out, HasSubstr("exposure      10 us"));
  EXPECT_THAT(run.out, HasSubstr("-5417 to -5403 (trigger = frame 0)"));
}

TEST_F(CliFootage, InfoOnABadFileSaysWhatIsWrong) {
  const std::string mraw = scratch_->file("alone.mraw");
  writeBytes(mraw, std::vector<std::uint8_t>(100, 0));
  auto run = runCollide("info " + q(mraw), *scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("no header alone.cihx or .cih next to"));
  run = runCollide("info", *scratch_);
  EXPECT_EQ(run.exit_code, 2);
}

TEST_F(CliFootage, AnalyzeACineTakesTheFrameRateFromTheFile) {
  ASSERT_TRUE(campaign_ok_) << campaign_err_;
  ASSERT_NE(shot_, nullptr);
  ASSERT_TRUE(consecutive()) << "the simulated shot has gaps; pick another seed";
  const auto& b = shot_->burst;
  CineSpec s;
  s.width = b.width();
  s.height = b.height();
  s.bit_count = b.format == collide::vision::PixelFormat::Mono8 ? 8 : 16;
  s.real_bpp = collide::vision::bitDepth(b.format);
  s.first_image_no = static_cast<std::int32_t>(b.frames.front().id);
  s.fps = static_cast<std::uint32_t>(std::lround(shot_->camera.fps));
  ASSERT_EQ(s.fps, shot_->camera.fps) << "the writer stores whole frames/s";
  std::vector<cv::Mat> images;
  for (const auto& f : b.frames) images.push_back(f.image);
  const std::string cine = scratch_->file("shot.cine");
  writeBytes(cine, cineBytes(s, images));

  auto info = runCollide("info " + q(cine), *scratch_);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_THAT(info.out, HasSubstr(std::to_string(b.frames.size())));

  CommandRun run;
  const auto r = analyze(cine, "", &run);
  EXPECT_THAT(run.err, HasSubstr("(from the file)"));
  ASSERT_FALSE(r.error.has_value()) << *r.error;
  const auto& c = r.collision;
  EXPECT_LT(std::abs(c.e.value - shot_->truth->material.e), 4 * c.e.sigma + 1e-3)
      << "e " << c.e.value << " +- " << c.e.sigma << ", truth " << shot_->truth->material.e;
  EXPECT_NEAR(c.t_collision_s.value, shot_->truth->t_collision_s - shot_->truth->t_s.front(),
              0.5 / shot_->camera.fps);

  // --fps overrides the file: twice the rate doubles the speeds. Across the
  // image only: the vertical components are not simply doubled, since the fits
  // keep gravity at g while the doubled clock asks for 4 g (the analysis flags
  // that as gravity_scale_mismatch).
  const auto r2 = analyze(cine, " --fps " + std::to_string(2 * shot_->camera.fps));
  for (int s = 0; s < 2; ++s) {
    const double vx = r.sphere[s].velocity_before_m_s.value.x();
    EXPECT_NEAR(r2.sphere[s].velocity_before_m_s.value.x(), 2 * vx, 0.01 * std::abs(vx))
        << "sphere " << s + 1;
  }
  EXPECT_NE(std::find(r2.quality_flags.begin(), r2.quality_flags.end(), "gravity_scale_mismatch"),
            r2.quality_flags.end());
}

TEST_F(CliFootage, AnalyzeAnMrawUsesTheFilesPixelSize) {
  ASSERT_TRUE(campaign_ok_) << campaign_err_;
  ASSERT_NE(shot_, nullptr);
  ASSERT_TRUE(consecutive());
  const auto& b = shot_->burst;
  const int bits = b.format == collide::vision::PixelFormat::Mono8    ? 8
                   : b.format == collide::vision::PixelFormat::Mono12 ? 12
                                                                      : 16;
  std::vector<std::uint8_t> bytes;
  for (const auto& f : b.frames) {
    auto fb = mrawFrameBytes(f.image, bits);
    bytes.insert(bytes.end(), fb.begin(), fb.end());
  }
  const std::string mraw = scratch_->file("shot.mraw");
  writeBytes(mraw, bytes);
  const double px_mm = shot_->scene.pixel_size_m * 1e3;
  writeText(
      scratch_->file("shot.cihx"),
      cihxText(b.width(), b.height(), bits, static_cast<long>(b.frames.size()), shot_->camera.fps,
               20000, static_cast<long>(b.frames.front().id), "mm", px_mm));
  CommandRun run;
  const auto r = analyze(mraw, "", &run);
  EXPECT_THAT(run.err, HasSubstr("pixel size from the file"));
  ASSERT_FALSE(r.error.has_value()) << *r.error;
  // cihxText writes sizeOfPixel with 6 decimals.
  EXPECT_NEAR(r.pixel_size_m, shot_->scene.pixel_size_m, 1e-9);
  EXPECT_LT(std::abs(r.collision.e.value - shot_->truth->material.e),
            4 * r.collision.e.sigma + 1e-3);

  // A range of frames of the file.
  const auto first = b.frames.front().id;
  auto part = runCollide("analyze --frames " + q(mraw) + " --diameter-mm 25.4 --range " +
                             std::to_string(first) + ":" + std::to_string(first + 2),
                         *scratch_);
  EXPECT_THAT(part.err, HasSubstr(": 3 frames"));
}

}  // namespace
