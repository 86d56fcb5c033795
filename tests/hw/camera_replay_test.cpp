// What only the replay camera does: keep a stored burst's content, statuses
// and gaps; refuse settings that differ from it; load through the caller's
// hook or vision's folder loader; and stand in for the camera of a rig.
#include "hw/camera_replay.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "hw/clock.hpp"
#include "hw/rig.hpp"
#include "hw/sequencer.hpp"
#include "profile_text.hpp"
#include "vision/frame_io.hpp"

using namespace collide::hw;
using collide::hw::testing::simProfileText;
using collide::hw::testing::withKey;
using collide::vision::Burst;
using collide::vision::FrameStatus;
using collide::vision::PixelFormat;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

constexpr std::int64_t kMs = 1'000'000;

// Frames -4..9 of a 100 x 80 Mono8 burst at 1000 frames/s, each image filled
// with 100 + id, frame 3 lost and frame 5 failed in the original stream.
Burst storedBurst() {
  Burst b;
  b.format = PixelFormat::Mono8;
  b.fps = 1000.0;
  b.exposure_us = 200.0;
  for (int id = -4; id < 10; ++id) {
    if (id == 3) continue;
    collide::vision::Frame f;
    f.id = id;
    f.timestamp_ns = 2'000'000'000 + id * kMs;
    f.status = id == 5 ? FrameStatus::Failed : FrameStatus::Good;
    f.image = cv::Mat(80, 100, CV_8UC1, cv::Scalar(100 + id));
    b.frames.push_back(f);
  }
  return b;
}

CameraConfig matching() {
  return {0, 0, 100, 80, PixelFormat::Mono8, 1000.0, 200.0, 0.0};
}

}  // namespace

