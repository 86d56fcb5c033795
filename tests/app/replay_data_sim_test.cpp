// The recorded shots in tests/data replayed end to end: through the replay
// camera, the sequencer and the simulated regulator and valves, saved again,
// and compared with the recording frame by frame.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "app/analyze.hpp"
#include "app/replay.hpp"
#include "app/report/results_json.hpp"
#include "app/store/shot_file.hpp"
#include "hw/replay_profile.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace collide::app {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> recordedShots() {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(COLLIDE_TEST_DATA_DIR))
    if (e.path().extension() == ".h5") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

TEST(ReplayData, RecordedShotsArePresent) {
  EXPECT_GE(recordedShots().size(), 2u);
}

TEST(ReplayData, EveryRecordedShotReplaysFrameForFrame) {
  testing::ScratchDir out;
  int sequence = 0;
  for (const auto& file : recordedShots()) {
    SCOPED_TRACE(file);
    auto recorded = readShot(file);
    ASSERT_TRUE(recorded.ok()) << recorded.error().message;
    ReplayOptions options{out.path(), false, sequence++};
    auto replayed = replayShotFile(file, options);
    ASSERT_TRUE(replayed.ok()) << replayed.error().message;
    const hw::Shot& shot = replayed->shot;
    ASSERT_EQ(shot.status, hw::ShotStatus::Ok) << shot.failure_reason;
    EXPECT_EQ(shot.camera.backend, "replay");
    EXPECT_FALSE(shot.truth.has_value()) << "a replay knows no ground truth";
    // The recording's geometry came along: the replay is analysed at the same scale.
    EXPECT_EQ(shot.scene.pixel_size_m, recorded->scene.pixel_size_m);
    EXPECT_EQ(shot.scene.diameter_m, recorded->scene.diameter_m);

    const auto& a = recorded->burst.frames;
    const auto& b = shot.burst.frames;
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].id, b[i].id);
      // Frame spacing is kept (the replay's clock starts elsewhere).
      if (i > 0) {
        EXPECT_NEAR(double(b[i].timestamp_ns - b[0].timestamp_ns),
                    double(a[i].timestamp_ns - a[0].timestamp_ns), 1000.0);
      }
      testing::expectSameImage(a[i].image, b[i].image, "frame " + std::to_string(a[i].id));
    }
    // Saved like a live shot, then analysed like one: the material the
    // recording was simulated with comes back out of the replayed frames.
    auto outcome = analyzeShotFile(replayed->file);
    ASSERT_TRUE(outcome.analysed) << outcome.message;
    auto saved = readShot(replayed->file, {.frames = false});
    ASSERT_TRUE(saved.ok()) << saved.error().message;
    EXPECT_EQ(saved->id, shot.id);
    EXPECT_EQ(saved->camera.backend, "replay");
    EXPECT_EQ(saved->results_json, outcome.results_json);
    auto r = parseResultsJson(saved->results_json);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(recorded->truth.has_value());
    const auto& c = r->collision;
    EXPECT_GT(c.e.sigma, 0.0);
    EXPECT_LT(std::abs(c.e.value - recorded->truth->material.e), 4 * c.e.sigma + 1e-3)
        << "e " << c.e.value << " +- " << c.e.sigma;
    // Both recordings are oblique (25-55 degrees from head-on), so beta is measured.
    EXPECT_TRUE(std::isfinite(c.beta.value));
  }
}

TEST(ReplayData, ReplayProfileKeepsTheRigAndSimulatesTheDevices) {
  auto recorded = readShot(recordedShots().at(0), {.frames = false});
  ASSERT_TRUE(recorded.ok());
  auto p = hw::replayProfile(recorded->rig_profile_toml, "recorded", "shot.h5");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_EQ(p->camera.backend, "replay");
  EXPECT_EQ(p->regulator.backend, "sim");
  EXPECT_EQ(p->valves.backend, "sim");
  auto original = hw::parseRigProfile(recorded->rig_profile_toml, "recorded");
  ASSERT_TRUE(original.ok());
  EXPECT_EQ(p->camera_config.width, original->camera_config.width);
  EXPECT_EQ(p->camera_config.fps, original->camera_config.fps);
  EXPECT_EQ(p->geometry.pixel_size_m, original->geometry.pixel_size_m);
  EXPECT_EQ(p->launchers[1].exit_m, original->launchers[1].exit_m);
  EXPECT_EQ(p->burst.pre_trigger_frames, original->burst.pre_trigger_frames);

  auto bad = hw::replayProfile("name = \"x\"\n[camera\n", "broken.toml", "shot.h5");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("broken.toml"), std::string::npos) << bad.error().message;
}

TEST(ReplayData, ACorruptRecordingIsRefusedByName) {
  testing::ScratchDir dir;
  const std::string file = dir.file("corrupt.h5");
  testing::writeAll(file, "not an HDF5 file");
  auto r = replayShotFile(file, {dir.path(), false, 0});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("corrupt.h5"), std::string::npos) << r.error().message;
}

}  // namespace
}  // namespace collide::app
