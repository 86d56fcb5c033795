// `collide track` through the built program, on drops rendered with the
// project's renderer at a known pixel size and frame rate: a ballistic drop
// (its fitted acceleration is g, its velocity the thrown one), a drop with a
// floor bounce (two segments split at the bounce), the same footage as a
// calibrated Photron file, the outputs (JSON, CSV, PNG) and the errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "hw/camera_sim.hpp"
#include "hw/rig_profile.hpp"
#include "tests/app/cli_run.hpp"
#include "tests/vision/footage_writers.hpp"
#include "vision/frame_io.hpp"
#include "vision/render.hpp"

namespace {

namespace fs = std::filesystem;
using namespace collide::testing;
using nlohmann::json;
using ::testing::HasSubstr;

constexpr double kG = 9.80665;
constexpr double kPixelM = 0.25e-3;  // object-plane pixel, m
constexpr double kFps = 1000;
constexpr double kRadiusPx = 20;  // a 10 mm sphere
constexpr int kWidth = 640, kHeight = 480;

/// A sphere thrown at (vx, vy) m/s from (u0, v0) px, bouncing off a floor at
/// centre height v_floor_px (image v; NaN: none) with restitution e.
struct Drop {
  double u0 = 100, v0 = 120, vx = 0.4, vy = 0.3;
  double v_floor_px = std::nan(""), e = 0.6;
  int frames = 150;
  bool backlit = false;

