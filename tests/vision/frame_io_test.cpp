#include "vision/frame_io.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <random>

namespace collide::vision {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// A fresh folder per test, removed afterwards.
class FrameIo : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("collide_frame_io_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  void writeText(const std::string& name, const std::string& text) const {
    std::ofstream(path(name)) << text;
  }
  void writeImage(const std::string& name, const cv::Mat& m) const {
    ASSERT_TRUE(cv::imwrite(path(name), m)) << name;
  }

  fs::path dir_;
};

Burst randomBurst(PixelFormat format, int hi, std::int64_t first_id, int count) {
  Burst b;
  b.format = format;
  cv::RNG rng(12345);
  for (int i = 0; i < count; ++i) {
    Frame f;
    f.id = first_id + i;
    f.image.create(24, 32, cvType(format));
    rng.fill(f.image, cv::RNG::UNIFORM, 0, hi + 1);
    b.frames.push_back(f);
  }
  return b;
}

void expectSameImagesInOrder(const Burst& loaded, const Burst& original, double fps) {
  ASSERT_EQ(loaded.frames.size(), original.frames.size());
  EXPECT_EQ(loaded.format, original.format);
  EXPECT_EQ(loaded.fps, fps);
  for (std::size_t i = 0; i < loaded.frames.size(); ++i) {
    const Frame& f = loaded.frames[i];
    EXPECT_EQ(f.id, static_cast<std::int64_t>(i));
    EXPECT_EQ(f.timestamp_ns, std::llround(i * 1e9 / fps));
    ASSERT_EQ(f.image.type(), original.frames[i].image.type());
    EXPECT_EQ(cv::norm(f.image, original.frames[i].image, cv::NORM_INF), 0.0) << "frame " << i;
  }
}

TEST(FrameFileName, NameOrderIsFrameOrder) {
  EXPECT_EQ(frameFileName(0, -5), "frame_0000_id-5.png");
  EXPECT_EQ(frameFileName(12, 7), "frame_0012_id7.png");
  EXPECT_EQ(frameFileName(12345, 0, 4), "frame_12345_id0.png");  // widened to fit
  std::vector<std::string> names;
  for (std::int64_t id = -120; id <= 120; ++id) names.push_back(frameFileName(id + 120, id));
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));  // plain byte order
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end(), naturalLess));
}

TEST(NaturalLess, DigitRunsCompareAsNumbers) {
  EXPECT_TRUE(naturalLess("frame2.png", "frame10.png"));
  EXPECT_FALSE(naturalLess("frame10.png", "frame2.png"));
  EXPECT_TRUE(naturalLess("a9b", "a10a"));
  EXPECT_TRUE(naturalLess("shot1_frame99", "shot2_frame1"));
  EXPECT_TRUE(naturalLess("frame", "frame1"));
  EXPECT_FALSE(naturalLess("frame7", "frame7"));
  // Equal numbers with different zero padding still order strictly, one way.
  EXPECT_NE(naturalLess("f01", "f1"), naturalLess("f1", "f01"));
}

TEST_F(FrameIo, RoundTrip8Bit) {
  const Burst b = randomBurst(PixelFormat::Mono8, 255, -3, 8);
  ASSERT_TRUE(exportBurstPng(b, dir_.string()));
  EXPECT_TRUE(fs::exists(path("frame_0000_id-3.png")));
  EXPECT_TRUE(fs::exists(path("frame_0007_id4.png")));
  const Result<Burst> loaded = loadFrameFolder(dir_.string(), 500.0);
  ASSERT_TRUE(loaded) << loaded.error().message;
  expectSameImagesInOrder(*loaded, b, 500.0);
  EXPECT_TRUE(loaded->note.empty());
}

TEST_F(FrameIo, RoundTrip16BitAnd12Bit) {
  const Burst b16 = randomBurst(PixelFormat::Mono16, 65535, -12, 20);
  ASSERT_TRUE(exportBurstPng(b16, path("16")));
  const Result<Burst> l16 = loadFrameFolder(path("16"), 1000.0);
  ASSERT_TRUE(l16) << l16.error().message;
  expectSameImagesInOrder(*l16, b16, 1000.0);

  const Burst b12 = randomBurst(PixelFormat::Mono12, 4095, 0, 5);
  ASSERT_TRUE(exportBurstPng(b12, path("12")));
  const Result<Burst> l12 = loadFrameFolder(path("12"), 250.0);
  ASSERT_TRUE(l12) << l12.error().message;
  expectSameImagesInOrder(*l12, b12, 250.0);
}

