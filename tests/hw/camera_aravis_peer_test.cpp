// CameraAravis against Aravis' own peers:
// - the in-process fake camera ("Fake_1"), whose frames we draw through its
//   fill-pattern callback, so every pixel that arrives can be checked;
// - arv-fake-gv-camera-0.8 on 127.0.0.1 (gige_fake.hpp): real GigE Vision
//   control and streaming over loopback, opened by IP address, with its
//   packet-loss knob, and killed mid-burst.
// Plus the Camera conformance suite over both.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "aravis_profile.hpp"
#include "camera_conformance.hpp"
#include "gige_fake.hpp"
#include "hw/camera_aravis.hpp"
#include "hw/clock.hpp"
#include "hw/rig.hpp"
#include "hw/sequencer.hpp"

using namespace collide;
using namespace collide::hw;
using namespace collide::hw::testing;
using collide::vision::Burst;
using collide::vision::FrameStatus;
using collide::vision::PixelFormat;
using ::testing::HasSubstr;

namespace {

constexpr std::int64_t kSecond = 1'000'000'000;
// What one control request to a camera that is gone waits before Aravis gives
// up on it: its GVCP timeout (500 ms) times its retries (5), Aravis' defaults.
constexpr std::int64_t kDeadRequestNs = 5 * 500'000'000LL;

// Waits (up to 30 s: Aravis' heartbeat gives up after 5 s of silence) until
// the camera marks itself lost.
bool waitUntilLost(const Camera& cam) {
  const std::int64_t until = monotonicNowNs() + 30 * kSecond;
  while (!cam.loss() && monotonicNowNs() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  return cam.loss().has_value();
}

// ---- frames we draw into the in-process fake: each encodes its frame id ----

cv::Mat patternFrame(std::uint64_t fid, int width, int height, PixelFormat format) {
  cv::Mat m(height, width, collide::vision::cvType(format));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      if (format == PixelFormat::Mono8)
        m.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(x + 3 * y + 7 * fid);
      else
        m.at<std::uint16_t>(y, x) =
            static_cast<std::uint16_t>((x * 17 + y * 131 + fid * 1009) & 0xFFFF);
    }
  // The id itself in the first pixels, little-endian.
  if (format == PixelFormat::Mono8) {
    m.at<std::uint8_t>(0, 0) = static_cast<std::uint8_t>(fid & 0xFF);
    m.at<std::uint8_t>(0, 1) = static_cast<std::uint8_t>((fid >> 8) & 0xFF);
  } else {
    m.at<std::uint16_t>(0, 0) = static_cast<std::uint16_t>(fid & 0xFFFF);
  }
  return m;
}

std::uint64_t patternId(const cv::Mat& m) {
  if (m.type() == CV_8UC1) return m.at<std::uint8_t>(0, 0) | (m.at<std::uint8_t>(0, 1) << 8);
  return m.at<std::uint16_t>(0, 0);
}

void fillPattern(const FakeFrameRequest& q) {
  const cv::Mat m = patternFrame(q.frame_id, q.width, q.height, q.format);
  std::memcpy(q.data, m.data, m.total() * m.elemSize());
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// The fake GigE camera's own picture (exposure 10 ms, gain 0): a diagonal
// ramp, pixel (x, y) = (x + y + frame id) mod 255.
bool isRamp(const cv::Mat& m) {
  if (m.type() != CV_8UC1) return false;
  const int f0 = m.at<std::uint8_t>(0, 0);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x)
      if (m.at<std::uint8_t>(y, x) != (x + y + f0) % 255) return false;
  return true;
}

CameraConfig config160(PixelFormat format = PixelFormat::Mono8, double fps = 100.0,
                       double exposure_us = 1000.0) {
  return {0, 0, 160, 120, format, fps, exposure_us, 0.0};
}

struct Taken {
  Burst burst;
  std::int64_t trigger_ns = 0;
  // For failure messages: the note, then each frame's id and exposure start
  // in ms from the trigger.
  std::string describe() const {
    std::ostringstream d;
    d << burst.note << "; frames (id@ms):";
    for (const auto& f : burst.frames)
      d << ' ' << f.id << '@' << (f.timestamp_ns - trigger_ns) / 1e6;
    return d.str();
  }
};

// Arms, triggers once the pre-trigger frames can have been exposed (and at
// least `lead_ns` from now), waits generously and takes the burst.
Taken shoot(Camera& cam, int pre, int post, std::int64_t lead_ns = 50'000'000) {
  Taken s;
  EXPECT_TRUE(cam.arm(pre, post));
  // The fakes are software-timed: on a loaded machine they may expose fewer
  // frames than their rate says, so leave extra time for the pre-trigger ring.
  lead_ns = std::max(lead_ns, (pre + 3) * cam.config().framePeriodNs()) + 200'000'000;
  s.trigger_ns = monotonicNowNs() + lead_ns;
  EXPECT_TRUE(cam.trigger(s.trigger_ns));
  const auto done = cam.waitBurst(monotonicNowNs() + 20 * kSecond);
  EXPECT_TRUE(done && *done);
  auto b = cam.takeBurst();
  EXPECT_TRUE(b) << b.error().message;
  if (b) s.burst = std::move(b).value();
  return s;
}

void bringUp(Camera& cam, const CameraConfig& c) {
  auto s = cam.open();
  ASSERT_TRUE(s) << s.error().message;
  s = cam.configure(c);
  ASSERT_TRUE(s) << s.error().message;
  s = cam.start();
  ASSERT_TRUE(s) << s.error().message;
}

// ---- conformance benches ----------------------------------------------------

CameraBench inProcessBench() {
  // Software-timed fake: frame spacing jitters with the machine's load.
  CameraBench b{nullptr,     std::make_unique<CameraAravis>("Fake_1", CameraAravisSettings{}),
                config160(), false,
                200'000'000, {}};
  b.no_unplug_reason =
      "Aravis' in-process fake camera cannot be taken away; the GigE simulator can (aravis_gige)";
  return b;
}

CameraBench gigeBench() {
  auto fake = std::make_shared<GigeFake>();
  if (!fake->ok()) return {nullptr, nullptr, {}, false, 0, fake->reason()};
  CameraBench b{
      fake,        std::make_unique<CameraAravis>(GigeFake::kAddress, CameraAravisSettings{}),
      config160(), false,
      200'000'000, {}};
  b.unplug = [f = fake.get()] { f->kill(); };  // SIGKILL: gone without a word
  return b;
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(Aravis, CameraConformance,
                         ::testing::Values(CameraBackend{"aravis_fake", &inProcessBench},
                                           CameraBackend{"aravis_gige", &gigeBench}),
                         [](const auto& info) { return info.param.name; });

// ---- the in-process fake ------------------------------------------------------

class InProcessFake : public ::testing::TestWithParam<PixelFormat> {};

TEST_P(InProcessFake, FramesArriveBitExactAndInOrder) {
  CameraAravis cam("Fake_1", {});
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.setFakeFill(&fillPattern));
  const CameraConfig c = config160(GetParam());
  ASSERT_TRUE(cam.configure(c));
  ASSERT_TRUE(cam.start());
  const Taken s = shoot(cam, 10, 30);
  const Burst& b = s.burst;
  ASSERT_TRUE(b.complete) << b.note;
  ASSERT_EQ(b.frames.size(), 40u) << b.note;
  EXPECT_EQ(b.stats.completed, 40u);
  EXPECT_EQ(b.stats.failed, 0u);
  EXPECT_EQ(b.stats.dropped, 0u);
  EXPECT_EQ(b.stats.underruns, 0u);
  for (std::size_t i = 0; i < b.frames.size(); ++i) {
    const auto& f = b.frames[i];
    ASSERT_TRUE(f.good()) << "frame " << f.id;
    EXPECT_EQ(f.id, static_cast<std::int64_t>(i) - 10);
    const std::uint64_t fid = patternId(f.image);
    EXPECT_TRUE(identical(f.image, patternFrame(fid, c.width, c.height, c.format)))
        << "frame " << f.id << " (fake frame " << fid << ") differs from what was drawn";
    if (i > 0) {
      // Consecutive burst ids are consecutive camera frames (16-bit ids wrap).
      const std::uint64_t previous = patternId(b.frames[i - 1].image);
      EXPECT_EQ(CameraAravis::unwrapFrameId(previous, 0, fid), 1u) << "frame " << f.id;
      EXPECT_GT(f.timestamp_ns, b.frames[i - 1].timestamp_ns);
    }
  }
  EXPECT_GE(b.frames[10].timestamp_ns, s.trigger_ns);
  EXPECT_LT(b.frames[9].timestamp_ns, s.trigger_ns);
  const AravisCounters n = cam.counters();
  EXPECT_GE(n.frames_good, 40u);
  EXPECT_EQ(n.frames_failed, 0u);
  EXPECT_EQ(n.frames_missing, 0u);
  EXPECT_EQ(n.bytes_good,
            n.frames_good * c.width * c.height * (c.format == PixelFormat::Mono8 ? 1 : 2));
  ASSERT_TRUE(cam.close());
}

INSTANTIATE_TEST_SUITE_P(Formats, InProcessFake,
                         ::testing::Values(PixelFormat::Mono8, PixelFormat::Mono16),
                         [](const auto& info) { return collide::vision::toString(info.param); });

TEST(CameraAravisFake, LiveViewPublishesFramesWhetherArmedOrNot) {
  CameraAravis cam("Fake_1", {});
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.setFakeFill(&fillPattern));
  ASSERT_TRUE(cam.configure(config160()));
  ASSERT_TRUE(cam.start());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(cam.publishedFrames(), 0u);  // nobody watches: nothing published
  cam.setLiveView(true);
  const std::int64_t deadline = monotonicNowNs() + 5 * kSecond;
  while (cam.publishedFrames() < 5 && monotonicNowNs() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GE(cam.publishedFrames(), 5u);
  const auto latest = cam.latestFrame();
  ASSERT_TRUE(latest);
  ASSERT_TRUE(latest->good());
  EXPECT_TRUE(identical(latest->image,
                        patternFrame(patternId(latest->image), 160, 120, PixelFormat::Mono8)));
  cam.setLiveView(false);
}

TEST(CameraAravisFake, RefusesMono12WhichTheFakeCannotDeliver) {
  CameraAravis cam("Fake_1", {});
  ASSERT_TRUE(cam.open());
  const auto formats = cam.info().formats;
  EXPECT_THAT(formats, ::testing::ElementsAre(PixelFormat::Mono8, PixelFormat::Mono16));
  auto s = cam.configure(config160(PixelFormat::Mono12));
  ASSERT_FALSE(s);
  EXPECT_THAT(s.error().message, HasSubstr("cannot deliver Mono12: check camera.format"));
}

TEST(CameraAravisFake, LineTriggerTakesAFramePerPulse) {
  CameraAravisSettings settings;
  settings.trigger = AravisTrigger::Line;
  CameraAravis cam("Fake_1", settings);
  // The fake's line pulses 25 times a second; camera.fps names that rate.
  bringUp(cam, config160(PixelFormat::Mono8, 25.0, 1000.0));
  auto mode = cam.feature("TriggerMode");
  ASSERT_TRUE(mode);
  EXPECT_EQ(*mode, "On");
  EXPECT_EQ(*cam.feature("TriggerSource"), "Line0");
  const Taken s = shoot(cam, 2, 4, 100'000'000);
  ASSERT_TRUE(s.burst.complete) << s.burst.note;
  EXPECT_EQ(s.burst.frames.size(), 6u) << s.burst.note;
}

TEST(CameraAravisFake, FreeRunSwitchesTriggeringOff) {
  CameraAravis cam("Fake_1", {});
  bringUp(cam, config160());
  EXPECT_EQ(*cam.feature("TriggerMode"), "Off");
  EXPECT_EQ(*cam.feature("PixelFormat"), "Mono8");
  EXPECT_EQ(*cam.feature("Width"), "160");
  EXPECT_EQ(*cam.feature("ExposureTimeAbs"), "1000");
  EXPECT_EQ(*cam.feature("AcquisitionFrameRate"), "100");
}

TEST(CameraAravisFake, ProfileFeaturesAreAppliedThroughTheRig) {
  const std::string text =
      aravisProfileText(aravisCameraLines("Fake_1"),
                        {"BinningHorizontal = 2", "GainAuto = \"Off\"", "TestBoolean = true"});
  auto profile = parseRigProfile(text, "lab.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  auto rig = makeRig(*profile);
  ASSERT_TRUE(rig) << rig.error().message;
  auto s = bringUp(*rig);
  ASSERT_TRUE(s) << s.error().message;
  auto& cam = dynamic_cast<CameraAravis&>(*rig->camera);
  EXPECT_EQ(*cam.feature("BinningHorizontal"), "2");
  EXPECT_EQ(*cam.feature("GainAuto"), "Off");
  EXPECT_EQ(*cam.feature("TestBoolean"), "true");
  EXPECT_EQ(*cam.feature("Width"), "160");
  EXPECT_TRUE(shutDown(*rig));
}

TEST(CameraAravisFake, ProfileFeatureErrorsNameTheLineAndTheProblem) {
  auto errorFor = [](const std::string& feature_line) {
    const std::string text = aravisProfileText(aravisCameraLines("Fake_1"), {feature_line});
    auto profile = parseRigProfile(text, "lab.toml");
    if (!profile) return profile.error().message;
    auto rig = makeRig(*profile);
    if (!rig) return rig.error().message;
    Status s = rig->camera->open();
    if (s) s = rig->camera->configure(profile->camera_config);
    return s ? std::string("(accepted)") : s.error().message;
  };
  EXPECT_THAT(errorFor("NoSuchFeature = 1"),
              HasSubstr("camera.features.NoSuchFeature = 1: the camera has no feature"));
  EXPECT_THAT(errorFor("BinningHorizontal = 40"),
              HasSubstr("camera.features.BinningHorizontal = 40: the camera refused it"));
  EXPECT_THAT(errorFor("GainAuto = 3"), HasSubstr("takes a name in quotes"));
  EXPECT_THAT(errorFor("AcquisitionStart = true"), HasSubstr("is a command"));
  EXPECT_THAT(errorFor("GainAuto = \"Sometimes\""),
              HasSubstr("camera.features.GainAuto = \"Sometimes\": the camera refused it"));
  EXPECT_THAT(errorFor("BinningHorizontal = 40"), HasSubstr("lab.toml:"));
}

TEST(CameraAravisFake, ConfigureRefusesWhatTheFakeCannotDo) {
  CameraAravis cam("Fake_1", {});
  ASSERT_TRUE(cam.open());
  // The fake exposes at least 10 us.
  auto s = cam.configure(config160(PixelFormat::Mono8, 100.0, 5.0));
  ASSERT_FALSE(s);
  EXPECT_THAT(s.error().message, HasSubstr("exposure 5 us is outside the camera's 10.."));
  // A GigE setting on a camera that is not GigE.
  CameraAravisSettings gige;
  gige.packet_size_bytes = 1500;
  CameraAravis other("Fake_1", gige);
  ASSERT_TRUE(other.open());
  s = other.configure(config160());
  ASSERT_FALSE(s);
  EXPECT_THAT(s.error().message, HasSubstr("apply to GigE Vision cameras only"));
}

TEST(CameraAravisFake, AnUnknownCameraIsNotFoundWithAHint) {
  CameraAravis cam("Collide-NoSuchCamera-42", {});
  auto s = cam.open();
  ASSERT_FALSE(s);
  EXPECT_THAT(s.error().message, HasSubstr("camera \"Collide-NoSuchCamera-42\": cannot open"));
  EXPECT_THAT(s.error().message, HasSubstr("check camera.device"));
  EXPECT_EQ(cam.state(), DeviceState::Closed);
}

// ---- GigE Vision over loopback ------------------------------------------------

class GigeLoopback : public ::testing::Test {
 protected:
  void start(const std::vector<std::string>& args = {}) {
    fake_ = std::make_unique<GigeFake>(args);
    if (!fake_->ok()) GTEST_SKIP() << fake_->reason();
  }
  std::unique_ptr<GigeFake> fake_;
};

TEST_F(GigeLoopback, OpensByAddressAndStreamsTheCamerasPictureBitExact) {
  start();
  CameraAravisSettings settings;
  settings.packet_size_bytes = 1500;
  settings.packet_delay_ns = 800;
  CameraAravis cam(GigeFake::kAddress, settings);
  // 10 ms exposure and no gain: the fake's ramp is then exactly (x + y + id) mod 255.
  bringUp(cam, config160(PixelFormat::Mono8, 50.0, 10000.0));
  EXPECT_EQ(*cam.feature("DeviceID"), fake_->serial());
  EXPECT_EQ(*cam.feature("ArvGevSCPSPacketSize"), "1500");
  EXPECT_EQ(*cam.feature("ArvGevSCPD"), "800");  // ticks of the fake's 1 GHz clock
  const Taken s = shoot(cam, 5, 20);
  const Burst& b = s.burst;
  ASSERT_TRUE(b.complete) << b.note;
  ASSERT_EQ(b.frames.size(), 25u) << b.note;
  EXPECT_EQ(b.stats.failed, 0u);
  EXPECT_EQ(b.stats.dropped, 0u);
  EXPECT_EQ(b.stats.missing_packets, 0u);
  for (std::size_t i = 0; i < b.frames.size(); ++i) {
    const auto& f = b.frames[i];
    ASSERT_TRUE(f.good()) << "frame " << f.id;
    EXPECT_TRUE(isRamp(f.image)) << "frame " << f.id << " is not the fake's picture";
    if (i > 0) {  // the ramp moves by one grey level per camera frame
      const int step =
          (f.image.at<std::uint8_t>(0, 0) - b.frames[i - 1].image.at<std::uint8_t>(0, 0) + 255) %
          255;
      EXPECT_EQ(step, 1) << "frame " << f.id;
    }
  }
  ASSERT_TRUE(cam.close());
}

TEST_F(GigeLoopback, GigeSettingsTheCameraCannotTakeAreRefusedNamingTheField) {
  start();
  CameraAravisSettings settings;
  settings.packet_delay_ns = 2000;  // the fake allows at most 1000 ticks of 1 ns
  CameraAravis cam(GigeFake::kAddress, settings);
  ASSERT_TRUE(cam.open());
  const auto s = cam.configure(config160());
  ASSERT_FALSE(s);
  EXPECT_THAT(s.error().message, HasSubstr("did not take inter-packet delay 2000 ns"));
  EXPECT_THAT(s.error().message, HasSubstr("check camera.packet_delay_ns"));
  EXPECT_EQ(cam.state(), DeviceState::Open);
}

TEST_F(GigeLoopback, StreamsMono16) {
  start();
  CameraAravis cam(GigeFake::kAddress, {});
  bringUp(cam, config160(PixelFormat::Mono16, 100.0, 1000.0));
  const Taken s = shoot(cam, 3, 10);
  ASSERT_TRUE(s.burst.complete) << s.burst.note;
  ASSERT_EQ(s.burst.frames.size(), 13u) << s.describe();
  for (const auto& f : s.burst.frames) {
    ASSERT_TRUE(f.good());
    EXPECT_EQ(f.image.type(), CV_16UC1);
    EXPECT_EQ(f.image.cols, 160);
    EXPECT_EQ(f.image.rows, 120);
  }
  EXPECT_EQ(s.burst.format, PixelFormat::Mono16);
}

TEST_F(GigeLoopback, StreamsMono12WhenTheCameraOffersIt) {
  // The stock fake has no Mono12: serve its own description with a Mono12
  // entry added (the pixel-format register takes any value).
  start();
  std::string xml;
  {
    CameraAravis probe(GigeFake::kAddress, {});
    ASSERT_TRUE(probe.open());
    auto x = probe.genicamXml();
    ASSERT_TRUE(x) << x.error().message;
    xml = *x;
  }
  const auto at = xml.find("<EnumEntry Name=\"Mono16\"");
  ASSERT_NE(at, std::string::npos);
  xml.insert(
      at,
      "<EnumEntry Name=\"Mono12\" NameSpace=\"Standard\"><Value>17825797</Value></EnumEntry>\n");
  const auto path = std::filesystem::temp_directory_path() /
                    ("collide-fake-mono12-" + std::to_string(::getpid()) + ".xml");
  std::ofstream(path) << xml;
  fake_.reset();
  start({"-g", path.string()});
  CameraAravis cam(GigeFake::kAddress, {});
  ASSERT_TRUE(cam.open());
  EXPECT_THAT(cam.info().formats, ::testing::Contains(PixelFormat::Mono12));
  ASSERT_TRUE(cam.configure(config160(PixelFormat::Mono12, 100.0, 1000.0)));
  ASSERT_TRUE(cam.start());
  EXPECT_EQ(*cam.feature("PixelFormat"), "Mono12");
  const Taken s = shoot(cam, 3, 10);
  std::filesystem::remove(path);
  ASSERT_TRUE(s.burst.complete) << s.burst.note;
  ASSERT_EQ(s.burst.frames.size(), 13u) << s.describe();
  for (const auto& f : s.burst.frames) {
    ASSERT_TRUE(f.good());
    EXPECT_EQ(f.image.type(), CV_16UC1);
  }
  EXPECT_EQ(s.burst.format, PixelFormat::Mono12);
}

TEST_F(GigeLoopback, LostPacketsMakeFailedFramesThatAreCountedAndNeverGood) {
  start({"-r", "10"});  // the fake drops 1 % of its packets and never resends
  CameraAravisSettings settings;
  settings.packet_size_bytes = 1500;  // ~16 packets a frame: ~15 % of frames hit
  CameraAravis cam(GigeFake::kAddress, settings);
  bringUp(cam, config160(PixelFormat::Mono8, 50.0, 10000.0));
  const Taken s = shoot(cam, 5, 40);
  const Burst& b = s.burst;
  ASSERT_TRUE(b.complete) << b.note;
  EXPECT_GT(b.stats.failed, 0u);
  EXPECT_GT(b.stats.missing_packets, 0u);
  EXPECT_EQ(b.stats.completed + b.stats.failed + b.stats.dropped, 45u);
  EXPECT_THAT(b.note, HasSubstr(std::to_string(b.stats.failed) + " frames failed"));
  EXPECT_THAT(b.note, HasSubstr("packets missing"));
  std::uint64_t good = 0, bad = 0;
  for (const auto& f : b.frames) {
    if (f.good()) {
      ++good;
      EXPECT_TRUE(isRamp(f.image)) << "frame " << f.id << " handed on as good but damaged";
    } else {
      ++bad;
      EXPECT_TRUE(f.status == FrameStatus::Incomplete || f.status == FrameStatus::Failed);
      EXPECT_TRUE(f.image.empty()) << "frame " << f.id;
    }
  }
  EXPECT_EQ(good, b.stats.completed);
  EXPECT_EQ(bad, b.stats.failed);
  EXPECT_GE(cam.counters().frames_failed, b.stats.failed);
}

TEST_F(GigeLoopback, ACameraKilledMidBurstLeavesAnIncompleteBurstWithWhatArrived) {
  start();
  CameraAravis cam(GigeFake::kAddress, {});
  bringUp(cam, config160(PixelFormat::Mono8, 100.0, 1000.0));
  ASSERT_TRUE(cam.arm(5, 100000));
  ASSERT_TRUE(cam.trigger(monotonicNowNs() + 20'000'000));
  // Let frames flow, then pull the plug.
  (void)cam.waitBurst(monotonicNowNs() + 400'000'000);
  fake_->kill();
  const auto ended = cam.waitBurst(monotonicNowNs() + 30 * kSecond);
  ASSERT_TRUE(ended);
  EXPECT_TRUE(*ended) << "the burst never learned that the camera was gone";
  auto b = cam.takeBurst();
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_FALSE(b->complete);
  EXPECT_GT(b->frames.size(), 10u);
  // Good frames up to the end; the frame in flight when the camera died may
  // have arrived incomplete: marked, without an image.
  int bad = 0;
  for (const auto& f : b->frames) {
    if (f.good()) continue;
    ++bad;
    EXPECT_TRUE(f.image.empty()) << "frame " << f.id;
    EXPECT_EQ(f.id, b->frames.back().id) << "only the last frame may be incomplete";
  }
  EXPECT_LE(bad, 1);
  // The camera's lifecycle is lost, and the burst ended with the same sentence.
  ASSERT_TRUE(cam.loss()) << "the camera did not mark itself lost";
  const std::string lost = lostMessage(*cam.loss());
  EXPECT_THAT(lost, ::testing::StartsWith("camera \"127.0.0.1\" is lost ("));
  EXPECT_THAT(lost, HasSubstr("retrying will not help"));
  EXPECT_THAT(lost, HasSubstr("check its power and cable, the network link (ping 127.0.0.1)"));
  EXPECT_THAT(b->note, HasSubstr(lost));
  EXPECT_THAT(b->note, HasSubstr("post-trigger frames arrived"));
  // The next shot's arm() is refused at once, with that sentence.
  std::int64_t t0 = monotonicNowNs();
  const auto armed = cam.arm(5, 10);
  ASSERT_FALSE(armed);
  EXPECT_EQ(armed.error().message, lost);
  EXPECT_FALSE(cam.trigger(monotonicNowNs()));
  // Stopping a lost camera still works, without waiting on it: Aravis closes
  // the stream channel with requests the dead camera never answers, which
  // happens in the background (they took 5 s inline). Starting it again is
  // refused without asking it (one request to it would wait kDeadRequestNs).
  t0 = monotonicNowNs();
  EXPECT_TRUE(cam.stop());
  const std::int64_t stopped_after = monotonicNowNs() - t0;
  EXPECT_LT(stopped_after, kDeadRequestNs / 2) << "stop() waited on the lost camera";
  t0 = monotonicNowNs();
  const auto restart = cam.start();
  const std::int64_t refused_after = monotonicNowNs() - t0;
  ASSERT_FALSE(restart);
  EXPECT_EQ(restart.error().message, lost);
  EXPECT_LT(refused_after, kDeadRequestNs / 2) << "start() asked the lost camera";
  // Closing it does not wait either (Aravis' release of control, 2.5 s inline).
  t0 = monotonicNowNs();
  (void)cam.close();
  const std::int64_t closed_after = monotonicNowNs() - t0;
  EXPECT_EQ(cam.state(), DeviceState::Closed);
  EXPECT_LT(closed_after, kDeadRequestNs / 2) << "close() waited on the lost camera";
  std::printf("lost camera: stop() %.1f ms, close() %.1f ms\n", stopped_after * 1e-6,
              closed_after * 1e-6);
  // Opening it again first lets the old one go (the camera is still gone).
  t0 = monotonicNowNs();
  EXPECT_FALSE(cam.open());
  std::printf("open() of the gone camera failed after %.1f s\n", (monotonicNowNs() - t0) * 1e-9);
}

TEST_F(GigeLoopback, ACameraKilledBetweenShotsIsLostAndTheNextStartIsRefusedAtOnce) {
  start();
  CameraAravis cam(GigeFake::kAddress, {});
  bringUp(cam, config160(PixelFormat::Mono8, 100.0, 1000.0));
  const Taken s = shoot(cam, 2, 5);
  ASSERT_TRUE(s.burst.complete) << s.burst.note;
  ASSERT_TRUE(cam.stop());  // between shots, as the sequencer leaves it
  EXPECT_FALSE(cam.loss());
  fake_->kill();
  const std::int64_t killed = monotonicNowNs();
  // Nobody asks the camera anything: its control link's heartbeat finds it gone.
  ASSERT_TRUE(waitUntilLost(cam)) << "the camera never noticed it was gone";
  const double noticed_s = (monotonicNowNs() - killed) * 1e-9;
  const std::string lost = lostMessage(*cam.loss());
  std::printf("the user reads: %s\n", lost.c_str());
  EXPECT_THAT(lost, HasSubstr("heartbeat"));
  EXPECT_THAT(lost, HasSubstr("retrying will not help"));
  const std::int64_t t0 = monotonicNowNs();
  const auto restart = cam.start();
  const std::int64_t refused_after = monotonicNowNs() - t0;
  ASSERT_FALSE(restart);
  EXPECT_EQ(restart.error().message, lost);
  EXPECT_LT(refused_after, kDeadRequestNs / 2) << "start() asked the lost camera";
  std::printf("lost %.1f s after the kill; start() refused in %.3f ms\n", noticed_s,
              refused_after * 1e-6);
  const auto configured = cam.configure(config160());
  ASSERT_FALSE(configured);
  EXPECT_EQ(configured.error().message, lost);
  EXPECT_EQ(cam.state(), DeviceState::Configured);
  // Reopening is how it is looked for again: with the camera still gone it
  // fails, saying so.
  ASSERT_TRUE(cam.close());
  EXPECT_FALSE(cam.open());
}

TEST_F(GigeLoopback, ACameraThatDiesJustBeforeStartIsLostByItsFirstUnansweredRequest) {
  start();
  CameraAravis cam(GigeFake::kAddress, {});
  bringUp(cam, config160(PixelFormat::Mono8, 100.0, 1000.0));
  ASSERT_TRUE(cam.stop());
  fake_->kill();
  // start() asks the camera before the heartbeat (5 s) can notice: that one
  // request waits out its timeout, and the camera is lost from then on.
  const auto first = cam.start();
  ASSERT_FALSE(first);
  ASSERT_TRUE(cam.loss()) << first.error().message;
  const std::string lost = lostMessage(*cam.loss());
  std::printf("the user reads: %s\n", first.error().message.c_str());
  EXPECT_EQ(first.error().message, lost);
  EXPECT_THAT(lost, HasSubstr("retrying will not help"));
  const std::int64_t t0 = monotonicNowNs();
  const auto again = cam.start();
  const std::int64_t refused_after = monotonicNowNs() - t0;
  ASSERT_FALSE(again);
  EXPECT_EQ(again.error().message, lost);
  EXPECT_LT(refused_after, kDeadRequestNs / 2) << "the second start() asked the lost camera";
  (void)cam.close();
}

TEST_F(GigeLoopback, SoftwareTriggersPaceTheFrames) {
  start();
  CameraAravisSettings settings;
  settings.trigger = AravisTrigger::Software;
  CameraAravis cam(GigeFake::kAddress, settings);
  // The fake looks for a software trigger 25 times a second: trigger slower.
  bringUp(cam, config160(PixelFormat::Mono8, 10.0, 1000.0));
  EXPECT_EQ(*cam.feature("TriggerSource"), "Software");
  const Taken s = shoot(cam, 2, 4, 150'000'000);
  ASSERT_TRUE(s.burst.complete) << s.burst.note;
  ASSERT_EQ(s.burst.frames.size(), 6u) << s.burst.note;
  // One frame per trigger, 100 ms apart on average (the fake answers a trigger
  // at its next 40 ms poll; free running it would send a frame every 40 ms).
  const auto& f = s.burst.frames;
  const double mean_gap_ms =
      (f.back().timestamp_ns - f.front().timestamp_ns) / 1e6 / (f.size() - 1);
  EXPECT_GT(mean_gap_ms, 80.0) << s.describe();
  EXPECT_LT(mean_gap_ms, 120.0) << s.describe();
  EXPECT_EQ(s.burst.stats.dropped, 0u);
}

TEST_F(GigeLoopback, ACameraLostWhileWaitingForLinePulsesIsNoticed) {
  start();
  CameraAravisSettings settings;
  settings.trigger = AravisTrigger::Line;  // the fake pulses its line 25 times a second
  settings.stall_timeout_ms = 300;
  CameraAravis cam(GigeFake::kAddress, settings);
  bringUp(cam, config160(PixelFormat::Mono8, 25.0, 1000.0));
  ASSERT_TRUE(cam.arm(2, 100000));
  ASSERT_TRUE(cam.trigger(monotonicNowNs() + 200'000'000));
  (void)cam.waitBurst(monotonicNowNs() + 500'000'000);  // some frames arrive
  fake_->kill();
  const auto ended = cam.waitBurst(monotonicNowNs() + 30 * kSecond);
  ASSERT_TRUE(ended);
  EXPECT_TRUE(*ended) << "the burst never learned that the camera was gone";
  auto b = cam.takeBurst();
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_FALSE(b->complete);
  EXPECT_THAT(b->note, HasSubstr("is lost"));
  EXPECT_THAT(b->note, HasSubstr("no longer answers"));
  ASSERT_TRUE(cam.loss());
  EXPECT_EQ(cam.arm(2, 10).error().message, lostMessage(*cam.loss()));
  (void)cam.close();
}

TEST_F(GigeLoopback, ACameraLostDuringAShotFailsItSayingWhyAndKeepsTheFrames) {
  start();
  // The simulated rig with its camera on the GigE simulator; a long burst
  // (1 s of post-trigger frames) so the camera can be pulled during it.
  auto lines = aravisCameraLines(GigeFake::kAddress);
  lines[2] = "roi = [0, 0, 640, 480]";  // sim.toml's field of view
  std::string text = aravisProfileText(lines);
  text = withKey(text, "burst", "pre_trigger_frames", "5");
  text = withKey(text, "burst", "post_trigger_frames", "100");
  auto profile = parseRigProfile(text, "lab.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  auto rig = makeRig(*profile);
  ASSERT_TRUE(rig) << rig.error().message;
  Sequencer sequencer(*rig);
  std::thread puller;
  const Shot shot = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0), [&](const StepStamp& step) {
    // Frames are flowing into the burst: pull the plug once a quarter of it
    // has come in, well past frame 0 (the predicted contact, about 7 frames
    // after arming here) and far from its end. Counted, not timed: 150 ms
    // after "fired" once held no post-trigger frame on a loaded machine
    // (the sanitizer pass).
    if (step.name == "fired")
      puller = std::thread([this, &rig] {
        const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        while (rig->camera->burstArrivals() < 5 + 100 / 4 &&
               std::chrono::steady_clock::now() < give_up)
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
        fake_->kill();
      });
  });
  if (puller.joinable()) puller.join();
  (void)shutDown(*rig);
  ASSERT_EQ(shot.status, ShotStatus::Failed);
  std::printf("the user reads: %s\n", shot.failure_reason.c_str());
  EXPECT_THAT(shot.failure_reason, ::testing::StartsWith("camera \"127.0.0.1\" is lost ("));
  EXPECT_THAT(shot.failure_reason, HasSubstr("retrying will not help"));
  EXPECT_THAT(shot.failure_reason, HasSubstr("check its power and cable"));
  EXPECT_FALSE(shot.burst.complete);
  EXPECT_GT(shot.burst.frames.size(), 5u) << "the frames that arrived are kept";
  EXPECT_THAT(shot.burst.note, HasSubstr("post-trigger frames arrived"));
  ASSERT_TRUE(rig->camera->loss());

  // The next shot is refused before anything is asked of any device, long
  // before a wait on the camera (the collect window, or one dead request)
  // could have ended.
  const std::int64_t t0 = monotonicNowNs();
  const Shot next = sequencer.fire(ShotRequest::atSpeeds(2.0, 2.0));
  const std::int64_t refused_after = monotonicNowNs() - t0;
  ASSERT_EQ(next.status, ShotStatus::Failed);
  EXPECT_THAT(next.failure_reason, ::testing::StartsWith("refused: camera \"127.0.0.1\" is lost"));
  ASSERT_FALSE(next.steps.empty());
  EXPECT_EQ(next.steps.back().name, "refused");
  EXPECT_LT(refused_after, kDeadRequestNs / 2);
}
