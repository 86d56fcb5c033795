// `collide calibrate-camera` end to end (issue 11, item 3): the simulated
// lab camera (config/sim-lab.toml) draws chessboard targets through its own
// lens and sensor, the command calibrates from them, and what it recovers is
// checked against the lens the profile states (independent truth: the
// calibration never sees it); the profile gains a [camera.calibration] table
// that parses, a shot fired with that profile records it, and the analysis
// measures e through it as well as through the profile's own lens.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "app/analyze.hpp"
#include "app/store/shot_file.hpp"
#include "hw/camera_sim.hpp"
#include "hw/rig_profile.hpp"
#include "tests/app/cli_run.hpp"
#include "vision/shot_analysis.hpp"

namespace collide::testing {
namespace {

// config/sim-lab.toml's lens: 50 mm focal length, 20 um pixels, 0.5292 m
// from the collision plane, distortion [-0.08, 0.02, 0.0001, -0.0001].
constexpr double kFocalPx = 50e-3 / 20e-6;
constexpr double kDistanceM = 0.5292;
constexpr double kPlanePixelM = kDistanceM / kFocalPx;
constexpr double kK1 = -0.08, kK2 = 0.02, kP1 = 0.0001, kP2 = -0.0001;

// Within 3 standard uncertainties, and the uncertainty itself positive and no
// wider than `max_sigma`.
void expectWithin(const char* what, double value, double sigma, double truth, double max_sigma) {
  EXPECT_GT(sigma, 0) << what;
  EXPECT_LT(sigma, max_sigma) << what << ": " << value << " +- " << sigma;
  EXPECT_LT(std::abs(value - truth), 3 * sigma)
      << what << ": " << value << " +- " << sigma << ", truth " << truth;
}

TEST(CliCalibrateCamera, RecoversTheSimulatedLensAndTheAnalysisUsesIt) {
  ScratchDir scratch;
  const std::string profile = scratch.file("lab.toml");
  const std::string original = readAll(std::string(COLLIDE_SOURCE_DIR) + "/config/sim-lab.toml");
  std::ofstream(profile) << original;
  const std::string targets = scratch.file("targets");

  // 1. The simulated camera draws the targets.
  auto run = runCollide("calibrate-camera --render-targets " + q(targets) + " --rig " + q(profile) +
                            " --views 16 --board 9x6 --square-mm 8.5",
                        scratch);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  ASSERT_TRUE(std::filesystem::exists(targets + "/plane.png"));
  ASSERT_TRUE(std::filesystem::exists(targets + "/view-16.png"));

  // 2. Calibrate from them, into the profile and JSON.
  const std::string json_path = scratch.file("cal.json");
  run = runCollide("calibrate-camera " + q(targets) + "/view-*.png --plane " +
                       q(targets + "/plane.png") + " --board 9x6 --square-mm 8.5 --profile " +
                       q(profile) + " --json " + q(json_path),
                   scratch);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("focal length (20 um pixels)"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("m/px"), std::string::npos) << run.out;
  const auto j = nlohmann::json::parse(readAll(json_path));
  EXPECT_EQ(j["views_used"].get<int>(), 17);
  EXPECT_LT(j["rms_px"].get<double>(), 0.5);
  // Bounds on the uncertainties for this narrow field (a 50 mm lens, 14
  // degrees across): f to 1 %, k1 to 0.05, p1 p2 to 0.005, the plane's
  // scale to 0.3 % (its uncertainty allows for a coherent corner bias, see
  // vision/camera_calibration.cpp) and its distance to 1 %.
  expectWithin("focal_px", j["focal_px"], j["focal_px_sigma"], kFocalPx, 0.01 * kFocalPx);
  expectWithin("focal_length_mm", j["focal_length_mm"], j["focal_length_mm_sigma"], 50.0, 0.5);
  expectWithin("k1", j["distortion"][0], j["distortion_sigma"][0], kK1, 0.05);
  const double k2_sigma = j["distortion_sigma"][1];
  if (k2_sigma > 0) {
    expectWithin("k2", j["distortion"][1], k2_sigma, kK2, 50.0);
  } else {  // held at 0, and said so
    EXPECT_EQ(j["distortion"][1].get<double>(), 0.0);
    EXPECT_NE(run.out.find("k2 held at 0"), std::string::npos) << run.out;
  }
  expectWithin("p1", j["distortion"][2], j["distortion_sigma"][2], kP1, 0.005);
  expectWithin("p2", j["distortion"][3], j["distortion_sigma"][3], kP2, 0.005);
  expectWithin("plane_pixel_size_m", j["plane_pixel_size_m"], j["plane_pixel_size_m_sigma"],
               kPlanePixelM, 3e-3 * kPlanePixelM);
  expectWithin("plane_distance_m", j["plane_distance_m"], j["plane_distance_m_sigma"], kDistanceM,
               0.01 * kDistanceM);

  // 3. The profile gained [camera.calibration], which parses, and kept the rest.
  const std::string written = readAll(profile);
  EXPECT_EQ(readAll(profile + ".bak"), original);
  ASSERT_NE(written.find("\n[camera.calibration]\n"), std::string::npos);
  EXPECT_NE(written.find(original.substr(0, original.find("[camera.imaging]"))), std::string::npos);
  auto parsed = hw::loadRigProfile(profile);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  ASSERT_TRUE(parsed->camera_calibration.has_value());
  EXPECT_NEAR(parsed->camera_calibration->focal_px, j["focal_px"].get<double>(), 1e-6);
  ASSERT_TRUE(parsed->camera_calibration->plane_pixel_size_m.has_value());

  // 4. A shot fired with it records the table; the analysis takes its lens.
  const std::string out = scratch.file("shots");
  run = runCollide("campaign --rig " + q(profile) + " --shots 1 --out " + q(out), scratch);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  std::optional<hw::Shot> shot;
  std::string shot_path;
  for (const auto& e : std::filesystem::directory_iterator(out))
    if (e.path().extension() == ".h5") {
      shot_path = e.path().string();
      auto s = app::readShot(e.path().string());
      ASSERT_TRUE(s.ok()) << s.error().message;
      shot = std::move(*s);
    }
  ASSERT_TRUE(shot.has_value());
  const std::string table =
      written.substr(written.find("[camera.calibration]"),
                     written.find("\n[", written.find("[camera.calibration]")) -
                         written.find("[camera.calibration]"));
  EXPECT_NE(shot->rig_profile_toml.find(table), std::string::npos);
  const vision::AnalysisSettings with_calibration = app::analysisSettingsFor(*shot);
  ASSERT_TRUE(with_calibration.camera.has_value());
  EXPECT_NEAR(with_calibration.camera->focal_px, j["focal_px"].get<double>(), 1e-6);
  // The same shot through the profile's own (true) lens.
  auto shot_profile = hw::parseRigProfile(shot->rig_profile_toml, "recorded");
  ASSERT_TRUE(shot_profile.ok());
  auto true_lens = hw::simulatedLens(*shot_profile);
  ASSERT_TRUE(true_lens.ok() && true_lens->has_value());
  vision::AnalysisSettings with_truth = with_calibration;
  with_truth.camera = **true_lens;
  // Both lenses put the world origin at the same pixel.
  EXPECT_LT(
      (with_calibration.camera->onPlane(319.5, 239.5) - with_truth.camera->onPlane(319.5, 239.5))
          .norm(),
      1e-6);
  auto a_cal = vision::analyzeBurst(shot->burst, with_calibration);
  auto a_true = vision::analyzeBurst(shot->burst, with_truth);
  ASSERT_TRUE(a_cal.ok()) << a_cal.error().message;
  ASSERT_TRUE(a_true.ok()) << a_true.error().message;
  ASSERT_TRUE(shot->truth.has_value());
  const double e_truth = shot->truth->material.e;
  const vision::Measured e_cal = a_cal->collision.e, e_true_lens = a_true->collision.e;
  std::cout << "e through the calibration " << e_cal.value << " +- " << e_cal.sigma
            << ", through the true lens " << e_true_lens.value << " +- " << e_true_lens.sigma
            << ", truth " << e_truth << "\n";
  // The calibrated lens moves e by less than its measurement uncertainty, and
  // e stays as near the truth as through the true lens (within that sigma).
  EXPECT_LT(std::abs(e_cal.value - e_true_lens.value), e_true_lens.sigma)
      << e_cal.value << " vs " << e_true_lens.value << " +- " << e_true_lens.sigma;
  EXPECT_LT(std::abs(e_cal.value - e_truth),
            std::abs(e_true_lens.value - e_truth) + e_true_lens.sigma)
      << "e " << e_cal.value << " (calibration) " << e_true_lens.value << " (true lens), truth "
      << e_truth;

  // 5. The same frames as footage recorded elsewhere, through the profile's
  // calibration (--profile): e as the shot's own analysis through it.
  const std::string png = scratch.file("png");
  ASSERT_EQ(runCollide("export " + q(shot_path) + " --png " + q(png), scratch).exit_code, 0);
  const std::string footage_json = scratch.file("footage.json");
  const std::string footage = "analyze --frames " + q(png) + " --fps " +
                              std::to_string(shot->camera.fps) + " --diameter-mm 25.4";
  run = runCollide(footage + " --profile " + q(profile) + " --json " + q(footage_json), scratch);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  // PNG frames do not say their exposure: the profile's camera took them, so its.
  EXPECT_NE(run.err.find("exposure " + std::to_string(static_cast<int>(shot->burst.exposure_us)) +
                         " us from " + profile),
            std::string::npos)
      << run.err;
  const auto results = nlohmann::json::parse(readAll(footage_json));
  ASSERT_TRUE(results["e"].is_number()) << results.dump();
  std::cout << "the same frames as footage: e " << results["e"].get<double>() << "\n";
  EXPECT_LT(std::abs(results["e"].get<double>() - e_cal.value), e_cal.sigma)
      << results["e"] << " vs " << e_cal.value;
  // An exposure longer than a frame period is refused, naming the option.
  const double period_us = 1e6 / shot->camera.fps;
  run = runCollide(footage + " --exposure-us " + std::to_string(1.2 * period_us), scratch);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--exposure-us"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("frame period"), std::string::npos) << run.err;
  // Frames faster than the profile's camera ran: its exposure is not theirs, and is not used.
  run = runCollide("analyze --frames " + q(png) + " --fps " + std::to_string(4 * shot->camera.fps) +
                       " --diameter-mm 25.4 --profile " + q(profile),
                   scratch);
  EXPECT_NE(run.err.find("is longer than these frames' period"), std::string::npos) << run.err;
  EXPECT_EQ(run.err.find(" us from " + profile), std::string::npos) << run.err;
  // A profile without the table is named.
  const std::string lab = std::string(COLLIDE_SOURCE_DIR) + "/config/sim-lab.toml";
  run = runCollide(footage + " --profile " + q(lab), scratch);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("has no [camera.calibration]"), std::string::npos) << run.err;
}

TEST(CliCalibrateCamera, TooFewBoardsSaysHowManyAreNeeded) {
  ScratchDir scratch;
  const std::string profile = scratch.file("lab.toml");
  std::ofstream(profile) << readAll(std::string(COLLIDE_SOURCE_DIR) + "/config/sim-lab.toml");
  const std::string targets = scratch.file("targets");
  auto run = runCollide("calibrate-camera --render-targets " + q(targets) + " --rig " + q(profile) +
                            " --views 3 --square-mm 8.5",
                        scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // Two views and a board of the wrong size: nothing found in any of them.
  run = runCollide("calibrate-camera " + q(targets + "/view-01.png") + " " +
                       q(targets + "/view-02.png") + " --board 7x5 --square-mm 8.5",
                   scratch);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("found in 0 of 2 pictures; at least 3"), std::string::npos) << run.err;
  // The right board, but only two views.
  run = runCollide("calibrate-camera " + q(targets + "/view-01.png") + " " +
                       q(targets + "/view-02.png") + " --board 9x6 --square-mm 8.5",
                   scratch);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("found in 2 of 2 pictures; at least 3"), std::string::npos) << run.err;
  // A file that is not a picture is named.
  run = runCollide("calibrate-camera " + q(profile) + " --square-mm 8.5", scratch);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("lab.toml: not a picture"), std::string::npos) << run.err;
  run = runCollide("calibrate-camera " + q(targets + "/view-99.png") + " --square-mm 8.5", scratch);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("view-99.png: no such picture file"), std::string::npos) << run.err;
  run = runCollide(
      "calibrate-camera " + q(targets + "/view-01.png") + " --board 9by6 --square-mm 8", scratch);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--board 9by6"), std::string::npos) << run.err;
}

