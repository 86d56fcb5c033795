#include "vision/footage.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "tests/vision/footage_writers.hpp"
#include "vision/footage_reader.hpp"
#include "vision/frame_io.hpp"

namespace collide::vision {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using namespace collide::testing;

const std::string kData = std::string(COLLIDE_TEST_DATA_DIR) + "/footage/";

class FootageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("collide_footage_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

cv::Mat randomImage(int rows, int cols, int type, int hi, unsigned seed) {
  cv::Mat m(rows, cols, type);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> u(0, hi);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (type == CV_8UC1)
        m.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(u(rng));
      else
        m.at<std::uint16_t>(r, c) = static_cast<std::uint16_t>(u(rng));
    }
  return m;
}

bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// ---------------------------------------------------------------- real files

// Expected pixel values come from tests/data/footage/independent_decode.py,
// which decodes the raw bytes with numpy (little-endian 16-bit words; CINE rows
// bottom-up), not from these readers.
TEST_F(FootageTest, RealPhotronMrawWithCihx) {
  for (const std::string name : {"beam.mraw", "beam.cihx"}) {
    auto f = Footage::open(kData + name);
    ASSERT_TRUE(f.ok()) << f.error().message;
    const FootageInfo& in = f->info();
    EXPECT_EQ(in.format, "Photron MRAW");
    EXPECT_EQ(in.data_path, kData + "beam.mraw");
    EXPECT_EQ(in.header_path, kData + "beam.cihx");
    EXPECT_THAT(in.camera, HasSubstr("SA-Z"));
    EXPECT_EQ(in.width, 1024);
    EXPECT_EQ(in.height, 80);
    EXPECT_EQ(in.frame_count, 4);
    EXPECT_DOUBLE_EQ(in.fps, 50000);
    EXPECT_NEAR(in.exposure_s, 5e-6, 1e-15);  // shutterSpeedNsec 5000
    EXPECT_EQ(in.stored_bits, 16);
    EXPECT_FALSE(in.packed);
    EXPECT_EQ(in.effective_bits, 12);
    EXPECT_EQ(in.pixel_format, PixelFormat::Mono12);
    EXPECT_TRUE(in.trigger_known);
    EXPECT_EQ(in.first_frame, 0);
    EXPECT_EQ(in.pixel_size_m, 0);  // calibration without a distance unit
    EXPECT_THAT(in.note, HasSubstr("save step"));

    cv::Mat img;
    ASSERT_TRUE(f->read(0, img).ok());
    ASSERT_EQ(img.type(), CV_16UC1);
    EXPECT_EQ(img.at<std::uint16_t>(0, 0), 76);
    EXPECT_EQ(img.at<std::uint16_t>(0, 1), 83);
    EXPECT_EQ(img.at<std::uint16_t>(40, 512), 2697);
    EXPECT_EQ(cv::sum(img)[0], 62998095.0);
    ASSERT_TRUE(f->read(1, img).ok());
    EXPECT_EQ(img.at<std::uint16_t>(10, 100), 279);
    ASSERT_TRUE(f->read(2, img).ok());
    EXPECT_EQ(img.at<std::uint16_t>(79, 1023), 799);
    ASSERT_TRUE(f->read(3, img).ok());
    EXPECT_EQ(img.at<std::uint16_t>(55, 700), 344);
  }
}

TEST_F(FootageTest, RealPhantomCine) {
  auto f = Footage::open(kData + "cine_781.cine");
  ASSERT_TRUE(f.ok()) << f.error().message;
  const FootageInfo& in = f->info();
  EXPECT_EQ(in.format, "Phantom CINE");
  EXPECT_EQ(in.width, 256);
  EXPECT_EQ(in.height, 256);
  EXPECT_EQ(in.frame_count, 15);
  EXPECT_DOUBLE_EQ(in.fps, 90000);
  EXPECT_NEAR(in.exposure_s, 10e-6, 1e-15);  // ShutterNs 10000
  EXPECT_EQ(in.stored_bits, 16);
  EXPECT_EQ(in.effective_bits, 12);  // RealBPP
  EXPECT_EQ(in.pixel_format, PixelFormat::Mono12);
  EXPECT_TRUE(in.trigger_known);
  EXPECT_EQ(in.first_frame, -5417);           // FirstImageNo
  EXPECT_THAT(in.note, HasSubstr("bFlipV"));  // set in this file, not applied (rows bottom-up)
  EXPECT_NEAR(in.sensor_pixel_m, 1.0 / 35714, 1e-12);
  EXPECT_EQ(in.pixel_size_m, 0);

  cv::Mat img;
  ASSERT_TRUE(f->read(0, img).ok());
  EXPECT_EQ(img.at<std::uint16_t>(0, 0), 2921);
  EXPECT_EQ(img.at<std::uint16_t>(255, 255), 2809);
  EXPECT_EQ(img.at<std::uint16_t>(128, 64), 2900);
  EXPECT_EQ(cv::sum(img)[0], 176860542.0);
  ASSERT_TRUE(f->read(7, img).ok());
  EXPECT_EQ(img.at<std::uint16_t>(100, 200), 2837);
  ASSERT_TRUE(f->read(14, img).ok());
  EXPECT_EQ(img.at<std::uint16_t>(10, 250), 2816);
  EXPECT_EQ(img.at<std::uint16_t>(200, 30), 2878);

  auto fr = f->frame(14);
  ASSERT_TRUE(fr.ok());
  EXPECT_EQ(fr->id, -5403);
  EXPECT_EQ(fr->timestamp_ns, std::llround(-5403 * 1e9 / 90000));
}

TEST_F(FootageTest, LoadsABurstWithTriggerRelativeIdsAndARange) {
  auto all = loadFootage(kData + "cine_781.cine");
  ASSERT_TRUE(all.ok()) << all.error().message;
  EXPECT_EQ(all->frames.size(), 15u);
  EXPECT_EQ(all->format, PixelFormat::Mono12);
  EXPECT_DOUBLE_EQ(all->fps, 90000);
  EXPECT_NEAR(all->exposure_us, 10, 1e-9);
  EXPECT_EQ(all->frames.front().id, -5417);
  EXPECT_EQ(all->frames.back().id, -5403);

  auto part = loadFootage(kData + "cine_781.cine", 1000, {.first_id = -5410, .last_id = -5408});
  ASSERT_TRUE(part.ok()) << part.error().message;
  ASSERT_EQ(part->frames.size(), 3u);
  EXPECT_DOUBLE_EQ(part->fps, 1000);  // the given rate replaces the file's
  EXPECT_EQ(part->frames[0].id, -5410);
  EXPECT_EQ(part->frames[1].timestamp_ns - part->frames[0].timestamp_ns, 1000000);
  EXPECT_TRUE(same(part->frames[0].image, all->frames[7].image));

  auto outside = loadFootage(kData + "cine_781.cine", 0, {.first_id = 0});
  ASSERT_FALSE(outside.ok());
  EXPECT_THAT(outside.error().message, HasSubstr("-5417 to -5403"));

  auto too_big = loadFootage(kData + "beam.mraw", 0, {}, 1000);
  ASSERT_FALSE(too_big.ok());
  EXPECT_THAT(too_big.error().message, HasSubstr("shorter range"));
}

TEST_F(FootageTest, FramesCanBeReadFromSeveralThreads) {
  auto f = Footage::open(kData + "cine_781.cine");
  ASSERT_TRUE(f.ok());
  std::vector<cv::Mat> ref(15);
  for (int i = 0; i < 15; ++i) ASSERT_TRUE(f->read(i, ref[i]).ok());
  std::vector<int> bad(4, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      cv::Mat m;
      for (int k = 0; k < 60; ++k) {
        const int i = (k * 7 + t) % 15;
        if (!f->read(i, m).ok() || !same(m, ref[i])) ++bad[t];
      }
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(bad, std::vector<int>(4, 0));
}

// ---------------------------------------------------------------- round trips

TEST_F(FootageTest, Mraw8BitWithCihRoundTrip) {
  std::vector<cv::Mat> frames;
  std::vector<std::uint8_t> bytes;
  for (int i = 0; i < 3; ++i) {
    frames.push_back(randomImage(6, 10, CV_8UC1, 255, i));
    auto b = mrawFrameBytes(frames.back(), 8);
    bytes.insert(bytes.end(), b.begin(), b.end());
  }
  writeBytes(path("a.mraw"), bytes);
  writeText(path("a.cih"), cihText(10, 6, 8, 3, 20000, "1/40000", -1));
  auto f = Footage::open(path("a.mraw"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->info().header_path, path("a.cih"));
  EXPECT_EQ(f->info().pixel_format, PixelFormat::Mono8);
  EXPECT_DOUBLE_EQ(f->info().fps, 20000);
  EXPECT_DOUBLE_EQ(f->info().exposure_s, 1.0 / 40000);
  EXPECT_EQ(f->info().first_frame, -1);
  EXPECT_EQ(f->info().camera, "FASTCAM test");
  for (int i = 0; i < 3; ++i) {
    auto fr = f->frame(i);
    ASSERT_TRUE(fr.ok());
    EXPECT_TRUE(same(fr->image, frames[i])) << i;
    EXPECT_EQ(fr->id, i - 1);
  }
}

TEST_F(FootageTest, Mraw12BitPackedRoundTrip) {
  // 4 x 7: an odd width, so pixel pairs span rows.
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 4; ++i) frames.push_back(randomImage(4, 7, CV_16UC1, 4095, 10 + i));
  frames[0].at<std::uint16_t>(0, 0) = 4095;  // extremes
  frames[0].at<std::uint16_t>(0, 1) = 0;
  std::vector<std::uint8_t> bytes;
  for (const auto& m : frames) {
    auto b = mrawFrameBytes(m, 12);
    bytes.insert(bytes.end(), b.begin(), b.end());
  }
  ASSERT_EQ(bytes.size(), 4u * 42);  // 1.5 bytes per pixel
  writeBytes(path("b.mraw"), bytes);
  writeText(path("b.cih"), cihText(7, 4, 12, 4, 100000, "0.000002"));
  auto f = Footage::open(path("b.cih"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_TRUE(f->info().packed);
  EXPECT_EQ(f->info().frame_bytes, 42u);
  EXPECT_EQ(f->info().pixel_format, PixelFormat::Mono12);
  EXPECT_DOUBLE_EQ(f->info().exposure_s, 2e-6);
  cv::Mat img;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(f->read(i, img).ok());
    EXPECT_TRUE(same(img, frames[i])) << i;
  }
  // Into a view that is not continuous (a column range of a larger image).
  cv::Mat big(4, 20, CV_16UC1, cv::Scalar(9));
  cv::Mat view = big.colRange(3, 10);
  ASSERT_TRUE(f->read(2, view).ok());
  EXPECT_EQ(view.data, big.data + 6);
  EXPECT_TRUE(same(view, frames[2]));
}

TEST_F(FootageTest, Mraw12BitUnpackingMatchesTheDocumentedLayout) {
  // Bytes ab cd ef hold pixels 0xabc and 0xdef.
  writeBytes(path("c.mraw"), {0xAB, 0xCD, 0xEF, 0x12, 0x34, 0x56});
  writeText(path("c.cih"), cihText(4, 1, 12, 1, 1000));
  auto f = Footage::open(path("c.mraw"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  cv::Mat img;
  ASSERT_TRUE(f->read(0, img).ok());
  EXPECT_EQ(img.at<std::uint16_t>(0, 0), 0xABC);
  EXPECT_EQ(img.at<std::uint16_t>(0, 1), 0xDEF);
  EXPECT_EQ(img.at<std::uint16_t>(0, 2), 0x123);
  EXPECT_EQ(img.at<std::uint16_t>(0, 3), 0x456);
}

TEST_F(FootageTest, Mraw16BitWithDataInTheUpperBitsIsShiftedDown) {
  cv::Mat m = randomImage(3, 4, CV_16UC1, 1023, 3);
  writeBytes(path("d.mraw"), mrawFrameBytes(m, 16, 6));
  writeText(path("d.cih"), cihText(4, 3, 16, 1, 1000, "1/2000", 0, 10, "Higher"));
  auto f = Footage::open(path("d.mraw"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->info().effective_bits, 10);
  cv::Mat img;
  ASSERT_TRUE(f->read(0, img).ok());
  EXPECT_TRUE(same(img, m));
}

TEST_F(FootageTest, CihxCalibrationGivesThePixelSize) {
  cv::Mat m = randomImage(4, 4, CV_8UC1, 255, 5);
  writeBytes(path("e.mraw"), mrawFrameBytes(m, 8));
  writeText(path("e.cihx"), cihxText(4, 4, 8, 1, 5000, 20000, -3, "mm", 0.05));
  auto f = Footage::open(path("e.mraw"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_NEAR(f->info().pixel_size_m, 5e-5, 1e-15);
  EXPECT_NEAR(f->info().exposure_s, 20e-6, 1e-15);
  EXPECT_EQ(f->info().first_frame, -3);
  EXPECT_THAT(describeFootage(f->info()), HasSubstr("0.05 mm (from the file)"));
}

TEST_F(FootageTest, Cine8BitRoundTripIsBottomUp) {
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 3; ++i) frames.push_back(randomImage(8, 16, CV_8UC1, 255, 20 + i));
  CineSpec s;
  s.first_image_no = -2;
  s.fps = 25000;
  s.shutter_ns = 7000;
  writeBytes(path("a.cine"), cineBytes(s, frames));
  auto f = Footage::open(path("a.cine"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->info().pixel_format, PixelFormat::Mono8);
  EXPECT_EQ(f->info().first_frame, -2);
  EXPECT_DOUBLE_EQ(f->info().fps, 25000);
  EXPECT_NEAR(f->info().exposure_s, 7e-6, 1e-15);
  for (int i = 0; i < 3; ++i) {
    auto fr = f->frame(i);
    ASSERT_TRUE(fr.ok());
    EXPECT_TRUE(same(fr->image, frames[i])) << i;
    EXPECT_EQ(fr->id, i - 2);
  }
}

TEST_F(FootageTest, CinePacked10BitRoundTripThroughPhantomsTable) {
  // Points of Phantom's published 10-to-12-bit table.
  const std::uint16_t* lut = detail::phantomLinLut10();
  EXPECT_EQ(lut[0], 2);
  EXPECT_EQ(lut[16], 19);
  EXPECT_EQ(lut[512], 998);
  EXPECT_EQ(lut[1014], 4064);
  EXPECT_EQ(lut[1023], 4095);
  for (int i = 1; i < 1024; ++i) ASSERT_LE(lut[i - 1], lut[i]) << i;

  std::vector<cv::Mat> codes;
  for (int i = 0; i < 2; ++i) codes.push_back(randomImage(6, 12, CV_16UC1, 1023, 30 + i));
  codes[0].at<std::uint16_t>(0, 0) = 1023;
  codes[0].at<std::uint16_t>(5, 11) = 0;
  CineSpec s;
  s.width = 12;
  s.height = 6;
  s.packed10 = true;
  s.real_bpp = 10;
  writeBytes(path("p.cine"), cineBytes(s, codes));
  auto f = Footage::open(path("p.cine"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_TRUE(f->info().packed);
  EXPECT_EQ(f->info().stored_bits, 10);
  EXPECT_EQ(f->info().effective_bits, 12);
  EXPECT_EQ(f->info().pixel_format, PixelFormat::Mono12);
  cv::Mat img;
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(f->read(i, img).ok());
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 12; ++c)
        ASSERT_EQ(img.at<std::uint16_t>(r, c), lut[codes[i].at<std::uint16_t>(r, c)])
            << "frame " << i << " (" << r << ", " << c << ")";  // packed rows are top-down
  }
  EXPECT_EQ(img.at<std::uint16_t>(0, 0), lut[codes[1].at<std::uint16_t>(0, 0)]);
  ASSERT_TRUE(f->read(0, img).ok());
  EXPECT_EQ(img.at<std::uint16_t>(0, 0), 4095);
  EXPECT_EQ(img.at<std::uint16_t>(5, 11), 2);
}

TEST_F(FootageTest, Cine16BitRoundTrip) {
  std::vector<cv::Mat> frames{randomImage(4, 6, CV_16UC1, 65535, 40)};
  CineSpec s;
  s.width = 6;
  s.height = 4;
  s.bit_count = 16;
  s.real_bpp = 16;
  writeBytes(path("w.cine"), cineBytes(s, frames));
  auto f = Footage::open(path("w.cine"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->info().pixel_format, PixelFormat::Mono16);
  cv::Mat img;
  ASSERT_TRUE(f->read(0, img).ok());
  EXPECT_TRUE(same(img, frames[0]));
}

TEST_F(FootageTest, PcoB16ImageAndAFolderOfThem) {
  const cv::Mat a = randomImage(5, 9, CV_16UC1, 4095, 50),
                b = randomImage(5, 9, CV_16UC1, 4095, 51);
  writeBytes(path("img_2.b16"), b16Bytes(b));
  writeBytes(path("img_1.b16"), b16Bytes(a, 512));
  auto f = Footage::open(path("img_1.b16"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->info().format, "pco B16");
  EXPECT_EQ(f->info().frame_count, 1);
  EXPECT_EQ(f->info().fps, 0);
  cv::Mat img;
  ASSERT_TRUE(f->read(0, img).ok());
  EXPECT_TRUE(same(img, a));
  EXPECT_FALSE(loadFootage(path("img_1.b16")).ok());  // no frame rate in the file

  auto burst = loadFrameFolder(dir_.string(), 500);
  ASSERT_TRUE(burst.ok()) << burst.error().message;
  ASSERT_EQ(burst->frames.size(), 2u);
  EXPECT_EQ(burst->format, PixelFormat::Mono12);
  EXPECT_TRUE(same(burst->frames[0].image, a));
  EXPECT_TRUE(same(burst->frames[1].image, b));

  auto cut = b16Bytes(a);
  cut.resize(cut.size() - 1);
  writeBytes(path("img_3.b16"), cut);
  auto g = Footage::open(path("img_3.b16"));
  ASSERT_FALSE(g.ok());
  EXPECT_THAT(g.error().message, HasSubstr("truncated"));
  auto folder = loadFrameFolder(dir_.string(), 500);
  ASSERT_FALSE(folder.ok());
  EXPECT_THAT(folder.error().message, HasSubstr("img_3.b16"));
  cut[0] = 'X';
  writeBytes(path("img_3.b16"), cut);
  EXPECT_THAT(Footage::open(path("img_3.b16")).error().message, HasSubstr("'PCO-'"));
}

// ---------------------------------------------------------------- bad files

std::vector<std::uint8_t> readAllBytes(const std::string& p) {
  std::ifstream is(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(is), {}};
}

TEST_F(FootageTest, MrawWithoutHeaderSaysWhatIsMissing) {
  writeBytes(path("lonely.mraw"), std::vector<std::uint8_t>(64, 0));
  auto f = Footage::open(path("lonely.mraw"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("no header lonely.cihx or .cih next to"));
  EXPECT_THAT(f.error().message, HasSubstr(path("lonely.mraw")));

  writeText(path("nodata.cih"), cihText(4, 4, 8, 1, 1000));
  auto g = Footage::open(path("nodata.cih"));
  ASSERT_FALSE(g.ok());
  EXPECT_THAT(g.error().message, HasSubstr("no nodata.mraw next to"));
}

TEST_F(FootageTest, MrawShorterThanItsHeaderSaysIsTruncated) {
  writeBytes(path("t.mraw"), std::vector<std::uint8_t>(16 * 2 + 5, 0));  // 2 frames and a bit
  writeText(path("t.cih"), cihText(4, 4, 8, 1000000, 1000));
  auto f = Footage::open(path("t.mraw"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("holds 2 complete frames"));
  EXPECT_THAT(f.error().message, HasSubstr("says 1000000"));
  EXPECT_THAT(f.error().message, HasSubstr("truncated"));
}

TEST_F(FootageTest, AbsurdOrMissingHeaderNumbersAreRejectedBeforeAnyAllocation) {
  writeBytes(path("x.mraw"), std::vector<std::uint8_t>(64, 0));
  writeText(path("x.cih"), cihText(60000, 60000, 16, 1, 1000));
  auto f = Footage::open(path("x.mraw"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("60000 x 60000"));

  writeText(path("x.cih"), cihText(4, 4, 10, 1, 1000));
  f = Footage::open(path("x.mraw"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("10-bit MRAW"));

  writeText(path("x.cih"), "just some text\n");
  f = Footage::open(path("x.mraw"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("not a Photron .cih header"));

  writeText(path("x.cih"), "");
  std::filesystem::rename(path("x.cih"), path("x.cihx"));
  writeText(path("x.cihx"), std::string("binary\0\0\0 no xml here", 22));
  f = Footage::open(path("x.mraw"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("no XML"));

  std::string colour = cihxText(4, 4, 8, 1, 1000, 1000, 0);
  colour.replace(colour.find("<type>Mono"), 10, "<type>Color");
  writeText(path("x.cihx"), colour);
  f = Footage::open(path("x.mraw"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("only monochrome"));

  auto bytes = cineBytes({}, {cv::Mat(8, 16, CV_8UC1, cv::Scalar(1))});
  bytes[44 + 4] = 0x60;  // biWidth = 60000 (0xEA60)
  bytes[44 + 5] = 0xEA;
  bytes[44 + 8] = 0x60;
  bytes[44 + 9] = 0xEA;
  writeBytes(path("huge.cine"), bytes);
  auto c = Footage::open(path("huge.cine"));
  ASSERT_FALSE(c.ok());
  EXPECT_THAT(c.error().message, HasSubstr("60000 x 60000 is impossible"));
}

TEST_F(FootageTest, CineWithBadMagicOrTruncatedIsRejected) {
  auto real = readAllBytes(kData + "cine_781.cine");
  ASSERT_EQ(real.size(), 1977140u);

  auto wrong = real;
  wrong[0] = 'X';
  writeBytes(path("magic.cine"), wrong);
  auto f = Footage::open(path("magic.cine"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("does not start with 'CI'"));

  for (std::size_t keep : {std::size_t{20}, std::size_t{5000}, std::size_t{10900},
                           std::size_t{200000}, real.size() - 1}) {
    writeBytes(path("cut.cine"), std::vector<std::uint8_t>(real.begin(), real.begin() + keep));
    auto g = Footage::open(path("cut.cine"));
    ASSERT_FALSE(g.ok()) << keep;
    EXPECT_THAT(g.error().message, HasSubstr(path("cut.cine"))) << keep;
    if (keep >= 10900) {
      EXPECT_THAT(g.error().message, HasSubstr("truncated")) << keep;
    }
  }

  auto many = real;
  many[20] = 0xFF;  // ImageCount = 0xFFFFFF0F: the offset table would run far past the end
  many[21] = 0xFF;
  many[22] = 0xFF;
  writeBytes(path("many.cine"), many);
  f = Footage::open(path("many.cine"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("truncated"));

  writeBytes(path("empty.cine"), {});
  f = Footage::open(path("empty.cine"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("empty"));
}

TEST_F(FootageTest, ColourAndCompressedCineAreRefusedWithAReason) {
  CineSpec s;
  s.cfa = 3;  // Bayer
  writeBytes(path("bayer.cine"), cineBytes(s, {cv::Mat(8, 16, CV_8UC1, cv::Scalar(1))}));
  auto f = Footage::open(path("bayer.cine"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("colour"));

  s = {};
  s.compression = 1;
  writeBytes(path("jpeg.cine"), cineBytes(s, {cv::Mat(8, 16, CV_8UC1, cv::Scalar(1))}));
  f = Footage::open(path("jpeg.cine"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("compression 1"));
}

// Random damage to every header byte must give a value or an error, never a
// crash or an out-of-bounds read (run under ASan to be sure).
TEST_F(FootageTest, RandomlyDamagedFilesNeverCrash) {
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 3; ++i) frames.push_back(randomImage(8, 16, CV_16UC1, 1023, 60 + i));
  CineSpec s;
  s.bit_count = 16;
  s.real_bpp = 12;
  const auto plain = cineBytes(s, frames);
  s.packed10 = true;
  const auto packed = cineBytes(s, frames);
  std::mt19937 rng(7);
  int opened = 0;
  for (int k = 0; k < 1500; ++k) {
    auto bytes = k % 2 ? plain : packed;
    const std::size_t header_end = 84 + 5700 + 8 * 3 + 8;
    for (int m = 0; m < 1 + k % 4; ++m) {
      const std::size_t at = std::uniform_int_distribution<std::size_t>(0, header_end)(rng);
      bytes[at] = static_cast<std::uint8_t>(rng());
    }
    if (k % 7 == 0) bytes.resize(std::uniform_int_distribution<std::size_t>(0, bytes.size())(rng));
    writeBytes(path("fuzz.cine"), bytes);
    auto f = Footage::open(path("fuzz.cine"));
    if (!f.ok()) continue;
    ++opened;
    cv::Mat img;
    for (std::int64_t i = 0; i < std::min<std::int64_t>(f->info().frame_count, 8); ++i)
      (void)f->read(i, img);
  }
  EXPECT_GT(opened, 0);  // most damage lands in unused SETUP bytes

  const std::string cih = cihText(16, 8, 12, 3, 1000);
  writeBytes(path("fuzz.mraw"), std::vector<std::uint8_t>(16 * 8 * 3 * 3 / 2, 0x5A));
  for (int k = 0; k < 500; ++k) {
    std::string text = cih;
    for (int m = 0; m < 3; ++m)
      text[std::uniform_int_distribution<std::size_t>(0, text.size() - 1)(rng)] =
          "0123456789-: x\n"[rng() % 15];
    writeText(path("fuzz.cih"), text);
    auto f = Footage::open(path("fuzz.mraw"));
    if (!f.ok()) continue;
    cv::Mat img;
    for (std::int64_t i = 0; i < f->info().frame_count; ++i) (void)f->read(i, img);
  }
}

TEST_F(FootageTest, OtherFilesAndIndicesAreRefused) {
  EXPECT_TRUE(isFootageFile("a/B.MRAW"));
  EXPECT_TRUE(isFootageFile("x.cihx"));
  EXPECT_TRUE(isFootageFile("x.cine"));
  EXPECT_TRUE(isFootageFile("x.b16"));
  EXPECT_FALSE(isFootageFile("x.avi"));
  auto f = Footage::open(path("missing.cine"));
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("does not exist"));
  writeText(path("x.avi"), "x");
  EXPECT_FALSE(Footage::open(path("x.avi")).ok());

  auto g = Footage::open(kData + "beam.mraw");
  ASSERT_TRUE(g.ok());
  cv::Mat img;
  EXPECT_FALSE(g->read(4, img).ok());
  EXPECT_FALSE(g->read(-1, img).ok());
}

}  // namespace
}  // namespace collide::vision
