// How well `collide plan` aims (issue 16 §1): plans across 10-80 degrees and
// 1.6-2.6 m/s fired on the simulated rig, the incidence and speeds at contact
// compared with what was asked, from the ground truth (the centres' relative
// velocity and line of centres at contact) and from the analysis.
//
//   build/bench/plan_bench [--shots N] [--seed S]
//
// Two rigs: config/sim.toml without launch scatter or spin (the planner's own
// accuracy), and as it is (speed scatter 1 %, direction 2 mrad, spin up to
// 20 rad/s: what a campaign really gets). Figures go in docs/benchmarks.md.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <regex>
#include <string>

#include "analysis/walton.hpp"
#include "app/analyze.hpp"
#include "app/plan.hpp"
#include "app/rig_setup.hpp"
#include "bench/truth_at_contact.hpp"
#include "hw/rig_profile.hpp"
#include "vision/shot_analysis.hpp"

using namespace collide;

namespace {

constexpr double kDeg = 180.0 / 3.14159265358979323846;

struct Stat {
  double sum2 = 0, worst = 0;
  int n = 0;
  void add(double x) { sum2 += x * x, worst = std::max(worst, std::abs(x)), ++n; }
  double rms() const { return n ? std::sqrt(sum2 / n) : NAN; }
};

// Incidence of the centres (deg, 0 head-on) from two spheres at contact.
double centreIncidence(const std::array<Sphere, 2>& s) {
  const Vec3 n = (s[0].position_m - s[1].position_m).normalized();
  const Vec3 approach = -(s[0].velocity_m_s - s[1].velocity_m_s).normalized();
  return std::acos(std::clamp(n.dot(approach), -1.0, 1.0)) * kDeg;
}

void run(const char* title, const hw::RigProfile& profile, int shots, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> speed(1.6, 2.6);
  Stat truth_deg, analysed_deg, speed_rel;
  int planned = 0, refused = 0, fired = 0, analysed = 0;
  double plan_s = 0;
  for (int i = 0; i < shots; ++i) {
    app::PlanRequest req;
    req.incidence_deg = 10 + 70.0 * (i + 0.5) / shots;
    req.speed_m_s = {speed(rng), speed(rng)};
    const auto t0 = std::chrono::steady_clock::now();
    app::Infeasible why;
    auto plan = app::planShot(profile, req, &why);
    plan_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!plan) {
      ++refused;
      std::printf("  %.1f deg at %.2f/%.2f m/s refused: %s\n", req.incidence_deg, req.speed_m_s[0],
                  req.speed_m_s[1], plan.error().message.c_str());
      if (!why.nearest) continue;
      req = *why.nearest;
      plan = app::planShot(profile, req);
      if (!plan) continue;
    }
    ++planned;
    plan->aimed.simulation.seed = seed * 7919 + i;
    auto shot = app::fireShot(
        plan->aimed, hw::ShotRequest::atSpeeds(plan->exit_speed_m_s[0], plan->exit_speed_m_s[1]),
        "plan");
    if (!shot || shot->status != hw::ShotStatus::Ok || !shot->truth) continue;
    ++fired;
    std::array<Sphere, 2> tb, ta;
    if (!bench::truthAtContact(*shot, tb, ta)) continue;
    truth_deg.add(centreIncidence(tb) - req.incidence_deg);
    auto r = vision::analyzeBurst(shot->burst, app::analysisSettingsFor(*shot));
    if (!r) continue;
    ++analysed;
    analysed_deg.add(180.0 - r->collision.gamma_deg.value - req.incidence_deg);
    for (int s = 0; s < 2; ++s)
      speed_rel.add(r->sphere[s].velocity_before_m_s.value.norm() / req.speed_m_s[s] - 1);
  }
  std::printf(
      "%s: %d asked, %d planned (%d refused, their nearest feasible shot fired), %d fired, %d "
      "analysed; planning %.1f ms per shot\n"
      "  incidence error from the truth: RMS %.3f deg, worst %.3f deg\n"
      "  incidence measured by the analysis (180 - gamma, spin included): RMS %.3f deg, worst "
      "%.3f deg\n"
      "  speed at contact measured by the analysis: RMS %.2f %%, worst %.2f %%\n",
      title, shots, planned, refused, fired, analysed, 1e3 * plan_s / std::max(1, shots),
      truth_deg.rms(), truth_deg.worst, analysed_deg.rms(), analysed_deg.worst,
      100 * speed_rel.rms(), 100 * speed_rel.worst);
}

}  // namespace

int main(int argc, char** argv) {
  int shots = 40;
  std::uint64_t seed = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--shots")) shots = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--seed")) seed = std::strtoull(argv[i + 1], nullptr, 10);
  }
  auto as_is = hw::loadRigProfile(std::string(COLLIDE_SOURCE_DIR) + "/config/sim.toml");
  if (!as_is) {
    std::fprintf(stderr, "%s\n", as_is.error().message.c_str());
    return 1;
  }
  std::string text = as_is->text;
  for (const char* key : {"speed_scatter", "direction_scatter_rad"})
    text = std::regex_replace(text, std::regex(std::string(key) + R"(\s*=\s*[0-9.eE+-]+)"),
                              std::string(key) + " = 0.0");
  text = std::regex_replace(text, std::regex(R"(spin_at_exit_rad_s\s*=\s*\[[^\]]*\])"),
                            "spin_at_exit_rad_s = [0.0, 0.0]");
  auto exact = hw::parseRigProfile(text, "config/sim.toml without scatter or spin");
  if (!exact) {
    std::fprintf(stderr, "%s\n", exact.error().message.c_str());
    return 1;
  }
  run("config/sim.toml without scatter or spin", *exact, shots, seed);
  run("config/sim.toml as it is (scatter, spin)", *as_is, shots, seed);
  return 0;
}