TEST(CameraReplay, PlaysTheStoredFramesBackWithTheirStatusesAndGaps) {
  CameraReplay cam(storedBurst(), "stored", false);
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(matching()));
  ASSERT_TRUE(cam.start());
  ASSERT_TRUE(cam.arm(4, 10));
  const std::int64_t trigger = monotonicNowNs() + 5 * kMs;
  ASSERT_TRUE(cam.trigger(trigger));
  ASSERT_TRUE(*cam.waitBurst(monotonicNowNs() + 10'000 * kMs));
  const auto b = cam.takeBurst();
  ASSERT_TRUE(b);
  EXPECT_TRUE(b->complete) << b->note;
  ASSERT_EQ(b->frames.size(), 13u);
  for (const auto& f : b->frames) {
    EXPECT_EQ(f.image.at<std::uint8_t>(0, 0), 100 + f.id) << "frame " << f.id;
    // Stored frame 0 lands on the trigger, the rest keep their spacing.
    EXPECT_EQ(f.timestamp_ns, trigger + f.id * kMs);
  }
  EXPECT_EQ(b->stats.missing_ids, (std::vector<std::int64_t>{3}));
  EXPECT_EQ(b->stats.failed, 1u);
  EXPECT_EQ(b->frames[8].id, 5);
  EXPECT_EQ(b->frames[8].status, FrameStatus::Failed);
}

TEST(CameraReplay, AShortStoredBurstEndsTheStreamEarly) {
  CameraReplay cam(storedBurst(), "stored", false);
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(matching()));
  ASSERT_TRUE(cam.start());
  ASSERT_TRUE(cam.arm(2, 50));
  ASSERT_TRUE(cam.trigger(monotonicNowNs()));
  ASSERT_TRUE(*cam.waitBurst(monotonicNowNs() + 10'000 * kMs));
  const auto b = cam.takeBurst();
  EXPECT_FALSE(b->complete);
  EXPECT_THAT(b->note, HasSubstr("the replayed burst stored ends at frame 9"));
}

TEST(CameraReplay, RefusesSettingsThatDifferFromTheStoredBurst) {
  CameraReplay cam(storedBurst(), "stored", false);
  ASSERT_TRUE(cam.open());
  CameraConfig c = matching();
  c.width = 90;
  EXPECT_THAT(cam.configure(c).error().message,
              HasSubstr("the replayed burst is 100x80: set camera.roi = [0, 0, 100, 80]"));
  c = matching();
  c.fps = 500.0;
  c.exposure_us = 100.0;
  EXPECT_THAT(cam.configure(c).error().message,
              HasSubstr("taken at 1000 frames/s: set camera.fps = 1000"));
  c = matching();
  c.format = PixelFormat::Mono16;
  EXPECT_THAT(cam.configure(c).error().message, HasSubstr("cannot deliver Mono16"));
}

TEST(CameraReplay, RigUsesTheCallersLoaderAndShootsWithoutTruth) {
  std::string text = withKey(simProfileText(), "camera", "backend", "\"replay\"");
  text = withKey(text, "camera", "roi", "[0, 0, 100, 80]");
  text = withKey(text, "camera", "source", "\"shots/0001.h5\"");
  for (const char* k : {"sensor_px", "noise_grey", "drop_every", "stop_after_frames"})
    text = collide::hw::testing::withoutKey(text, "camera", k);
  text = withKey(text, "burst", "pre_trigger_frames", "4");
  text = withKey(text, "burst", "post_trigger_frames", "10");
  text = withKey(text, "sequencer", "max_dropped_frames", "1");
  text = withKey(text, "geometry", "origin_px", "[49.5, 39.5]");
  text = withKey(text, "geometry", "pixel_size_m", "0.0015");
  auto profile = parseRigProfile(text, "replay.toml");
  ASSERT_TRUE(profile) << profile.error().message;

  std::string asked;
  RigHooks hooks;
  hooks.load_burst = [&](const std::string& source) -> collide::Result<Burst> {
    asked = source;
    return storedBurst();
  };
  auto rig = makeRig(*profile, hooks);
  ASSERT_TRUE(rig) << rig.error().message;
  EXPECT_EQ(asked, "shots/0001.h5");
  const Shot shot = Sequencer(*rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  ASSERT_EQ(shot.status, ShotStatus::Ok) << shot.failure_reason;
  EXPECT_EQ(shot.camera.backend, "replay");
  EXPECT_EQ(shot.burst.frames.size(), 13u);  // 14 ids, one lost in the original
  EXPECT_EQ(shot.burst.frames.front().image.at<std::uint8_t>(0, 0), 100 - 4);
  EXPECT_FALSE(shot.truth.has_value());
}

TEST(CameraReplay, WithoutALoaderReadsAFolderOfImagesNumberedFromTriggerFrame) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("collide_replay_" + std::to_string(monotonicNowNs()));
  Burst folder = storedBurst();
  ASSERT_TRUE(collide::vision::exportBurstPng(folder, dir.string()));

  std::string text = withKey(simProfileText(), "camera", "backend", "\"replay\"");
  text = withKey(text, "camera", "roi", "[0, 0, 100, 80]");
  std::string quoted_dir = "\"";  // appended: GCC 12 warns falsely on "\"" + string
  quoted_dir.append(dir.string()).append("\"");
  text = withKey(text, "camera", "source", quoted_dir);
  text = withKey(text, "camera", "trigger_frame", "4");
  for (const char* k : {"sensor_px", "noise_grey", "drop_every", "stop_after_frames"})
    text = collide::hw::testing::withoutKey(text, "camera", k);
  auto profile = parseRigProfile(text, "replay.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  auto rig = makeRig(*profile);
  ASSERT_TRUE(rig) << rig.error().message;
  Camera& cam = *rig->camera;
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.configure(profile->camera_config));
  ASSERT_TRUE(cam.start());
  ASSERT_TRUE(cam.arm(4, 5));
  ASSERT_TRUE(cam.trigger(monotonicNowNs() + 10 * kMs));
  ASSERT_TRUE(*cam.waitBurst(monotonicNowNs() + 10'000 * kMs));
  const auto b = cam.takeBurst();
  ASSERT_TRUE(b->complete) << b->note;
  // The folder holds 13 images; the 5th (stored id 0) becomes frame 0.
  ASSERT_EQ(b->frames.size(), 9u);
  EXPECT_EQ(b->frames[4].id, 0);
  EXPECT_EQ(b->frames[4].image.at<std::uint8_t>(0, 0), 100);
  std::filesystem::remove_all(dir);
}

TEST(CameraReplay, MissingSourceIsReportedAtTheField) {
  std::string text = withKey(simProfileText(), "camera", "backend", "\"replay\"");
  text = withKey(text, "camera", "source", "\"/nonexistent/shot\"");
  for (const char* k : {"sensor_px", "noise_grey", "drop_every", "stop_after_frames"})
    text = collide::hw::testing::withoutKey(text, "camera", k);
  auto profile = parseRigProfile(text, "replay.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  auto rig = makeRig(*profile);
  ASSERT_FALSE(rig);
  EXPECT_THAT(rig.error().message,
              StartsWith("replay.toml:" +
                         std::to_string(collide::hw::testing::lineOf(text, "camera", "source")) +
                         ": camera.source = \"/nonexistent/shot\": "));
}