TEST(CameraCalibrationProfile, BadFieldsAreNamed) {
  std::string text(readAll(std::string(COLLIDE_SOURCE_DIR) + "/config/sim-lab.toml"));
  const std::string good =
      "\n[camera.calibration]\nimage_px = [640, 480]\nfocal_px = 2500\nfocal_px_sigma = 5\n"
      "principal_px = [320, 240]\nprincipal_px_sigma = [10, 10]\n"
      "distortion = [-0.08, 0, 0, 0]\ndistortion_sigma = [0.03, 0, 0.001, 0.001]\n";
  const auto with = [&](const std::string& table) {
    std::string t = text;
    t.insert(t.find("\n[burst]"), table);
    return hw::parseRigProfile(t, "lab.toml");
  };
  auto p = with(good);
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_TRUE(p->camera_calibration.has_value());
  EXPECT_FALSE(p->camera_calibration->plane_distance_m.has_value());
  // Without a plane distance the lens stands where geometry.pixel_size_m says.
  EXPECT_NEAR(p->camera_calibration->lens(p->geometry).centre_m.z(),
              p->geometry.pixel_size_m * 2500, 1e-12);
  for (const auto& [bad, field] : std::vector<std::pair<std::string, std::string>>{
           {"focal_px = 2500", "camera.calibration.focal_px"},
           {"image_px = [640, 480]", "camera.calibration.image_px"},
           {"focal_px_sigma = 5", "camera.calibration.focal_px_sigma"},
       }) {
    std::string table = good;
    const std::string replacement = bad == "focal_px = 2500"         ? "focal_px = -1"
                                    : bad == "image_px = [640, 480]" ? "image_px = [320, 240]"
                                                                     : "focal_px_sigma = -5";
    table.replace(table.find(bad), bad.size(), replacement);
    auto r = with(table);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().message.find(field), std::string::npos) << r.error().message;
  }
  auto r = with(good + "plane_distance_m = 0.53\n");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("plane_distance_m_sigma"), std::string::npos)
      << r.error().message;
  r = with(good + "focal_mm = 50\n");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("camera.calibration.focal_mm"), std::string::npos)
      << r.error().message;
}

}  // namespace
}  // namespace collide::testing
