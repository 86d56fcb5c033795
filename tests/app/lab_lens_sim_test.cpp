// Two spheres filmed through config/sim-lab.toml's lens and one-sided lamp,
// with the spheres held in the image plane (no out-of-plane drift, no tilt of
// the line of centres): what is left of the centres' error is the detector's
// own and the lamp's. Under perspective the lit part of each limb is seen from
// a changing angle as a sphere crosses the field, so the detected centre
// drifts along a track (5-25 um across the field on the probe of
// docs/benchmarks.md, session 32), which a straight fit takes for velocity.
// The analysis carries that drift, the profile's radius_systematic_px over
// each track's span, in every fit's velocity sigma (vision/shot_fits.hpp,
// centreDriftSigma_m_s); these tests check it is there and that the stated
// sigmas then cover the true velocities.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <regex>
#include <vector>

#include "app/analyze.hpp"
#include "app/plan.hpp"
#include "app/rig_setup.hpp"
#include "bench/truth_at_contact.hpp"
#include "hw/rig_profile.hpp"
#include "shot_fixtures.hpp"
#include "vision/shot_analysis.hpp"

namespace collide::app {
namespace {

hw::RigProfile labInThePlane() {
  std::string text = testing::readAll(std::string(COLLIDE_SOURCE_DIR) + "/config/sim-lab.toml");
  for (const char* key : {"contact_tilt_deg", "out_of_plane_drift"}) {
    const std::regex line(std::string("\n") + key + R"(\s*=\s*[0-9.eE+-]+)");
    EXPECT_TRUE(std::regex_search(text, line)) << key << " is no longer in sim-lab.toml";
    text = std::regex_replace(text, line, std::string("\n") + key + " = 0.0");
  }
  auto p = hw::parseRigProfile(text, "sim-lab.toml (in the plane)");
  EXPECT_TRUE(p.ok()) << p.error().message;
  return p.ok() ? *p : hw::RigProfile{};  // an empty profile: the shots then fail, named
}

struct LabShot {
  double incidence_deg = 0;
  vision::ShotAnalysis analysis;
  vision::AnalysisSettings settings;
  std::array<Sphere, 2> before, after;  ///< the truth at the contact
};

LabShot fireLabShot(const hw::RigProfile& profile, double incidence_deg, std::uint64_t seed) {
  PlanRequest req;
  req.incidence_deg = incidence_deg;
  req.speed_m_s = {1.5, 1.5};
  auto plan = planShot(profile, req);
  EXPECT_TRUE(plan.ok()) << incidence_deg << ": " << plan.error().message;
  if (!plan.ok()) return {};
  plan->aimed.simulation.seed = seed;
  auto shot = fireShot(plan->aimed,
                       hw::ShotRequest::atSpeeds(plan->exit_speed_m_s[0], plan->exit_speed_m_s[1]),
                       "lab-lens");
  EXPECT_TRUE(shot.ok()) << shot.error().message;
  if (!shot.ok()) return {};
  EXPECT_EQ(shot->status, hw::ShotStatus::Ok) << shot->failure_reason;
  LabShot out;
  out.settings = analysisSettingsFor(*shot);
  auto r = vision::analyzeBurst(shot->burst, out.settings);
  EXPECT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(bench::truthAtContact(*shot, out.before, out.after)) << "no contact in the truth";
  if (r.ok()) out.analysis = *r;
  return out;
}

// Sixteen shots, mostly nearly head-on (where accuracy_bench saw the largest
// post-impact pulls on this profile), each with a seed of its own; fired
// once and shared by the tests below.
const std::vector<LabShot>& labShots() {
  static const std::vector<LabShot> shots = [] {
    const hw::RigProfile profile = labInThePlane();
    std::vector<LabShot> out;
    std::uint64_t seed = 500;
    for (const double incidence : {10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 25.0})
      for (int repeat = 0; repeat < 2; ++repeat) {
        out.push_back(fireLabShot(profile, incidence, ++seed));
        out.back().incidence_deg = incidence;
      }
    return out;
  }();
  return shots;
}

TEST(LabLensSim, EveryFitsVelocitySigmaHoldsTheLampsDrift) {
  for (const LabShot& s : labShots()) {
    ASSERT_TRUE(s.settings.camera) << "the lab's lens did not reach the analysis";
    const double px = s.analysis.pixel_size_m;
    ASSERT_GT(px, 0);
    for (int sphere = 0; sphere < 2; ++sphere)
      for (int side = 0; side < 2; ++side) {
        const auto& fit = s.analysis.trajectory[sphere][side];
        ASSERT_TRUE(fit) << s.incidence_deg << " deg";
        const double span = fit->tLast_s() - fit->tFirst_s();
        ASSERT_GT(span, 0);
        // The lamp's drift alone; the Monte Carlo's 300 draws give its
        // spread to a few per cent. Without it 42 of these 128 sigmas were
        // below it, the smallest at 0.28 of it.
        const double lamp = s.settings.radius_systematic_px * px / span;
        const auto& k = s.analysis.sphere[sphere];
        const Vec3 sigma = side == 0 ? k.velocity_before_m_s.sigma : k.velocity_after_m_s.sigma;
        for (int ax = 0; ax < 2; ++ax)
          EXPECT_GT(sigma[ax], 0.9 * lamp) << s.incidence_deg << " deg, sphere " << sphere + 1
                                           << (side ? " after" : " before") << ", axis " << ax;
      }
  }
}

// Against the simulation's truth at the contact: no pull beyond 4, and each
// image axis' pulls with an RMS in 0.5-1.5 (issue 12's yardstick). Without the
// lamp's drift the pulls on y (mostly across the motion) had RMS 1.53, one of
// them 5.6.
TEST(LabLensSim, TheStatedSigmasCoverTheTrueVelocities) {
  std::array<double, 2> sum2{};
  int n = 0;
  for (const LabShot& s : labShots()) {
    for (int sphere = 0; sphere < 2; ++sphere)
      for (int side = 0; side < 2; ++side) {
        const auto& k = s.analysis.sphere[sphere];
        const Estimate3& v = side == 0 ? k.velocity_before_m_s : k.velocity_after_m_s;
        const Vec3 truth = (side == 0 ? s.before : s.after)[sphere].velocity_m_s;
        for (int ax = 0; ax < 2; ++ax) {
          const double pull = (v.value[ax] - truth[ax]) / v.sigma[ax];
          std::printf("%2.0f deg, sphere %d %s, axis %d: error %+.2f mm/s, pull %+.2f\n",
                      s.incidence_deg, sphere + 1, side ? "after " : "before", ax,
                      1e3 * (v.value[ax] - truth[ax]), pull);
          EXPECT_LT(std::abs(pull), 4.0) << s.incidence_deg << " deg, sphere " << sphere + 1
                                         << (side ? " after" : " before") << ", axis " << ax;
          sum2[ax] += pull * pull;
        }
        ++n;
      }
  }
  ASSERT_EQ(n, 64);
  for (int ax = 0; ax < 2; ++ax) {
    const double rms = std::sqrt(sum2[ax] / n);
    std::printf("axis %d: pull RMS %.2f over %d velocities\n", ax, rms, n);
    EXPECT_GT(rms, 0.5) << "axis " << ax << ": the sigmas are far too wide";
    EXPECT_LT(rms, 1.5) << "axis " << ax << ": the sigmas do not cover the errors";
  }
}

}  // namespace
}  // namespace collide::app