TEST_F(FrameIo, NaturalOrderAndTiffAndColour) {
  for (int n : {10, 2, 1, 33})
    writeImage("frame" + std::to_string(n) + ".png", cv::Mat(4, 6, CV_8UC1, cv::Scalar(n)));
  const Result<Burst> b = loadFrameFolder(dir_.string(), 100);
  ASSERT_TRUE(b) << b.error().message;
  ASSERT_EQ(b->frames.size(), 4u);
  const int expected[] = {1, 2, 10, 33};
  for (int i = 0; i < 4; ++i) EXPECT_EQ(b->frames[i].image.at<std::uint8_t>(0, 0), expected[i]);

  // 16-bit TIFF and a colour PNG in their own folders.
  fs::create_directories(path("tiff"));
  ASSERT_TRUE(cv::imwrite(path("tiff/a1.tif"), cv::Mat(4, 6, CV_16UC1, cv::Scalar(40000))));
  ASSERT_TRUE(cv::imwrite(path("tiff/a2.tiff"), cv::Mat(4, 6, CV_16UC1, cv::Scalar(7))));
  const Result<Burst> t = loadFrameFolder(path("tiff"), 100);
  ASSERT_TRUE(t) << t.error().message;
  EXPECT_EQ(t->format, PixelFormat::Mono16);
  EXPECT_EQ(t->frames[0].image.at<std::uint16_t>(0, 0), 40000);

  fs::create_directories(path("colour"));
  ASSERT_TRUE(cv::imwrite(path("colour/c.png"), cv::Mat(4, 6, CV_8UC3, cv::Scalar(100, 100, 100))));
  const Result<Burst> c = loadFrameFolder(path("colour"), 100);
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->frames[0].image.type(), CV_8UC1);
  EXPECT_EQ(c->frames[0].image.at<std::uint8_t>(0, 0), 100);
}

TEST_F(FrameIo, NonImageFilesAreSkippedWithANote) {
  writeImage("f1.png", cv::Mat(4, 6, CV_8UC1, cv::Scalar(1)));
  writeText("notes.txt", "shot 17, nylon");
  fs::create_directories(path("sub"));
  const Result<Burst> b = loadFrameFolder(dir_.string(), 100);
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_EQ(b->frames.size(), 1u);
  EXPECT_THAT(b->note, HasSubstr("notes.txt"));
  EXPECT_THAT(b->note, HasSubstr("sub"));
}

TEST_F(FrameIo, BadFolderInputsNameTheProblem) {
  // fps
  writeImage("f1.png", cv::Mat(4, 6, CV_8UC1, cv::Scalar(1)));
  for (double fps : {0.0, -5.0, std::nan("")}) {
    const Result<Burst> b = loadFrameFolder(dir_.string(), fps);
    ASSERT_FALSE(b);
    EXPECT_THAT(b.error().message, HasSubstr("frame rate"));
  }
  // missing folder, a file instead of a folder
  const Result<Burst> missing = loadFrameFolder(path("nope"), 100);
  ASSERT_FALSE(missing);
  EXPECT_THAT(missing.error().message, HasSubstr(path("nope")));
  const Result<Burst> file = loadFrameFolder(path("f1.png"), 100);
  ASSERT_FALSE(file);
  EXPECT_THAT(file.error().message, HasSubstr("not a folder"));
  // empty folder, folder with no images
  fs::create_directories(path("empty"));
  const Result<Burst> empty = loadFrameFolder(path("empty"), 100);
  ASSERT_FALSE(empty);
  EXPECT_THAT(empty.error().message, HasSubstr(path("empty")));
  fs::create_directories(path("text"));
  std::ofstream(path("text/readme.md")) << "no frames here";
  const Result<Burst> text = loadFrameFolder(path("text"), 100);
  ASSERT_FALSE(text);
  EXPECT_THAT(text.error().message, HasSubstr("readme.md"));
}

TEST_F(FrameIo, UndecodableImageIsAnErrorNamingIt) {
  writeImage("f1.png", cv::Mat(4, 6, CV_8UC1, cv::Scalar(1)));
  writeText("f2.png", "this is not a PNG");
  const Result<Burst> b = loadFrameFolder(dir_.string(), 100);
  ASSERT_FALSE(b);
  EXPECT_THAT(b.error().message, HasSubstr(path("f2.png")));
}

