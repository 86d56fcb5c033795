// The [wall] table of a rig profile (config/sim-wall.toml) and the plate the
// simulated camera draws for it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <regex>
#include <sstream>

#include "hw/camera_sim.hpp"
#include "hw/rig.hpp"
#include "hw/rig_profile.hpp"
#include "hw/sequencer.hpp"
#include "vision/render_wall.hpp"
#include "vision/wall_line.hpp"

namespace collide::hw {
namespace {

using ::testing::HasSubstr;

std::string fileText(const std::string& relative) {
  std::ifstream in(std::string(COLLIDE_SOURCE_DIR) + "/" + relative);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
std::string wallText() {
  return fileText("config/sim-wall.toml");
}

// bench/profiles/wall-lab.toml: the plate through sim-lab's lens (perspective
// and barrel distortion), its plate turned to `normal_deg` (the normal's
// angle in the world x-y plane).
RigProfile lensWallProfile(double normal_deg) {
  auto p = parseRigProfile(fileText("bench/profiles/wall-lab.toml"), "wall-lab.toml");
  EXPECT_TRUE(p) << p.error().message;
  const double a = normal_deg * std::numbers::pi / 180;
  p->wall->normal = Vec3(std::cos(a), std::sin(a), 0.0);
  return *p;
}

TEST(WallProfile, SimWallParsesWithAUnitNormalFacingLauncherOne) {
  auto p = parseRigProfile(wallText(), "sim-wall.toml");
  ASSERT_TRUE(p) << p.error().message;
  ASSERT_TRUE(p->wall);
  EXPECT_NEAR(p->wall->normal.norm(), 1.0, 1e-12);
  EXPECT_GT((p->launchers[0].exit_m - p->wall->point_m).dot(p->wall->normal), 0.0);
  auto plain = defaultRigProfile();
  ASSERT_TRUE(plain);
  EXPECT_FALSE(plain->wall);
}

TEST(WallProfile, ErrorsNameTheFieldAndWhatToDo) {
  const std::string text = wallText();
  auto flipped = parseRigProfile(
      std::regex_replace(text, std::regex(R"(normal = \[[^\]]*\])"), "normal = [0.766, -0.643, 0]"),
      "flipped.toml");
  ASSERT_FALSE(flipped);
  EXPECT_THAT(flipped.error().message, HasSubstr("wall.normal"));
  EXPECT_THAT(flipped.error().message, HasSubstr("flip the normal"));
  auto zero = parseRigProfile(
      std::regex_replace(text, std::regex(R"(normal = \[[^\]]*\])"), "normal = [0, 0, 0]"),
      "zero.toml");
  ASSERT_FALSE(zero);
  EXPECT_THAT(zero.error().message, HasSubstr("wall.normal"));
  auto unknown = parseRigProfile(
      std::regex_replace(text, std::regex(R"(level = 0.0 )"), "colour = 1.0 "), "unknown.toml");
  ASSERT_FALSE(unknown);
  EXPECT_THAT(unknown.error().message, HasSubstr("colour"));
  auto missing = parseRigProfile(
      std::regex_replace(text, std::regex(R"(point_m = \[[^\]]*\])"), ""), "missing.toml");
  ASSERT_FALSE(missing);
  EXPECT_THAT(missing.error().message, HasSubstr("point_m"));
  // A wall rig drives real valves too: the sequencer never opens launcher 2.
  auto real_valves =
      parseRigProfile(std::regex_replace(text, std::regex(R"(\[valves\]\nbackend = "sim")"),
                                         "[valves]\nbackend = \"gpiod\""),
                      "gpiod-wall.toml");
  EXPECT_TRUE(real_valves) << real_valves.error().message;
}

// The sequencer fires launcher 1 only on a wall rig: launcher 2 is held at
// 0 kPa and its valve never opens (on real valves it would fire a sphere into
// the room), while launcher 1's pulse is the profile's.
TEST(WallProfile, TheSequencerFiresLauncherOneOnly) {
  auto profile = parseRigProfile(wallText(), "sim-wall.toml");
  ASSERT_TRUE(profile) << profile.error().message;
  auto rig = makeRig(*profile);
  ASSERT_TRUE(rig) << rig.error().message;
  const Shot shot = Sequencer(*rig).fire(ShotRequest::atSpeeds(2.0, 2.0));
  (void)shutDown(*rig);
  ASSERT_EQ(shot.status, ShotStatus::Ok) << shot.failure_reason;
  EXPECT_GT(shot.launchers[0].valve_open_ns, 0);
  EXPECT_EQ(shot.launchers[0].pulse_us, profile->sequencer.pulse_us);
  EXPECT_EQ(shot.launchers[1].valve_open_ns, 0);
  EXPECT_EQ(shot.launchers[1].pulse_us, 0);
  EXPECT_EQ(shot.launchers[1].commanded_kPa, 0.0);
  bool said = false;
  for (const auto& step : shot.steps)
    if (step.name == "fire") said = step.detail.find("stays shut") != std::string::npos;
  EXPECT_TRUE(said) << "the fire step should say launcher 2 stays shut";
}

TEST(WallProfile, TheFaceLineInTheImageFollowsTheGeometry) {
  auto p = parseRigProfile(wallText(), "sim-wall.toml");
  ASSERT_TRUE(p);
  auto line = wallInImage(*p);
  ASSERT_TRUE(line);
  // The world point on the face maps to a pixel on the line; the image normal
  // is the world normal with v flipped.
  const double px = p->geometry.pixel_size_m;
  const Eigen::Vector2d at(p->geometry.origin_u_px + p->wall->point_m.x() / px,
                           p->geometry.origin_v_px - p->wall->point_m.y() / px);
  EXPECT_NEAR(line->distancePx(at.x(), at.y()), 0.0, 1e-9);
  EXPECT_NEAR(line->normal.x(), p->wall->normal.x(), 1e-12);
  EXPECT_NEAR(line->normal.y(), -p->wall->normal.y(), 1e-12);
}

TEST(WallRender, PlateCoverageIsTheAreaBehindTheFace) {
  // A vertical face at u = 10.3: column 10 is 20 % behind it, 11 and beyond
  // fully, up to the band's back edge.
  cv::Mat img(4, 40, CV_16UC1, cv::Scalar(1000));
  vision::WallLine line;
  line.point_px = {10.3, 0.0};
  line.normal = {-1.0, 0.0};  // the sphere's side is u < 10.3
  vision::WallLook look;
  look.thickness_px = 20;
  look.level = 0.0;
  vision::drawWall(img, 4095, line, look);
  EXPECT_EQ(img.at<std::uint16_t>(1, 9), 1000);
  EXPECT_EQ(img.at<std::uint16_t>(1, 10), 800);  // 0.2 of the pixel on the plate
  EXPECT_EQ(img.at<std::uint16_t>(1, 11), 0);
  EXPECT_EQ(img.at<std::uint16_t>(1, 29), 0);
  EXPECT_EQ(img.at<std::uint16_t>(1, 30), 200);  // back edge at u = 30.3
  EXPECT_EQ(img.at<std::uint16_t>(1, 31), 1000);
  // A diagonal face: the plate's share of the whole image equals the area
  // behind the line (a triangle) to within the pixels' rounding.
  cv::Mat sq(100, 100, CV_16UC1, cv::Scalar(4000));
  line.point_px = {49.5, 49.5};
  line.normal = Eigen::Vector2d(-1.0, -1.0).normalized();
  look.thickness_px = 1000;
  vision::drawWall(sq, 4095, line, look);
  const double dark = 100 * 100 - cv::sum(sq)[0] / 4000.0;
  EXPECT_NEAR(dark, 0.5 * 100 * 100, 0.5);
}

// Under a lens that bends straight lines, the plate's face is drawn where the
// lens puts the face's points: the line wallInImage gives, bent by
// wallBendInImage (an independent check: each point projected on its own).
TEST(WallRender, ALensBendsTheFaceAsItBendsTheFacesPoints) {
  const RigProfile p = lensWallProfile(140.0);
  auto lens = simulatedLens(p);
  ASSERT_TRUE(lens && *lens);
  ASSERT_TRUE((*lens)->distorted());
  const auto line = wallInImage(p);
  ASSERT_TRUE(line);
  const vision::WallBend bend = wallBendInImage(p, *line);
  ASSERT_FALSE(bend.offset_px.empty());
  const Vec3 along = Vec3::UnitZ().cross(p.wall->normal).normalized();
  const Eigen::Vector2d t(-line->normal.y(), line->normal.x());
  double largest = 0;
  int inside = 0;
  for (double k = -0.2; k <= 0.2; k += 0.005) {  // metres along the face
    const Eigen::Vector2d q = (*lens)->project(p.wall->point_m + k * along);
    if (q.x() < 0 || q.y() < 0 || q.x() > 639 || q.y() > 479) continue;
    ++inside;
    const double s = (q - line->point_px).dot(t);
    EXPECT_NEAR(line->distancePx(q.x(), q.y()), bend.at(s), 2e-3) << "at " << k << " m";
    largest = std::max(largest, std::abs(bend.at(s)));
  }
  EXPECT_GT(inside, 20);
  EXPECT_GT(largest, 0.05);  // the bend is several times the edge's sub-pixel precision
  // Through sim-wall.toml's orthographic optics there is nothing to bend.
  auto plain = parseRigProfile(wallText(), "sim-wall.toml");
  ASSERT_TRUE(plain);
  EXPECT_TRUE(wallBendInImage(*plain, *wallInImage(*plain)).offset_px.empty());
}

// A bend of a constant 2 px draws the face exactly as the line moved by 2 px.
TEST(WallRender, AConstantBendIsTheLineMoved) {
  vision::WallLine line;
  line.point_px = {30.4, 20.0};
  line.normal = Eigen::Vector2d(-1.0, 0.3).normalized();
  vision::WallLook look;
  look.thickness_px = 15;
  vision::WallBend bend;
  bend.first_px = -100;
  bend.offset_px.assign(201, 2.0);
  cv::Mat bent(40, 60, CV_16UC1, cv::Scalar(3000)), moved = bent.clone();
  vision::drawWall(bent, 4095, line, look, bend);
  vision::WallLine shifted = line;
  shifted.point_px += 2.0 * line.normal;
  vision::drawWall(moved, 4095, shifted, look);
  EXPECT_EQ(cv::norm(bent, moved, cv::NORM_INF), 0.0);
  EXPECT_DOUBLE_EQ(bend.at(-1000), 2.0);  // the end values beyond the table
}

// Nine frames of the plate's face `line`, bent by `bend`, on a grey
// background, with noise as the simulated camera's (seeded by `seed`).
vision::Burst plateFrames(const vision::WallLine& line, const vision::WallBend& bend,
                          std::uint64_t seed) {
  vision::Burst burst;
  burst.format = vision::PixelFormat::Mono16;
  cv::RNG rng(seed);
  for (int f = 0; f < 9; ++f) {
    vision::Frame fr;
    fr.id = f;
    fr.image = cv::Mat(480, 640, CV_16UC1, cv::Scalar(2400));
    cv::Mat noise(480, 640, CV_16SC1);
    rng.fill(noise, cv::RNG::NORMAL, 0, 12);
    cv::add(fr.image, noise, fr.image, cv::noArray(), CV_16UC1);
    vision::WallLook look;
    look.level = 0.05;
    look.noise_grey = 12;
    look.noise_seed = 100 * seed + f;
    vision::drawWall(fr.image, 4095, line, look, bend);
    burst.frames.push_back(fr);
  }
  return burst;
}

// The face found through the lens: its direction on the collision plane
// against the plate's (the profile's, not the code under test), within its
// stated sigma, for plates turned several ways; frames drawn with the face
// bent and noisy as the simulated camera draws them.
TEST(WallLine, FoundThroughALensWithinItsSigma) {
  double sum2 = 0;
  int n = 0;
  for (double normal_deg : {100.0, 125.0, 140.0, 160.0, 200.0}) {
    const RigProfile p = lensWallProfile(normal_deg);
    auto lens = simulatedLens(p);
    ASSERT_TRUE(lens && *lens);
    const auto line = wallInImage(p);
    ASSERT_TRUE(line);
    const vision::WallBend bend = wallBendInImage(p, *line);
    const vision::Burst burst = plateFrames(*line, bend, static_cast<std::uint64_t>(normal_deg));
    vision::WallLine guess = *line;
    guess.point_px += 1.5 * line->normal;  // a guess off by 1.5 px
    auto fit = vision::findWallLine(burst, guess, std::nullopt, &**lens);
    ASSERT_TRUE(fit) << fit.error().message;
    // Fitted where the face is straight, the bend does not widen the sigma
    // beyond that of the same face drawn unbent (through no lens): a bent
    // line's stretches disagree, and the jackknife would take that for noise.
    auto flat = vision::findWallLine(plateFrames(*line, {}, static_cast<std::uint64_t>(normal_deg)),
                                     guess, std::nullopt, nullptr);
    ASSERT_TRUE(flat) << flat.error().message;
    EXPECT_LT(fit->angle_sigma_rad, 1.5 * flat->angle_sigma_rad) << normal_deg << " deg";
    // The found line through the lens onto z = 0, as the wall analysis takes it.
    const Eigen::Vector2d t(-fit->line.normal.y(), fit->line.normal.x());
    const Eigen::Vector2d a = fit->line.point_px - 50 * t, b = fit->line.point_px + 50 * t;
    const Vec3 d = (*lens)->onPlane(b.x(), b.y()) - (*lens)->onPlane(a.x(), a.y());
    const Vec3 truth = Vec3::UnitZ().cross(p.wall->normal).normalized();
    const double err = std::asin(d.normalized().cross(truth).z());
    const double err_folded =
        std::abs(err) > std::numbers::pi / 2 ? std::numbers::pi - std::abs(err) : std::abs(err);
    EXPECT_LT(err_folded, 4 * fit->angle_sigma_rad) << normal_deg << " deg";
    EXPECT_LT(fit->angle_sigma_rad, 5e-4) << normal_deg << " deg";
    sum2 += (err_folded / fit->angle_sigma_rad) * (err_folded / fit->angle_sigma_rad);
    ++n;
  }
  EXPECT_LT(std::sqrt(sum2 / n), 2.0);
}

// An edge whose crossings wander together along it (a slow wave of 0.15 px,
// 450 px long, as a pixel-phase bias or a plate's unevenness makes): the
// line's angle is off by far more than independent residuals explain, and the
// jackknife over stretches of the edge widens its sigma to cover it.
TEST(WallLine, ResidualsThatWanderTogetherWidenTheAngleSigma) {
  vision::WallLine line;
  line.point_px = {320.0, 240.0};
  line.normal = Eigen::Vector2d(-0.9, 0.2).normalized();
  double worst_independent_pull = 0;
  for (double phase : {0.0, 0.9, 1.7, 2.6, 3.9, 5.1}) {
    vision::WallBend wave;
    wave.first_px = -800;
    for (int k = 0; k <= 1600; ++k)
      wave.offset_px.push_back(0.15 * std::sin(2 * std::numbers::pi * (k - 800) / 450.0 + phase));
    auto fit = vision::findWallLine(plateFrames(line, wave, 7), line, std::nullopt, nullptr);
    ASSERT_TRUE(fit) << fit.error().message;
    const double err =
        std::asin(fit->line.normal.x() * line.normal.y() - fit->line.normal.y() * line.normal.x());
    // What independent residuals would give: rms / sqrt(points * L^2 / 12)
    // with L = 2 px times the points.
    const double m = fit->points, independent = fit->residual_rms_px / std::sqrt(m * m * m / 3.0);
    worst_independent_pull = std::max(worst_independent_pull, std::abs(err) / independent);
    EXPECT_LT(std::abs(err), 4 * fit->angle_sigma_rad) << "phase " << phase;
    EXPECT_GT(fit->angle_sigma_rad, 2 * independent) << "phase " << phase;
    EXPECT_LT(fit->angle_sigma_rad, 1e-3) << "phase " << phase;
  }
  EXPECT_GT(worst_independent_pull, 6.0);  // the premise: independent sigmas fail here
}

}  // namespace
}  // namespace collide::hw
