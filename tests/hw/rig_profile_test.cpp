#include "hw/rig_profile.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "profile_text.hpp"

using namespace collide::hw;
using collide::hw::testing::lineOf;
using collide::hw::testing::readFile;
using collide::hw::testing::simProfileText;
using collide::hw::testing::withKey;
using collide::hw::testing::withoutKey;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

const std::string kSource = "config/sim.toml";

// The error message for `text`, or a failure if it parses.
std::string errorFor(const std::string& text) {
  const auto r = parseRigProfile(text, kSource);
  if (r.ok()) return "(parsed without error)";
  return r.error().message;
}

std::string at(const std::string& text, const std::string& section, const std::string& key,
               int occurrence = 1) {
  return kSource + ":" + std::to_string(lineOf(text, section, key, occurrence)) + ": ";
}

}  // namespace

TEST(RigProfile, SimProfileParsesWithTheValuesWrittenInIt) {
  const auto r = parseRigProfile(simProfileText(), kSource);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const RigProfile& p = *r;
  EXPECT_EQ(p.name, "sim");
  EXPECT_EQ(p.source, kSource);
  EXPECT_EQ(p.text, simProfileText());
  EXPECT_EQ(p.camera.backend, "sim");
  EXPECT_EQ(p.camera.device, "sim-camera");
  EXPECT_EQ(p.camera_config.width, 640);
  EXPECT_EQ(p.camera_config.height, 480);
  EXPECT_EQ(p.camera_config.format, collide::vision::PixelFormat::Mono8);
  EXPECT_DOUBLE_EQ(p.camera_config.fps, 1000.0);
  EXPECT_DOUBLE_EQ(p.camera_config.exposure_us, 200.0);
  EXPECT_EQ(p.regulator.backend, "sim");
  EXPECT_EQ(p.valves.backend, "sim");
  EXPECT_EQ(p.burst.pre_trigger_frames, 30);
  EXPECT_EQ(p.burst.post_trigger_frames, 40);
  EXPECT_DOUBLE_EQ(p.geometry.origin_u_px, 319.5);
  EXPECT_FALSE(p.geometry.meet_point_m.has_value());
  EXPECT_EQ(p.launchers[0].name, "left");
  EXPECT_EQ(p.launchers[1].valve, 1);
  EXPECT_TRUE(p.launchers[1].direction.isApprox(collide::Vec3(-1, 0, 0)));
  EXPECT_DOUBLE_EQ(p.launchers[0].exit_m.x(), -0.085);
  EXPECT_FALSE(p.launchers[0].slide_travel_m.has_value());
  ASSERT_TRUE(p.launchers[1].slide_travel_m.has_value());
  EXPECT_DOUBLE_EQ((*p.launchers[1].slide_travel_m)[0], -0.04);
  EXPECT_DOUBLE_EQ((*p.launchers[1].slide_travel_m)[1], 0.04);
  EXPECT_EQ(p.spheres.material_name, "nylon-6/6");
  EXPECT_DOUBLE_EQ(p.spheres.diameter_m[1], 0.0254);
  EXPECT_DOUBLE_EQ(p.spheres.material.beta0, 0.44);
  EXPECT_EQ(p.calibration.coefficients, (std::array<double, 4>{0.143, 6.6, -5.0, 3.38}));
  EXPECT_DOUBLE_EQ(p.calibration.exit_delay_s, 0.008);
  EXPECT_DOUBLE_EQ(p.sequencer.settle_hold_s, 0.005);
  EXPECT_EQ(p.sequencer.pulse_us, 15000);
  EXPECT_TRUE(p.safety.vent_on_failure);
  // The regulator's limit is capped by the safety limit.
  EXPECT_DOUBLE_EQ(p.regulator_config.max_kPa, 200.0);
  EXPECT_EQ(p.valve_config.max_pulse_us, 50000);
  EXPECT_EQ(p.simulation.seed, 1u);
  EXPECT_EQ(p.simulation.restitution, RestitutionLaw::Constant);
  // The backend keeps its own settings for later.
  EXPECT_TRUE(p.camera.table.has("noise_grey"));
}

TEST(RigProfile, SimProfileShowsASphereAbout120PixelsAcross) {
  const auto p = parseRigProfile(simProfileText(), kSource);
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_NEAR(p->spheres.diameter_m[0] / p->geometry.pixel_size_m, 120.0, 1.0);
}

