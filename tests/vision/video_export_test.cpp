// Bursts written as MJPG AVI videos, read back with OpenCV's VideoCapture (not
// the writer's own code): every frame is there, in order, at the chosen
// playback rate, with 16-bit values scaled to 8 bits as the GUI shows them;
// errors name the file, and a failed export leaves no partial file.
#include "vision/video_export.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <random>

namespace collide::vision {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class VideoExport : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("collide_video_export_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

constexpr int kBackground = 800, kSquare = 4095, kSide = 16;

// Mono12 frames 96 x 64: background 800, a 16 x 16 square at full scale whose
// left edge is at u = 6 k in frame k; frame 3 arrived without image data.
Burst movingSquare(int n) {
  Burst b;
  b.format = PixelFormat::Mono12;
  b.fps = 1000;
  for (int k = 0; k < n; ++k) {
    Frame f;
    f.id = k - 2;
    if (k != 3) {
      f.image = cv::Mat(64, 96, CV_16UC1, cv::Scalar(kBackground));
      f.image(cv::Rect(6 * k, 24, kSide, kSide)).setTo(kSquare);
    }
    b.frames.push_back(f);
  }
  return b;
}

TEST_F(VideoExport, EveryFrameScaledAsShownAtThePlaybackRate) {
  const Burst burst = movingSquare(12);
  auto report = exportBurstVideo(burst, path("shot.avi"), {.playback_fps = 10});
  ASSERT_TRUE(report) << report.error().message;
  EXPECT_EQ(report->written, 11u);
  EXPECT_EQ(report->skipped, 1u);

  cv::VideoCapture cap(path("shot.avi"), cv::CAP_OPENCV_MJPEG);
  ASSERT_TRUE(cap.isOpened());
  EXPECT_NEAR(cap.get(cv::CAP_PROP_FPS), 10.0, 1e-6);
  // Mono12 shown as value * 255 / 4095: 800 -> 49.8, 4095 -> 255.
  const double background8 = kBackground * 255.0 / 4095.0;
  cv::Mat frame, grey;
  std::vector<int> source;  // burst positions of the frames written
  for (int k = 0; k < 12; ++k)
    if (k != 3) source.push_back(k);
  for (int k : source) {
    ASSERT_TRUE(cap.read(frame)) << "frame " << k << " missing";
    cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
    ASSERT_EQ(grey.size(), cv::Size(96, 64));
    const cv::Rect square(6 * k, 24, kSide, kSide);
    EXPECT_GT(cv::mean(grey(cv::Rect(square.x + 2, square.y + 2, kSide - 4, kSide - 4)))[0], 245.0) << "frame " << k;
    EXPECT_NEAR(cv::mean(grey(cv::Rect(0, 0, 96, 16)))[0], background8, 3.0) << "frame " << k;
  }
  EXPECT_FALSE(cap.read(frame)) << "no frames beyond the burst's";
}

TEST_F(VideoExport, RefusalsNameTheFileAndLeaveNothing) {
  const Burst burst = movingSquare(5);
  auto png = exportBurstVideo(burst, path("shot.png"), {.playback_fps = 10});
  ASSERT_FALSE(png);
  EXPECT_THAT(png.error().message, HasSubstr(".avi"));
  auto slow = exportBurstVideo(burst, path("shot.avi"), {.playback_fps = 0});
  ASSERT_FALSE(slow);
  EXPECT_THAT(slow.error().message, HasSubstr(path("shot.avi")));
  const std::string nowhere = path("missing/folder/shot.avi");
  auto missing = exportBurstVideo(burst, nowhere, {.playback_fps = 10});
  ASSERT_FALSE(missing);
  EXPECT_THAT(missing.error().message, HasSubstr(nowhere));
  EXPECT_THAT(missing.error().message, HasSubstr("folder exists"));
  EXPECT_FALSE(fs::exists(path("shot.avi")));
  EXPECT_FALSE(fs::exists(path("shot.png")));
  Burst empty = burst;
  for (auto& f : empty.frames) f.image = cv::Mat();
  EXPECT_FALSE(exportBurstVideo(empty, path("shot.avi"), {.playback_fps = 10}));
  EXPECT_FALSE(fs::exists(path("shot.avi")));
}

// Disk full, as the file system reports it: a file size limit (RLIMIT_FSIZE)
// in a child process makes writes past 60 kB fail. The export must fail,
// say so with the file's name, and remove what it had written.
TEST_F(VideoExport, DiskFullFailsAndRemovesThePartialFile) {
  Burst burst;
  burst.format = PixelFormat::Mono8;
  burst.fps = 1000;
  std::mt19937 rng(7);
  for (int k = 0; k < 10; ++k) {  // noise: about 60 kB per JPEG frame
    Frame f;
    f.id = k;
    f.image = cv::Mat(256, 256, CV_8UC1);
    cv::randu(f.image, 0, 256);
    burst.frames.push_back(f);
  }
  const std::string file = path("full.avi");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::signal(SIGXFSZ, SIG_IGN);  // write() then fails with EFBIG
    const rlimit limit{60000, 60000};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    auto r = exportBurstVideo(burst, file, {.playback_fps = 10});
    const bool named = !r && r.error().message.find(file) != std::string::npos;
    ::_exit(r ? 1 : (named ? 0 : 2));
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "1: the export reported success; 2: no file name";
  EXPECT_FALSE(fs::exists(file)) << "the partial video was left behind";
  // Without the limit the same burst is written whole.
  auto ok = exportBurstVideo(burst, file, {.playback_fps = 10});
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(ok->written, 10u);
}

}  // namespace
}  // namespace collide::vision