  double bounceTime() const {  // y(t) = y0 + vy t - g t^2 / 2 reaches the floor
    if (std::isnan(v_floor_px)) return INFINITY;
    const double drop_m = (v_floor_px - v0) * kPixelM;  // >0: floor below
    return (vy + std::sqrt(vy * vy + 2 * kG * drop_m)) / kG;
  }
  /// Centre (px) and velocity (m/s, x right, y up) at t.
  Eigen::Vector2d centrePx(double t) const {
    const double tb = bounceTime();
    double y;  // metres, up, from the start
    if (t <= tb) {
      y = vy * t - 0.5 * kG * t * t;
    } else {
      const double s = t - tb;
      y = -(v_floor_px - v0) * kPixelM + velocity(tb).y() * -e * s - 0.5 * kG * s * s;
    }
    return {u0 + vx * t / kPixelM, v0 - y / kPixelM};
  }
  Eigen::Vector2d velocity(double t) const {
    const double tb = bounceTime();
    if (t <= tb) return {vx, vy - kG * t};
    return {vx, -e * (vy - kG * tb) - kG * (t - tb)};
  }
  std::vector<cv::Mat> render() const {
    collide::vision::RenderSettings rs;
    rs.width = kWidth;
    rs.height = kHeight;
    rs.format = collide::vision::PixelFormat::Mono12;
    rs.noise_grey = 30;  // 0.7 % of full scale
    if (backlit) {
      rs.background_level = 0.85;
      rs.sphere_level = 0.12;
      rs.rim_level = 0.08;
    }
    const collide::vision::Renderer renderer(rs);
    std::vector<cv::Mat> out;
    for (int k = 0; k < frames; ++k) {
      collide::vision::SphereView v;
      v.centre_px = centrePx(k / kFps);
      v.radius_px = kRadiusPx;
      out.push_back(renderer.render({v}, k));
    }
    return out;
  }
};

std::string writeFolder(const Drop& d, const std::string& dir) {
  fs::create_directories(dir);
  const auto frames = d.render();
  char name[64];
  for (std::size_t k = 0; k < frames.size(); ++k) {
    std::snprintf(name, sizeof name, "/frame%04zu.png", k);
    cv::imwrite(dir + name, frames[k]);
  }
  return dir;
}

json readJson(const std::string& path) {
  std::ifstream in(path);
  return json::parse(in, nullptr, false);
}

class CliTrack : public ::testing::Test {
 protected:
  ScratchDir scratch_;
};

TEST_F(CliTrack, ADropGivesGravityAndTheThrownVelocity) {
  const Drop d;
  const std::string dir = writeFolder(d, scratch_.file("drop"));
  const std::string js = scratch_.file("drop.json"), csv = scratch_.file("drop.csv"),
                    png = scratch_.file("drop.png");
  auto run = runCollide("track " + q(dir) + " --fps 1000 --diameter-mm 10 --json " + q(js) +
                            " --csv " + q(csv) + " --png " + q(png),
                        scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_THAT(run.out, HasSubstr("1 sphere"));
  const json j = readJson(js);
  ASSERT_FALSE(j.is_discarded());
  EXPECT_EQ(j["schema"], "collide.track/1");
  EXPECT_EQ(j["fps"], 1000.0);
  EXPECT_EQ(j["pixel_size_from"], "diameter");
  const double s = j["pixel_size_m"], s_sigma = j["pixel_size_sigma_m"];
  EXPECT_NEAR(s, kPixelM, 2 * s_sigma);
  ASSERT_EQ(j["spheres"].size(), 1u);
  const json& sp = j["spheres"][0];
  ASSERT_EQ(sp["frames"].size(), 150u);
  const json& f7 = sp["frames"][7];
  EXPECT_EQ(f7["index"], 7);
  EXPECT_DOUBLE_EQ(f7["t_s"].get<double>(), 7 / kFps);
  const Eigen::Vector2d c7 = d.centrePx(7 / kFps);
  EXPECT_NEAR(f7["centre_px"][0].get<double>(), c7.x(), 0.05);
  EXPECT_NEAR(f7["centre_px"][1].get<double>(), c7.y(), 0.05);
  EXPECT_NEAR(f7["radius_px"].get<double>(), kRadiusPx, 0.1);

  ASSERT_EQ(sp["segments"].size(), 1u) << sp["segments"].dump();
  const json& g = sp["segments"][0];
  EXPECT_EQ(g["first_frame"], 0);
  EXPECT_EQ(g["last_frame"], 149);
  EXPECT_EQ(g["ends_at"], "end");
  // Acceleration: g down, within its stated uncertainty (the fit's, and the
  // scale's, which every acceleration shares).
  const double ay = g["acceleration_m_s2"][1], ay_sigma = g["acceleration_sigma_m_s2"][1];
  const double ay_total_sigma = std::hypot(ay_sigma, kG * s_sigma / s);
  EXPECT_LT(std::abs(ay + kG), 2 * ay_total_sigma)
      << "a_y " << ay << " +- " << ay_sigma << " (fit), scale " << s_sigma / s;
  EXPECT_LT(std::abs(g["acceleration_m_s2"][0].get<double>()),
            3 * g["acceleration_sigma_m_s2"][0].get<double>());
  // Velocity at the first frame within 0.2 % of the thrown one.
  const Eigen::Vector2d v(g["velocity_m_s"][0].get<double>(), g["velocity_m_s"][1].get<double>());
  const Eigen::Vector2d v_true(d.vx, d.vy);
  EXPECT_LT((v - v_true).norm(), 0.002 * v_true.norm()) << v.transpose();
  EXPECT_LT(g["residual_px_rms"].get<double>(), 0.05);

  // CSV: a header and one row per frame.
  std::ifstream in(csv);
  std::string line;
  int rows = 0;
  std::getline(in, line);
  EXPECT_THAT(line, HasSubstr("sphere,index,id,t_s,u_px,v_px,radius_px"));
  while (std::getline(in, line)) ++rows;
  EXPECT_EQ(rows, 150);
  const cv::Mat pic = cv::imread(png, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(pic.empty()) << png;
  EXPECT_EQ(pic.cols, kWidth);
  EXPECT_EQ(pic.channels(), 3);
}

TEST_F(CliTrack, AFloorBounceGivesTwoSegmentsSplitAtTheBounce) {
  Drop d;
  d.u0 = 150;
  d.v0 = 100;
  d.vx = 0.2;
  d.vy = 0;
  d.v_floor_px = 400;
  d.frames = 200;
  const double tb = d.bounceTime();
  const int first_after = static_cast<int>(std::ceil(tb * kFps));
  const std::string dir = writeFolder(d, scratch_.file("bounce"));
  const std::string js = scratch_.file("bounce.json");
  auto run =
      runCollide("track " + q(dir) + " --fps 1000 --diameter-mm 10 --json " + q(js), scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const json j = readJson(js);
  const double s = j["pixel_size_m"], s_rel = j["pixel_size_sigma_m"].get<double>() / s;
  const json& segs = j["spheres"][0]["segments"];
  ASSERT_EQ(segs.size(), 2u) << segs.dump(1);
  EXPECT_EQ(segs[0]["first_frame"], 0);
  EXPECT_EQ(segs[0]["last_frame"], first_after - 1);
  EXPECT_EQ(segs[0]["ends_at"], "velocity_change");
  EXPECT_EQ(segs[1]["first_frame"], first_after);
  EXPECT_EQ(segs[1]["last_frame"], 199);
  for (const json& g : segs) {
    const double ay = g["acceleration_m_s2"][1], sigma = g["acceleration_sigma_m_s2"][1];
    EXPECT_LT(std::abs(ay + kG), 2 * std::hypot(sigma, kG * s_rel)) << g.dump();
  }
  const Eigen::Vector2d v_true = d.velocity(first_after / kFps);
  const double vy = segs[1]["velocity_m_s"][1];
  EXPECT_LT(std::abs(vy - v_true.y()), 0.002 * v_true.norm()) << vy << " vs " << v_true.y();
}

// Through a perspective lens (config/sim-lab.toml's, which `--rig` gives the
// track, with its one-sided lamp, blur and sensor), a thrown sphere drifting
// towards the camera at 3 % of its speed: its image grows and speeds up, which
// at the plane z = 0 reads as an acceleration of about 2 v v_z / Z (0.11 m/s^2
// along x here, 1 % of g). Each segment's depth from the apparent size places
// the centres, so the fitted acceleration is gravity's within its sigma
// (which carries the depth's), and the drift is measured. Truth: the world
// motion the frames were rendered from.
TEST_F(CliTrack, ADropDriftingTowardsTheCameraThroughALensStillGivesGravity) {
  const std::string rig = std::string(COLLIDE_SOURCE_DIR) + "/config/sim-lab.toml";
  auto profile = collide::hw::loadRigProfile(rig);
  ASSERT_TRUE(profile) << profile.error().message;
  auto rs = collide::hw::simulatedRenderSettings(*profile);
  ASSERT_TRUE(rs) << rs.error().message;
  const double fps = profile->camera_config.fps, radius_m = 0.5 * profile->spheres.diameter_m[0];
  const Eigen::Vector3d x0(-0.035, 0.02, 0.0), v0(1.0, 0.2, 0.03);
  const auto at = [&](double t) {
    return Eigen::Vector3d(x0 + v0 * t + Eigen::Vector3d(0, -0.5 * kG * t * t, 0));
  };
  const collide::vision::Renderer renderer(*rs);
  const std::string dir = scratch_.file("drift");
  fs::create_directories(dir);
  const int frames = 120;
  for (int k = 0; k < frames; ++k) {
    const double t = k / fps;
    collide::vision::SphereView v;
    v.centre_m = at(t);
    v.radius_m = radius_m;
    v.velocity_m_s = v0 + Eigen::Vector3d(0, -kG * t, 0);
    char name[64];
    std::snprintf(name, sizeof name, "/frame%04d.png", k);
    ASSERT_TRUE(cv::imwrite(dir + name, renderer.render({v}, k)));
  }
  const std::string js = scratch_.file("drift.json");
  auto run = runCollide(
      "track " + q(dir) + " --fps " + std::to_string(fps) + " --rig " + q(rig) + " --json " + q(js),
      scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const json j = readJson(js);
  EXPECT_EQ(j["pixel_size_from"], "camera");
  const json& segs = j["spheres"][0]["segments"];
  ASSERT_EQ(segs.size(), 1u) << segs.dump(1);
  const json& g = segs[0];
  std::printf("a %s +- %s, v_z %s +- %s\n", g["acceleration_m_s2"].dump().c_str(),
              g["acceleration_sigma_m_s2"].dump().c_str(), g["velocity_z_m_s"].dump().c_str(),
              g["velocity_z_sigma_m_s"].dump().c_str());
  ASSERT_FALSE(g["velocity_z_m_s"].is_null()) << g.dump(1) << j["notes"].dump();
  const double vz = g["velocity_z_m_s"], vz_sigma = g["velocity_z_sigma_m_s"];
  EXPECT_LT(std::abs(vz - v0.z()), 3 * vz_sigma) << vz << " +- " << vz_sigma;
  EXPECT_LT(vz_sigma, v0.z());  // the drift is measured, not only bounded
  const double ax = g["acceleration_m_s2"][0], ay = g["acceleration_m_s2"][1];
  const double ax_sigma = g["acceleration_sigma_m_s2"][0];
  const double ay_sigma = g["acceleration_sigma_m_s2"][1];
  EXPECT_LT(std::abs(ax), 3 * ax_sigma) << "a_x " << ax << " +- " << ax_sigma;
  EXPECT_LT(std::abs(ay + kG), 3 * ay_sigma) << "a_y " << ay << " +- " << ay_sigma;
  // At most half the false acceleration the drift gives centres left on the
  // plane z = 0 (the sigmas also carry the depth's: a radius bias changing by
  // the profile's radius_systematic_px along the track).
  auto lens = collide::hw::simulatedLens(*profile);
  ASSERT_TRUE(lens && *lens);
  EXPECT_LT(std::abs(ax), 0.5 * 2 * v0.x() * v0.z() / (**lens).centre_m.z());
  const int first = g["first_frame"];
  const Eigen::Vector2d v(g["velocity_m_s"][0].get<double>(), g["velocity_m_s"][1].get<double>());
  const Eigen::Vector3d v_true = v0 + Eigen::Vector3d(0, -kG * first / fps, 0);
  EXPECT_LT((v - v_true.head<2>()).norm(), 0.002 * v_true.norm()) << v.transpose();
  // The positions are at the sphere's depth: frame 60's is the truth's.
  const json& f60 = j["spheres"][0]["frames"][60];
  const Eigen::Vector3d c60 = at(f60["t_s"].get<double>());
  EXPECT_NEAR(f60["position_m"][0].get<double>(), c60.x(), 2e-5);
  EXPECT_NEAR(f60["position_m"][1].get<double>(), c60.y(), 2e-5);
}

// Two spheres of different sizes (1 inch and 3/4 inch, the profile's two)
// through the lab's lens, drifting in depth in opposite directions: each
// track takes the profile's diameter its image fits (the wrong one would put
// the 3/4 inch sphere 0.13 m in front of the plane by its size), and each
// gets gravity and its own drift. Truth: the rendered world motion.
TEST_F(CliTrack, UnequalSpheresThroughALensEachTakeTheirOwnDiameter) {
  const std::string lab = std::string(COLLIDE_SOURCE_DIR) + "/config/sim-lab.toml";
  std::ifstream in(lab);
  std::stringstream text;
  text << in.rdbuf();
  std::string profile_text = text.str();
  const auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = profile_text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    profile_text.replace(at, from.size(), to);
  };
  replace("diameter_m = 0.0254\n", "diameter_m = [0.0254, 0.01905]\n");
  replace("mass_kg = 0.00978\n", "mass_kg = [0.00978, 0.004126]\n");
  const std::string rig = scratch_.file("unequal-lab.toml");
  std::ofstream(rig) << profile_text;
  auto profile = collide::hw::loadRigProfile(rig);
  ASSERT_TRUE(profile) << profile.error().message;
  auto rs = collide::hw::simulatedRenderSettings(*profile);
  ASSERT_TRUE(rs) << rs.error().message;
  const double fps = profile->camera_config.fps;
  struct Body {
    double diameter_m;
    Eigen::Vector3d x0, v0;
    Eigen::Vector3d at(double t) const {
      return x0 + v0 * t + Eigen::Vector3d(0, -0.5 * kG * t * t, 0);
    }
  };
  const Body bodies[2] = {{0.0254, {-0.040, 0.022, 0}, {0.8, 0.1, 0.03}},
                          {0.01905, {0.040, -0.022, 0}, {-0.8, 0.3, -0.02}}};
  const collide::vision::Renderer renderer(*rs);
  const std::string dir = scratch_.file("unequal");
  fs::create_directories(dir);
  for (int k = 0; k < 120; ++k) {
    const double t = k / fps;
    std::vector<collide::vision::SphereView> views;
    for (const Body& b : bodies) {
      collide::vision::SphereView v;
      v.centre_m = b.at(t);
      v.radius_m = 0.5 * b.diameter_m;
      v.velocity_m_s = b.v0 + Eigen::Vector3d(0, -kG * t, 0);
      views.push_back(v);
    }
    char name[64];
    std::snprintf(name, sizeof name, "/frame%04d.png", k);
    ASSERT_TRUE(cv::imwrite(dir + name, renderer.render(views, k)));
  }
  const std::string js = scratch_.file("unequal.json");
  auto run = runCollide("track " + q(dir) + " --fps " + std::to_string(fps) + " --rig " + q(rig) +
                            " --spheres 2 --json " + q(js),
                        scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const json j = readJson(js);
  ASSERT_EQ(j["spheres"].size(), 2u);
  for (const json& sp : j["spheres"]) {
    // The bigger image is the 1 inch sphere.
    const bool big = sp["radius_px"].get<double>() > 52;
    const Body& b = bodies[big ? 0 : 1];
    EXPECT_DOUBLE_EQ(sp["diameter_m"].get<double>(), b.diameter_m);
    ASSERT_EQ(sp["segments"].size(), 1u) << sp["segments"].dump(1);
    const json& g = sp["segments"][0];
    ASSERT_FALSE(g["velocity_z_m_s"].is_null()) << g.dump(1);
    const double vz = g["velocity_z_m_s"], vz_sigma = g["velocity_z_sigma_m_s"];
    EXPECT_LT(std::abs(vz - b.v0.z()), 3 * vz_sigma) << vz << " +- " << vz_sigma;
    const double depth = g["depth_m"], depth_sigma = g["depth_sigma_m"];
    const int first = g["first_frame"];
    EXPECT_LT(std::abs(depth - b.at(first / fps).z()), 3 * depth_sigma + 2e-4)
        << depth << " +- " << depth_sigma;
    const double ay = g["acceleration_m_s2"][1], ay_sigma = g["acceleration_sigma_m_s2"][1];
    EXPECT_LT(std::abs(ay + kG), 3 * ay_sigma) << "a_y " << ay << " +- " << ay_sigma;
    const json& f60 = sp["frames"][60];
    const Eigen::Vector3d c60 = b.at(f60["t_s"].get<double>());
    EXPECT_NEAR(f60["position_m"][0].get<double>(), c60.x(), 5e-5);
    EXPECT_NEAR(f60["position_m"][1].get<double>(), c60.y(), 5e-5);
  }
}

// Two thrown spheres of 20 and 15 mm in a folder of frames, no profile:
// `--diameter-mm 20,15` gives each its own (the larger image the larger
// sphere), and the scale is both tracks' (each diameter over its own image);
// one diameter for both says that the radii differ; a count that is neither
// one nor one per sphere is refused.
TEST_F(CliTrack, OneDiameterPerSphereScalesUnequalSpheres) {
  const double r_big = 40, r_small = 30;  // px at 0.25 mm: 20 and 15 mm
  collide::vision::RenderSettings rs;
  rs.width = kWidth;
  rs.height = kHeight;
  rs.format = collide::vision::PixelFormat::Mono12;
  rs.noise_grey = 30;
  const collide::vision::Renderer renderer(rs);
  const std::string dir = scratch_.file("two");
  fs::create_directories(dir);
  const auto centre = [](double u0, double v0, double vx, double vy, double t) {
    return Eigen::Vector2d(u0 + vx * t / kPixelM, v0 - (vy * t - 0.5 * kG * t * t) / kPixelM);
  };
  for (int k = 0; k < 100; ++k) {
    const double t = k / kFps;
    collide::vision::SphereView big, small;
    big.centre_px = centre(120, 150, 0.5, 0.2, t);
    big.radius_px = r_big;
    small.centre_px = centre(520, 330, -0.5, 0.3, t);
    small.radius_px = r_small;
    char name[64];
    std::snprintf(name, sizeof name, "/frame%04d.png", k);
    ASSERT_TRUE(cv::imwrite(dir + name, renderer.render({big, small}, k)));
  }
  const std::string js = scratch_.file("two.json");
  auto run =
      runCollide("track " + q(dir) + " --fps 1000 --diameter-mm 15,20 --json " + q(js), scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  json j = readJson(js);
  const double s = j["pixel_size_m"], s_sigma = j["pixel_size_sigma_m"];
  EXPECT_NEAR(s, kPixelM, 2 * s_sigma) << s << " +- " << s_sigma;
  EXPECT_LT(s_sigma, 0.005 * kPixelM);
  ASSERT_EQ(j["spheres"].size(), 2u);
  for (const json& sp : j["spheres"]) {
    const bool big = sp["radius_px"].get<double>() > 35;
    EXPECT_DOUBLE_EQ(sp["diameter_m"].get<double>(), big ? 0.020 : 0.015);
    const json& g = sp["segments"][0];
    const double ay = g["acceleration_m_s2"][1], sigma = g["acceleration_sigma_m_s2"][1];
    EXPECT_LT(std::abs(ay + kG), 2 * std::hypot(sigma, kG * s_sigma / s)) << g.dump();
  }
  // One diameter for both: the scale takes it for both, and says so.
  run = runCollide("track " + q(dir) + " --fps 1000 --diameter-mm 20 --json " + q(js), scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  j = readJson(js);
  EXPECT_THAT(j["notes"].dump(), HasSubstr("give one per sphere if they differ"));
  // Three diameters for two spheres.
  run = runCollide("track " + q(dir) + " --fps 1000 --spheres 2 --diameter-mm 20,15,10", scratch_);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_THAT(run.err, HasSubstr("3 diameters for 2 spheres tracked"));
}

// The same kind of drop as a Photron MRAW whose .cihx carries a pixel size:
// no --diameter-mm, no --fps; both come from the file.
TEST_F(CliTrack, ACalibratedPhotronFileGivesItsOwnScaleAndRate) {
  Drop d;
  d.frames = 100;
  const auto frames = d.render();
  const std::string base = scratch_.file("drop");
  std::vector<std::uint8_t> bytes;
  for (const auto& f : frames) {
    auto b = mrawFrameBytes(f, 16);
    bytes.insert(bytes.end(), b.begin(), b.end());
  }
  writeBytes(base + ".mraw", bytes);
  writeText(base + ".cihx", cihxText(kWidth, kHeight, 16, d.frames, kFps, 20000, 0, "mm", 0.25));
  const std::string js = scratch_.file("mraw.json");
  auto run = runCollide("track " + q(base + ".cihx") + " --json " + q(js), scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const json j = readJson(js);
  EXPECT_EQ(j["pixel_size_from"], "file");
  EXPECT_DOUBLE_EQ(j["pixel_size_m"].get<double>(), kPixelM);
  EXPECT_EQ(j["fps"], kFps);
  const json& g = j["spheres"][0]["segments"][0];
  const double ay = g["acceleration_m_s2"][1], sigma = g["acceleration_sigma_m_s2"][1];
  EXPECT_LT(std::abs(ay + kG), 2 * sigma) << ay << " +- " << sigma;
  const Eigen::Vector2d v(g["velocity_m_s"][0].get<double>(), g["velocity_m_s"][1].get<double>());
  EXPECT_LT((v - Eigen::Vector2d(d.vx, d.vy)).norm(), 0.002 * std::hypot(d.vx, d.vy));
}

TEST_F(CliTrack, BacklitFootageForcedToTheWrongPolarityFailsClearly) {
  Drop d;
  d.frames = 30;
  d.backlit = true;
  const std::string dir = writeFolder(d, scratch_.file("backlit"));
  auto run =
      runCollide("track " + q(dir) + " --fps 1000 --diameter-mm 10 --polarity bright", scratch_);
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_THAT(run.err, HasSubstr("no sphere found"));
  EXPECT_THAT(run.err, HasSubstr("--polarity dark"));
  EXPECT_THAT(run.err, HasSubstr(dir));
  for (const char* p : {"dark", "auto"}) {
    run = runCollide("track " + q(dir) + " --fps 1000 --diameter-mm 10 --polarity " + p, scratch_);
    ASSERT_EQ(run.exit_code, 0) << p << ": " << run.err;
    const json j = json::parse(run.out, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << run.out;
    EXPECT_EQ(j["backlit"], true);
    const json& f = j["spheres"][0]["frames"][10];
    EXPECT_NEAR(f["centre_px"][0].get<double>(), d.centrePx(10 / kFps).x(), 0.05) << p;
  }
}

// Not a test: writes the footage docs/benchmarks.md times `collide track` on
// (a 1000-frame 640 x 480 16-bit MRAW of one thrown sphere at 7000 frames/s,
// 0.25 mm pixels in its .cihx) into $COLLIDE_TRACK_BENCH_DIR. Run with
// --gtest_also_run_disabled_tests --gtest_filter=*WriteBenchFootage*.
TEST_F(CliTrack, DISABLED_WriteBenchFootage) {
  const char* dir = std::getenv("COLLIDE_TRACK_BENCH_DIR");
  if (!dir) GTEST_SKIP() << "set COLLIDE_TRACK_BENCH_DIR";
  Drop d;
  d.frames = 1000;
  collide::vision::RenderSettings rs;
  rs.format = collide::vision::PixelFormat::Mono12;
  rs.noise_grey = 30;
  const collide::vision::Renderer renderer(rs);
  std::vector<std::uint8_t> bytes;
  for (int k = 0; k < d.frames; ++k) {
    collide::vision::SphereView v;
    v.centre_px = d.centrePx(k / 7000.0);
    v.radius_px = kRadiusPx;
    auto b = mrawFrameBytes(renderer.render({v}, k), 16);
    bytes.insert(bytes.end(), b.begin(), b.end());
  }
  writeBytes(std::string(dir) + "/bench.mraw", bytes);
  writeText(std::string(dir) + "/bench.cihx",
            cihxText(kWidth, kHeight, 16, d.frames, 7000, 20000, 0, "mm", 0.25));
}

TEST_F(CliTrack, BadInputIsNamed) {
  const Drop d;
  auto run = runCollide("track " + q(scratch_.file("nothing-here")) + " --fps 1000", scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("nothing-here: no such file or folder"));
  Drop small;
  small.frames = 6;
  const std::string dir = writeFolder(small, scratch_.file("few"));
  run = runCollide("track " + q(dir) + " --diameter-mm 10", scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("--fps"));
  run = runCollide("track " + q(dir) + " --fps 1000 --polarity sideways", scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("--polarity 'sideways'"));
  run = runCollide("track " + q(dir) + " --fps 1000 --spheres 4", scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("--spheres '4'"));
  run = runCollide("track " + q(dir) + " --fps 1000 --profile " + q(scratch_.file("no.toml")),
                   scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("no.toml: no such file"));
  run = runCollide("track " + q(dir) + " --fps 1000", scratch_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.err, HasSubstr("--diameter-mm"));
  // A folder of images that are not pictures of spheres at all.
  const std::string blank = scratch_.file("blank");
  fs::create_directories(blank);
  for (int k = 0; k < 5; ++k)
    cv::imwrite(blank + "/f" + std::to_string(k) + ".png", cv::Mat(100, 100, CV_8UC1, 10));
  run = runCollide("track " + q(blank) + " --fps 1000 --diameter-mm 10", scratch_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_THAT(run.err, HasSubstr("no sphere found in any of the 5 frames"));
  run = runCollide("analyze --frames " + q(dir) + " --fps 1000 --diameter-mm 10 --polarity up",
                   scratch_);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("--polarity 'up'"));
}

// Frames of a folder are decoded one at a time: a damaged one is left out,
// named, and the rest is tracked.
TEST_F(CliTrack, ADamagedFrameFileIsLeftOutAndNamed) {
  Drop d;
  d.frames = 40;
  const std::string dir = writeFolder(d, scratch_.file("damaged"));
  writeText(dir + "/frame0020.png", "not a picture");
  const std::string js = scratch_.file("damaged.json");
  auto run =
      runCollide("track " + q(dir) + " --fps 1000 --diameter-mm 10 --json " + q(js), scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.err, HasSubstr("1 frames could not be read"));
  EXPECT_THAT(run.err, HasSubstr("frame0020.png"));
  const json j = readJson(js);
  const json& frames = j["spheres"][0]["frames"];
  ASSERT_EQ(frames.size(), 39u);
  EXPECT_EQ(frames[20]["index"], 21);
  EXPECT_DOUBLE_EQ(frames[20]["t_s"].get<double>(), 21 / kFps);
}

// A video file (8-bit MJPG AVI, lossy): the frame rate from the container.
TEST_F(CliTrack, AVideoFileIsTrackedAtItsOwnFrameRate) {
  const Drop d;
  const std::string avi = scratch_.file("drop.avi");
  cv::VideoWriter w(avi, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), kFps,
                    cv::Size(kWidth, kHeight), false);
  if (!w.isOpened()) GTEST_SKIP() << "this OpenCV build cannot write MJPG AVI files";
  for (const cv::Mat& f : d.render()) {
    cv::Mat f8;
    f.convertTo(f8, CV_8U, 255.0 / 4095);
    w.write(f8);
  }
  w.release();
  const std::string js = scratch_.file("avi.json");
  auto run = runCollide("track " + q(avi) + " --diameter-mm 10 --json " + q(js), scratch_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json j = readJson(js);
  EXPECT_EQ(j["fps"], kFps);
  ASSERT_EQ(j["spheres"][0]["frames"].size(), 150u);
  const json& segs = j["spheres"][0]["segments"];
  ASSERT_EQ(segs.size(), 1u) << segs.dump(1);
  const double s = j["pixel_size_m"], s_rel = j["pixel_size_sigma_m"].get<double>() / s;
  const double ay = segs[0]["acceleration_m_s2"][1], sigma = segs[0]["acceleration_sigma_m_s2"][1];
  EXPECT_LT(std::abs(ay + kG), 2 * std::hypot(sigma, kG * s_rel)) << ay << " +- " << sigma;
  const Eigen::Vector2d v(segs[0]["velocity_m_s"][0].get<double>(),
                          segs[0]["velocity_m_s"][1].get<double>());
  EXPECT_LT((v - Eigen::Vector2d(d.vx, d.vy)).norm(), 0.002 * std::hypot(d.vx, d.vy))
      << v.transpose();
}

// The real camera files of tests/data/footage are read through track (their
// frame counts reach the message); neither shows a sphere, which it says.
TEST_F(CliTrack, TheRealCameraFilesAreReadAndShowNoSphere) {
  const std::string data = std::string(COLLIDE_TEST_DATA_DIR) + "/footage/";
  for (const auto& [file, frames] :
       std::vector<std::pair<std::string, int>>{{"beam.cihx", 4}, {"cine_781.cine", 15}}) {
    auto run = runCollide("track " + q(data + file) + " --diameter-mm 10", scratch_);
    EXPECT_EQ(run.exit_code, 1) << file;
    EXPECT_THAT(run.err, HasSubstr(file + ": no sphere found in any of the " +
                                   std::to_string(frames) + " frames"));
  }
}

}  // namespace
