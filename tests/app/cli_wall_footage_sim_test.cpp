// A sphere-on-wall shot from the simulated rig (config/sim-wall.toml) exported
// as PNG frames and read back as footage recorded elsewhere: `collide analyze
// --frames --wall` (face found in the frames, scale from the sphere) and
// `--wall-line` (the face given in pixels) both give the true e and the true
// beta against the wall; a bad --wall-line is refused, naming the flag.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "analysis/walton.hpp"
#include "app/report/results_json.hpp"
#include "app/store/shot_file.hpp"
#include "hw/camera_sim.hpp"
#include "hw/rig_profile.hpp"
#include "tests/app/cli_run.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

namespace fs = std::filesystem;
using namespace collide;
using namespace collide::testing;
using ::testing::HasSubstr;

const std::string kRig = std::string(COLLIDE_SOURCE_DIR) + "/config/sim-wall.toml";

// beta against the wall from the truth just before and after the impact.
double trueBeta(const hw::Shot& shot) {
  const hw::TruthRecord& t = *shot.truth;
  std::size_t k = 0;
  while (k + 1 < t.t_s.size() && t.t_s[k + 1] <= t.t_collision_s) ++k;
  Sphere side[2];
  for (int i = 0; i < 2; ++i) {
    const SphereState& s = t.states.at(k + i)[0];
    const double dt = t.t_collision_s - t.t_s[k + i];
    side[i].mass_kg = shot.scene.mass_kg[0];
    side[i].diameter_m = shot.scene.diameter_m[0];
    side[i].position_m = s.position_m + s.velocity_m_s * dt + 0.5 * kGravity_m_s2 * dt * dt;
    side[i].velocity_m_s = s.velocity_m_s + kGravity_m_s2 * dt;
    side[i].spin_rad_s = s.spin_rad_s;
  }
  side[1].position_m = side[0].position_m;
  auto p = hw::parseRigProfile(shot.rig_profile_toml, "shot");
  auto m = measureWallCollision(side[0], side[1], *p->wall);
  return m ? m->beta : NAN;
}

TEST(CliWallFootage, AnalyzeFramesWithWallOrWallLineGivesTheTrueEAndBeta) {
  ScratchDir scratch;
  const std::string dir = scratch.file("campaign");
  auto run = runCollide("campaign --rig " + q(kRig) + " --shots 1 --seed 3 --out " + q(dir) +
                            " --angle-min-deg 40 --angle-max-deg 40",
                        scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::string file;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".h5") file = e.path().string();
  auto shot = app::readShot(file);
  ASSERT_TRUE(shot.ok());
  const std::string frames = scratch.file("frames");
  run = runCollide("export " + q(file) + " --png " + q(frames), scratch);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const double beta_true = trueBeta(*shot);
  ASSERT_TRUE(std::isfinite(beta_true));

  // The face from the profile, as two pixels on it.
  auto profile = hw::parseRigProfile(shot->rig_profile_toml, "shot");
  auto line = hw::wallInImage(*profile);
  ASSERT_TRUE(line);
  const Eigen::Vector2d along(-line->normal.y(), line->normal.x());
  const Eigen::Vector2d a = line->point_px - 100 * along, b = line->point_px + 100 * along;
  char given[160];
  std::snprintf(given, sizeof given, "--wall-line %.6f,%.6f,%.6f,%.6f", a.x(), a.y(), b.x(), b.y());

  for (const std::string& how : {std::string("--wall"), std::string(given)}) {
    const std::string json = scratch.file("wall.json");
    run =
        runCollide("analyze --frames " + q(frames) + " --fps " + std::to_string(shot->camera.fps) +
                       " --diameter-mm 25.4 " + how + " --json " + q(json),
                   scratch);
    ASSERT_EQ(run.exit_code, 0) << how << ": " << run.err;
    const std::string text = readAll(json);
    EXPECT_THAT(text, HasSubstr("\"target\": \"wall\"")) << how;
    auto r = app::parseResultsJson(text);
    ASSERT_TRUE(r.ok()) << how;
    EXPECT_NEAR(r->collision.e.value, shot->truth->material.e, 0.005) << how;
    EXPECT_NEAR(r->collision.beta.value, beta_true, 0.03) << how;
  }
  run = runCollide(
      "analyze --frames " + q(frames) + " --fps 1000 --diameter-mm 25.4 " + "--wall-line 1,2,1,2",
      scratch);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_THAT(run.err, HasSubstr("--wall-line"));
}

}  // namespace
