// The [wall] table of a rig profile (config/sim-wall.toml) and the plate the
// simulated camera draws for it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>

#include "hw/camera_sim.hpp"
#include "hw/rig.hpp"
#include "hw/rig_profile.hpp"
#include "hw/sequencer.hpp"
#include "vision/render_wall.hpp"

namespace collide::hw {
namespace {

using ::testing::HasSubstr;

std::string wallText() {
  std::ifstream in(std::string(COLLIDE_SOURCE_DIR) + "/config/sim-wall.toml");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
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

}  // namespace
}  // namespace collide::hw