// Found by footage_fuzz (10^6 run, session 8): a damaged ".png" whose bytes
// happen to read as DICOM went to OpenCV's DICOM decoder, and libgdcm aborted
// the whole process on an assert. A frame file must start the way its
// extension says before any decoder sees it.
TEST_F(FrameIo, AFileThatIsNotTheFormatItsNameSaysIsRefusedBeforeDecoding) {
  fs::copy_file(fs::path(COLLIDE_TEST_DATA_DIR) / "corrupt" / "dicom-named-png.png",
                dir_ / "frame_0001.png");
  const Result<Burst> b = loadFrameFolder(dir_.string(), 100);
  ASSERT_FALSE(b);
  EXPECT_THAT(b.error().message, HasSubstr(path("frame_0001.png")));
  EXPECT_THAT(b.error().message, HasSubstr("is not a PNG file"));
  // Each format's own signature, under another format's name: refused too.
  writeImage("f2.tif", cv::Mat(4, 6, CV_8UC1, cv::Scalar(1)));
  fs::rename(dir_ / "f2.tif", dir_ / "frame_0002.jpg");
  fs::remove(dir_ / "frame_0001.png");
  const Result<Burst> c = loadFrameFolder(dir_.string(), 100);
  ASSERT_FALSE(c);
  EXPECT_THAT(c.error().message, HasSubstr("is not a JPEG file"));
}

TEST_F(FrameIo, FramesOfDifferentSizesOrDepths) {
  writeImage("f1.png", cv::Mat(48, 64, CV_8UC1, cv::Scalar(1)));
  writeImage("f2.png", cv::Mat(48, 64, CV_8UC1, cv::Scalar(2)));
  writeImage("f10.png", cv::Mat(24, 32, CV_8UC1, cv::Scalar(3)));
  const Result<Burst> b = loadFrameFolder(dir_.string(), 100);
  ASSERT_FALSE(b);
  EXPECT_THAT(b.error().message, HasSubstr(path("f10.png")));
  EXPECT_THAT(b.error().message, HasSubstr("32x24"));
  EXPECT_THAT(b.error().message, HasSubstr("64x48"));

  fs::remove(path("f10.png"));
  writeImage("f3.png", cv::Mat(48, 64, CV_16UC1, cv::Scalar(3)));
  const Result<Burst> d = loadFrameFolder(dir_.string(), 100);
  ASSERT_FALSE(d);
  EXPECT_THAT(d.error().message, HasSubstr(path("f3.png")));
  EXPECT_THAT(d.error().message, HasSubstr("16-bit"));
}

TEST_F(FrameIo, WriteErrors) {
  Frame f;
  f.image = cv::Mat(4, 6, CV_8UC1, cv::Scalar(9));
  const Status no_dir = writeFramePng(f, path("missing/frame.png"));
  ASSERT_FALSE(no_dir);
  EXPECT_THAT(no_dir.error().message, HasSubstr(path("missing")));
  EXPECT_FALSE(writeFramePng(Frame{}, path("x.png")));
  EXPECT_FALSE(writeFramePng(f, path("x.jpg")));
  Frame colour;
  colour.image = cv::Mat(4, 6, CV_8UC3);
  EXPECT_FALSE(writeFramePng(colour, path("c.png")));
  ASSERT_TRUE(writeFramePng(f, path("ok.png")));
  EXPECT_EQ(cv::imread(path("ok.png"), cv::IMREAD_UNCHANGED).at<std::uint8_t>(0, 0), 9);
}

TEST_F(FrameIo, ExportRefusesToMixWithAnotherExport) {
  ASSERT_TRUE(exportBurstPng(randomBurst(PixelFormat::Mono8, 255, -2, 4), dir_.string()));
  // The same burst again overwrites its own files...
  EXPECT_TRUE(exportBurstPng(randomBurst(PixelFormat::Mono8, 255, -2, 4), dir_.string()));
  // ...but a different one (ids 0..3) would leave the files of ids -2..1 behind
  // to be read back; the message names one of them.
  const auto s = exportBurstPng(randomBurst(PixelFormat::Mono8, 255, 0, 4), dir_.string());
  ASSERT_FALSE(s);
  EXPECT_THAT(s.error().message, HasSubstr("already holds frames from another export (frame_000"));
  Burst dup = randomBurst(PixelFormat::Mono8, 255, 0, 2);
  dup.frames[1].id = 0;
  EXPECT_FALSE(exportBurstPng(dup, path("dup")));
}