TEST(RigProfile, ThesisProfileIsSmallWithSpheres37PixelsAcross) {
  const std::string path = std::string(COLLIDE_SOURCE_DIR) + "/config/sim-thesis.toml";
  const auto p = loadRigProfile(path);
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_EQ(p->name, "sim-thesis");
  EXPECT_EQ(p->camera_config.width, 240);
  EXPECT_EQ(p->camera_config.height, 192);
  EXPECT_DOUBLE_EQ(p->camera_config.fps, 1000.0);
  EXPECT_NEAR(p->spheres.diameter_m[0] / p->geometry.pixel_size_m, 37.0, 0.5);
}

TEST(RigProfile, BuiltInDefaultIsConfigSimToml) {
  EXPECT_EQ(std::string(defaultRigProfileText()), simProfileText());
  const auto p = defaultRigProfile();
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_EQ(p->name, "sim");
}

// Every profile the project ships (config/, and bench/profiles/ that the
// accuracy bench fires, which no other test loads) is still a valid profile.
TEST(RigProfile, EveryShippedProfileLoads) {
  int loaded = 0;
  for (const char* folder : {"config", "bench/profiles"})
    for (const auto& e :
         std::filesystem::directory_iterator(std::string(COLLIDE_SOURCE_DIR) + "/" + folder)) {
      if (e.path().extension() != ".toml") continue;
      auto p = loadRigProfile(e.path().string());
      EXPECT_TRUE(p.ok()) << e.path() << ": " << p.error().message;
      ++loaded;
    }
  EXPECT_GE(loaded, 10);
}

TEST(RigProfile, MissingFileNamesThePath) {
  const auto p = loadRigProfile("/nonexistent/rig.toml");
  ASSERT_FALSE(p.ok());
  EXPECT_THAT(p.error().message, HasSubstr("/nonexistent/rig.toml"));
}

// Not a profile at all: a folder, a device that never ends, a huge file.
TEST(RigProfile, AFolderOrADeviceIsNamedAndNothingIsReadWithoutLimit) {
  const auto dir = loadRigProfile(std::filesystem::temp_directory_path());
  ASSERT_FALSE(dir.ok());
  EXPECT_THAT(dir.error().message, HasSubstr("is a folder, not a rig profile"));
  const auto zero = loadRigProfile("/dev/zero");
  ASSERT_FALSE(zero.ok());
  EXPECT_THAT(zero.error().message, HasSubstr("/dev/zero is not a regular file"));
  const auto big_path = std::filesystem::temp_directory_path() / "collide-big-profile.toml";
  {
    std::ofstream big(big_path);
    big << std::string(2 << 20, '#');
  }
  const auto big = loadRigProfile(big_path);
  std::filesystem::remove(big_path);
  ASSERT_FALSE(big.ok());
  EXPECT_THAT(big.error().message, HasSubstr("larger than 1 MB"));
}

TEST(RigProfile, OutOfRangeNumberGivesFileLineFieldAndRule) {
  const std::string text = withKey(simProfileText(), "camera", "fps", "-5");
  EXPECT_EQ(errorFor(text),
            at(text, "camera", "fps") + "camera.fps = -5: must be >= 1 and <= 2e+07");
}

// Numbers a rig cannot mean are refused at load, naming the field: a frame
// rate of 1e-9 once hung a campaign (its period overflowed int64 nanoseconds).
TEST(RigProfile, NumbersOutsideWhatTheRigCanMeanAreRefusedByName) {
  for (const char* fps : {"1e-9", "1e-8", "0.5", "1e12", "nan", "inf"})
    EXPECT_THAT(errorFor(withKey(simProfileText(), "camera", "fps", fps)),
                HasSubstr("camera.fps = "))
        << fps;
  EXPECT_THAT(errorFor(withKey(simProfileText(), "camera", "roi", "[0, 0, 65536, 480]")),
              HasSubstr("camera.roi = [0, 0, 65536, 480]: each element must be at most 32768"));
  EXPECT_THAT(errorFor(withKey(simProfileText(), "camera", "roi", "[2147483000, 0, 640, 480]")),
              HasSubstr("camera.roi"));
  EXPECT_THAT(errorFor(withKey(simProfileText(), "camera", "roi", "[30000, 0, 3000, 480]")),
              HasSubstr("the region must end within 32768 pixels"));
}

// A burst larger than this machine's memory is refused with the figures
// before anything is armed (it used to abort the simulated camera's thread).
TEST(RigProfile, ABurstLargerThanMemoryIsRefusedWithTheFigures) {
  std::string text = withKey(simProfileText(), "camera", "roi", "[0, 0, 32768, 32768]");
  text = withKey(text, "burst", "post_trigger_frames", "100000");
  EXPECT_THAT(errorFor(text), AllOf(HasSubstr("burst.post_trigger_frames = 100000"),
                                    HasSubstr("GB"), HasSubstr("record fewer frames")));
}

TEST(RigProfile, WrongTypeIsRefused) {
  const std::string text = withKey(simProfileText(), "camera", "fps", "\"fast\"");
  EXPECT_EQ(errorFor(text),
            at(text, "camera", "fps") + "camera.fps = \"fast\": must be a number, not a string");
}

TEST(RigProfile, NonWholeIntegerIsRefused) {
  const std::string text = withKey(simProfileText(), "burst", "pre_trigger_frames", "2.5");
  EXPECT_EQ(errorFor(text), at(text, "burst", "pre_trigger_frames") +
                                "burst.pre_trigger_frames = 2.5: must be a whole number");
}

TEST(RigProfile, MissingRequiredFieldPointsAtItsSection) {
  const std::string base = simProfileText();
  const std::string text = withoutKey(base, "camera", "exposure_us");
  const int header = lineOf(text, "camera", "backend") - 1;
  EXPECT_EQ(errorFor(text), kSource + ":" + std::to_string(header) +
                                ": camera.exposure_us is missing: add it to [camera]");
}

TEST(RigProfile, UnknownFieldInAProfileSectionIsRefused) {
  const std::string text = withKey(simProfileText(), "burst", "post_trigger_frame", "3");
  EXPECT_THAT(errorFor(text), StartsWith(at(text, "burst", "post_trigger_frame") +
                                         "burst.post_trigger_frame: unknown setting"));
}

TEST(RigProfile, UnknownSectionIsRefusedWithTheKnownOnes) {
  const std::string text = simProfileText() + "\n[cmaera]\nfps = 3\n";
  const std::string e = errorFor(text);
  EXPECT_THAT(e, StartsWith(kSource + ":"));
  EXPECT_THAT(e, HasSubstr("[cmaera] is not a section of a rig profile (known: regulator"));
}

TEST(RigProfile, BadChoiceListsTheChoices) {
  const std::string text = withKey(simProfileText(), "camera", "format", "\"RGB8\"");
  EXPECT_EQ(errorFor(text), at(text, "camera", "format") +
                                "camera.format = \"RGB8\": must be \"Mono8\", \"Mono12\" or "
                                "\"Mono16\"");
  const std::string law = withKey(simProfileText(), "simulation", "restitution", "\"linear\"");
  EXPECT_THAT(errorFor(law), StartsWith(at(law, "simulation", "restitution") +
                                        "simulation.restitution = \"linear\": must be one of"));
}

TEST(RigProfile, ExposureLongerThanAFrameIsRefused) {
  const std::string text = withKey(simProfileText(), "camera", "exposure_us", "1500");
  EXPECT_EQ(errorFor(text), at(text, "camera", "exposure_us") +
                                "camera.exposure_us = 1500: must be at most one frame period "
                                "(1000 us at 1000 frames/s)");
}

TEST(RigProfile, RoiMustBeFourWholeNumbers) {
  const std::string three = withKey(simProfileText(), "camera", "roi", "[0, 0, 640]");
  EXPECT_EQ(errorFor(three),
            at(three, "camera", "roi") + "camera.roi = [0, 0, 640]: must be an array of 4 numbers");
  const std::string zero = withKey(simProfileText(), "camera", "roi", "[0, 0, 0, 480]");
  EXPECT_THAT(errorFor(zero),
              StartsWith(at(zero, "camera", "roi") + "camera.roi = [0, 0, 0, 480]"));
}

TEST(RigProfile, SyntaxErrorGivesLineAndColumn) {
  std::string text = simProfileText();
  const int line = lineOf(text, "camera", "fps");
  text = withKey(text, "camera", "fps", "= 3");
  EXPECT_THAT(errorFor(text), StartsWith(kSource + ":" + std::to_string(line) + ":"));
  EXPECT_THAT(errorFor(text), HasSubstr("not valid TOML"));
}

TEST(RigProfile, NeedsExactlyTwoLaunchers) {
  const std::string text = simProfileText() +
                           "\n[[launcher]]\nvalve = 2\nregulator_channel = 2\nexit_m = [0, 0, "
                           "0]\ndirection = [0, 1, 0]\n";
  EXPECT_EQ(
      errorFor(text),
      kSource + ": the profile needs exactly two [[launcher]] tables, one per tube (found 3)");
}

TEST(RigProfile, LaunchersMustUseDifferentValves) {
  const std::string text = withKey(simProfileText(), "launcher", "valve", "0", 2);
  EXPECT_EQ(errorFor(text), at(text, "launcher", "valve", 2) +
                                "launcher[2].valve = 0: launcher[1] fires that valve already");
}