// A 64 x 48 grey MJPEG AVI of `frames` flat frames, frame i at level
// step * i + level0; false when this OpenCV build cannot write one.
bool writeGreyAvi(const std::string& file, double fps, int frames, int step, int level0) {
  cv::VideoWriter w(file, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, cv::Size(64, 48),
                    false);
  if (!w.isOpened()) return false;
  for (int i = 0; i < frames; ++i) w.write(cv::Mat(48, 64, CV_8UC1, cv::Scalar(step * i + level0)));
  return true;
}

TEST_F(FrameIo, VideoRoundTripAndErrors) {
  const Result<Burst> missing = loadVideo(path("none.avi"), 0);
  ASSERT_FALSE(missing);
  EXPECT_THAT(missing.error().message, HasSubstr(path("none.avi")));

  writeText("junk.avi", std::string(4096, 'x'));
  const Result<Burst> junk = loadVideo(path("junk.avi"), 0);
  ASSERT_FALSE(junk);
  EXPECT_THAT(junk.error().message, HasSubstr(path("junk.avi")));

  if (!writeGreyAvi(path("shot.avi"), 250, 6, 30, 20))
    GTEST_SKIP() << "this OpenCV build cannot write MJPG AVI files";

  const Result<Burst> b = loadVideo(path("shot.avi"), 0);
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_DOUBLE_EQ(b->fps, 250.0);
  EXPECT_EQ(b->format, PixelFormat::Mono8);
  ASSERT_EQ(b->frames.size(), 6u);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(b->frames[i].id, i);
    EXPECT_EQ(b->frames[i].timestamp_ns, i * 4'000'000);
    EXPECT_EQ(b->frames[i].image.type(), CV_8UC1);
    EXPECT_EQ(b->frames[i].image.size(), cv::Size(64, 48));
    EXPECT_NEAR(cv::mean(b->frames[i].image)[0], 30 * i + 20, 3.0);  // JPEG is lossy
  }
  const Result<Burst> forced = loadVideo(path("shot.avi"), 1000);
  ASSERT_TRUE(forced);
  EXPECT_EQ(forced->fps, 1000.0);
  EXPECT_EQ(forced->frames[5].timestamp_ns, 5'000'000);
  EXPECT_FALSE(loadVideo(path("shot.avi"), -1));
}

// The streamed video (collide track): the same frames as loadVideo's, read
// in any order (forward decodes on, backward opens the file again), without
// holding the video; a frame past the end and a missing file are errors.
TEST_F(FrameIo, AVideoStreamReadsTheSameFramesInAnyOrder) {
  EXPECT_FALSE(openVideoStream(path("none.avi"), 0));
  if (!writeGreyAvi(path("stream.avi"), 500, 9, 25, 10))
    GTEST_SKIP() << "this OpenCV build cannot write MJPG AVI files";
  const Result<Burst> whole = loadVideo(path("stream.avi"), 0);
  ASSERT_TRUE(whole) << whole.error().message;
  const Result<VideoStream> v = openVideoStream(path("stream.avi"), 0);
  ASSERT_TRUE(v) << v.error().message;
  EXPECT_EQ(v->count, 9);
  EXPECT_DOUBLE_EQ(v->fps, 500.0);
  EXPECT_EQ(v->width, 64);
  EXPECT_EQ(v->height, 48);
  EXPECT_EQ(v->format, PixelFormat::Mono8);
  for (const int i : {0, 1, 2, 7, 8, 3, 3, 5, 0}) {
    const Result<Frame> f = v->read(i);
    ASSERT_TRUE(f) << "frame " << i << ": " << f.error().message;
    EXPECT_EQ(f->id, i);
    EXPECT_EQ(f->timestamp_ns, i * 2'000'000);
    EXPECT_EQ(cv::norm(f->image, whole->frames[i].image, cv::NORM_INF), 0) << "frame " << i;
  }
  const Result<Frame> past = v->read(9);
  ASSERT_FALSE(past);
  EXPECT_THAT(past.error().message, HasSubstr("ends before frame 9"));
  EXPECT_THAT(past.error().message, HasSubstr(path("stream.avi")));
}

}  // namespace
}  // namespace collide::vision