TEST(RigProfile, SlideTravelMustStraddleTheExitPoint) {
  for (const char* bad : {"[0.01, 0.04]", "[-0.04, -0.01]", "[-0.6, 0.6]"}) {
    const std::string text = withKey(simProfileText(), "launcher", "slide_travel_m", bad, 2);
    EXPECT_THAT(errorFor(text), HasSubstr("slide_travel_m")) << bad;
    EXPECT_THAT(errorFor(text), HasSubstr("down <= 0 <= up")) << bad;
  }
  const std::string text = withKey(simProfileText(), "launcher", "slide_travel_m", "[-0.01, 0.0]");
  const auto r = parseRigProfile(text, kSource);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_TRUE(r->launchers[0].slide_travel_m.has_value());
  EXPECT_DOUBLE_EQ((*r->launchers[0].slide_travel_m)[0], -0.01);
}

TEST(RigProfile, ZeroDirectionIsRefused) {
  const std::string text = withKey(simProfileText(), "launcher", "direction", "[0, 0, 0]");
  EXPECT_THAT(errorFor(text), StartsWith(at(text, "launcher", "direction") +
                                         "launcher[1].direction = [0, 0, 0]: must point"));
}

TEST(RigProfile, CalibrationThatDoesNotRiseIsRefused) {
  const std::string text =
      withKey(simProfileText(), "calibration", "coefficients", "[3.0, -1.0, 0.0, 0.0]");
  EXPECT_THAT(errorFor(text), StartsWith(at(text, "calibration", "coefficients") +
                                         "calibration.coefficients = [3, -1, 0, 0]: "));
}

TEST(RigProfile, PulseAboveTheSafetyLimitIsRefused) {
  const std::string text = withKey(simProfileText(), "sequencer", "pulse_us", "60000");
  EXPECT_EQ(errorFor(text), at(text, "sequencer", "pulse_us") +
                                "sequencer.pulse_us = 60000: exceeds "
                                "safety.max_valve_pulse_us = 50000");
}

TEST(RigProfile, LaunchRangeAboveTheSafetyLimitIsRefused) {
  const std::string text = withKey(simProfileText(), "calibration", "max_kpa", "220");
  EXPECT_EQ(errorFor(text), at(text, "calibration", "max_kpa") +
                                "calibration.max_kpa = 220: exceeds safety.max_pressure_kpa = 200");
}

TEST(RigProfile, UnknownBackendNamesTheFieldAndTheKnownBackends) {
  const std::string text = withKey(simProfileText(), "camera", "backend", "\"aravis2\"");
  const std::string e = errorFor(text);
  EXPECT_THAT(e, StartsWith(at(text, "camera", "backend") +
                            "camera.backend = \"aravis2\": unknown backend (known: "));
  EXPECT_THAT(e, HasSubstr("\"sim\""));
  const std::string valves = withKey(simProfileText(), "valves", "backend", "\"gpio\"");
  EXPECT_THAT(errorFor(valves), StartsWith(at(valves, "valves", "backend") +
                                           "valves.backend = \"gpio\": unknown backend"));
}

TEST(RigProfile, MissingSectionIsNamed) {
  std::string text = simProfileText();
  const auto pos = text.find("[safety]");
  text.replace(pos, 8, "[safetyy]");
  EXPECT_THAT(errorFor(text), HasSubstr("[safetyy] is not a section"));
  const auto p =
      parseRigProfile("name = \"x\"\n[regulator]\nbackend = \"sim\"\nmax_kpa = 100\n", kSource);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(
      p.error().message,
      kSource + ": [safety] is missing: add the section (config/sim.toml documents every one)");
}

TEST(RigProfile, SimulationSectionIsOptional) {
  std::string text = simProfileText();
  text = text.substr(0, text.find("[simulation]"));
  const auto p = parseRigProfile(text, kSource);
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_DOUBLE_EQ(p->simulation.speed_scatter, 0.0);
}

TEST(RigProfile, BackendSettingsReaderSkipsRoleKeysAndCatchesTypos) {
  const std::string text = withKey(simProfileText(), "camera", "noise_gray", "1");
  const auto p = parseRigProfile(text, kSource);
  ASSERT_TRUE(p.ok()) << p.error().message;  // the profile does not know backend keys
  SettingsReader r = p->camera.backendSettings();
  for (const char* k : {"sensor_px", "realtime", "noise_grey", "drop_every", "stop_after_frames"})
    r.markRead(k);
  const collide::Status s = r.finish("the sim camera backend");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message, at(text, "camera", "noise_gray") +
                                   "camera.noise_gray: unknown setting for the sim camera backend "
                                   "(a typo, or a setting of another backend?)");
}
