// Shots needed to reach target uncertainties of mu and beta_0 (issue 16 §2):
// the adaptive campaign (analysis/adaptive_design.hpp) against today's
// uniform sweep, median over seeded runs, for several materials.
//
//   build/bench/adaptive_bench [--runs N] [--budget N] [--sigma-beta S]
//
// Shots are drawn from Walton's model with measurement noise like the
// analysis reports on the simulated rig's lab imaging (sigma_beta = S / sin psi,
// S = 0.01 by default; speeds 2 m/s each, 0.01 m/s per velocity component;
// e to 0.005): beta(x) = min(beta_0, -1 + (1 + 1/K)(1 + e) mu x), x = cot psi.
// The uniform sweep fires `budget` evenly spaced angles over 10-80 degrees in
// random order (app::planCampaign's design); both stop at the first shot after
// which the campaign fit's sigma_mu <= 0.005 and sigma_beta0 <= 0.02. A
// second table draws contact speeds over 2-6 m/s and compares the design
// choosing the speed with it choosing the angle only, for velocity errors
// flat in speed and growing as speed^2.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "analysis/adaptive_design.hpp"

using namespace collide;

namespace {

struct MaterialCase {
  const char* name;
  Material m;
};

// One campaign: shots until the targets are met (budget + 1 if never) and the
// fit's errors against the truth at that point, in sigmas.
struct RunResult {
  int shots = 0;
  double mu_pull = NAN, beta0_pull = NAN;
};

RunResult finish(int shots, std::span<const CampaignShot> all, const Material& m,
                 const AdaptiveOptions& o) {
  RunResult r;
  r.shots = shots;
  const AdaptiveStatus st = assessCampaign(all, o);
  if (st.friction) {
    r.mu_pull = (st.friction->mu.value - m.mu) / st.friction->mu.sigma;
    r.beta0_pull = (st.friction->beta0.value - m.beta0) / st.friction->beta0.sigma;
  }
  return r;
}

// Contact speeds drawn uniformly over [min, max] m/s for a shot whose speed
// the design does not choose (as app::planCampaign draws exit speeds); an
// empty range (the first table): every shot at the noise's own speed.
struct SpeedRange {
  double min = 0, max = 0;
};

double drawnSpeed(const SpeedRange& range, const ShotNoise& n, std::mt19937_64& rng) {
  if (!(range.max > range.min)) return n.relative_speed_m_s;
  return std::uniform_real_distribution<double>(range.min, range.max)(rng);
}

RunResult uniformRun(const Material& m, const ShotNoise& n, int budget, std::uint64_t seed,
                     const AdaptiveOptions& o, const SpeedRange& speeds = {}) {
  std::mt19937_64 rng(seed);
  std::vector<double> angles;
  for (int i = 0; i < budget; ++i)
    angles.push_back(o.angle_min_deg + (o.angle_max_deg - o.angle_min_deg) * (i + 0.5) / budget);
  std::shuffle(angles.begin(), angles.end(), rng);
  std::vector<CampaignShot> shots;
  for (int i = 0; i < budget; ++i) {
    ShotNoise at = n;
    at.relative_speed_m_s = drawnSpeed(speeds, n, rng);
    shots.push_back(synthesizeShot(m, angles[i], at, rng));
    if (shots.size() >= 6 && assessCampaign(shots, o).targets_met)
      return finish(i + 1, shots, m, o);
  }
  return finish(budget + 1, shots, m, o);
}

RunResult adaptiveRun(const Material& m, const ShotNoise& n, int budget, std::uint64_t seed,
                      const AdaptiveOptions& o, bool print, const SpeedRange& speeds = {}) {
  std::mt19937_64 rng(seed);
  std::vector<CampaignShot> shots;
  for (int i = 0; i < budget; ++i) {
    const AdaptiveStatus st = assessCampaign(shots, o);
    if (st.targets_met) return finish(i, shots, m, o);
    auto next = chooseNextShot(shots, st, o);
    if (!next) {
      std::fprintf(stderr, "%s\n", next.error().message.c_str());
      return finish(budget + 1, shots, m, o);
    }
    if (print)
      std::printf("    shot %2d: %.1f deg: %s\n", i + 1, next->incidence_deg, next->why.c_str());
    ShotNoise at = n;
    at.relative_speed_m_s = drawnSpeed(speeds, n, rng);  // drawn always: same draws either way
    if (std::isfinite(next->speed_m_s)) at.relative_speed_m_s = next->speed_m_s;
    shots.push_back(synthesizeShot(m, next->incidence_deg, at, rng));
  }
  return finish(assessCampaign(shots, o).targets_met ? budget : budget + 1, shots, m, o);
}

double median(std::vector<int> v) {
  std::sort(v.begin(), v.end());
  const std::size_t k = v.size() / 2;
  return v.size() % 2 ? v[k] : 0.5 * (v[k - 1] + v[k]);
}

double rmsOf(const std::vector<double>& v) {
  double s = 0;
  for (const double x : v) s += x * x;
  return v.empty() ? NAN : std::sqrt(s / v.size());
}

// Issue 16 §2's "and speed": contact speeds 2-6 m/s, drawn (uniform sweep;
// adaptive in angle only) or chosen by the design, with velocity errors flat
// in speed (sigma_beta ~ 1/V: fast is better) or blur-limited (~V^2: slow is
// better).
void speedTable(std::span<const MaterialCase> materials, int runs, int budget, ShotNoise noise) {
  const SpeedRange speeds{2.0, 6.0};
  std::printf(
      "\nspeed chosen or drawn, contact speeds %.0f-%.0f m/s (sigma_beta = %.3f (V / 4 m/s)^(k - "
      "1) / sin psi)\n| material | k | uniform, speed drawn | adaptive, speed drawn | adaptive, "
      "speed chosen | chosen / drawn | pull RMS mu / beta0, chosen |\n|---|---|---|---|---|---|---|"
      "\n",
      speeds.min, speeds.max, noise.sigma_beta_at_90);
  for (const double k : {0.0, 2.0})
    for (const MaterialCase& mc : materials) {
      noise.speed_exponent = k;
      AdaptiveOptions drawn, chosen;
      chosen.speed_min_m_s = speeds.min, chosen.speed_max_m_s = speeds.max;
      std::vector<int> uni, ada, sped;
      std::vector<double> mu_pull, beta0_pull;
      for (int r = 0; r < runs; ++r) {
        uni.push_back(uniformRun(mc.m, noise, budget, 2000 + r, drawn, speeds).shots);
        ada.push_back(adaptiveRun(mc.m, noise, budget, 2000 + r, drawn, false, speeds).shots);
        const RunResult c = adaptiveRun(mc.m, noise, budget, 2000 + r, chosen, false, speeds);
        sped.push_back(c.shots);
        if (std::isfinite(c.mu_pull)) mu_pull.push_back(c.mu_pull);
        if (std::isfinite(c.beta0_pull)) beta0_pull.push_back(c.beta0_pull);
      }
      std::printf("| %s | %.0f | %.1f | %.1f | %.1f | %.2f | %.2f / %.2f |\n", mc.name, k,
                  median(uni), median(ada), median(sped), median(sped) / median(ada),
                  rmsOf(mu_pull), rmsOf(beta0_pull));
    }
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 20, budget = 300;
  ShotNoise noise;
  bool verbose = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--verbose")) verbose = true;
    if (i + 1 >= argc) continue;
    if (!std::strcmp(argv[i], "--runs")) runs = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--budget")) budget = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--sigma-beta")) noise.sigma_beta_at_90 = std::atof(argv[i + 1]);
  }
  const MaterialCase materials[] = {
      {"Nylon-like (e 0.97, mu 0.176, beta0 0.44)", {0.97, 0.176, 0.44}},
      {"Teflon-like (e 0.90, mu 0.10, beta0 0.30)", {0.90, 0.10, 0.30}},
      {"rough (e 0.80, mu 0.40, beta0 0.10)", {0.80, 0.40, 0.10}},
  };
  AdaptiveOptions o;
  std::printf(
      "targets sigma_mu <= %.3f, sigma_beta0 <= %.3f; %d seeded runs; budget %d shots; "
      "sigma_beta = %.3f / sin psi\n",
      o.target_sigma_mu, o.target_sigma_beta0, runs, budget, noise.sigma_beta_at_90);
  std::printf(
      "| material | uniform: median shots (range) | adaptive: median shots (range) | ratio | "
      "pull RMS at the stop, mu / beta0: uniform | adaptive |\n|---|---|---|---|---|---|\n");
  for (const MaterialCase& mc : materials) {
    std::vector<int> uni, ada;
    std::vector<double> pulls[4];  // uniform mu, beta0, adaptive mu, beta0
    for (int r = 0; r < runs; ++r) {
      const RunResult u = uniformRun(mc.m, noise, budget, 1000 + r, o);
      const RunResult a = adaptiveRun(mc.m, noise, budget, 1000 + r, o, verbose && r == 0);
      uni.push_back(u.shots), ada.push_back(a.shots);
      for (const auto& [k, v] :
           {std::pair{0, u.mu_pull}, {1, u.beta0_pull}, {2, a.mu_pull}, {3, a.beta0_pull}})
        if (std::isfinite(v)) pulls[k].push_back(v);
    }
    const auto range = [](const std::vector<int>& v) {
      return std::to_string(*std::min_element(v.begin(), v.end())) + "-" +
             std::to_string(*std::max_element(v.begin(), v.end()));
    };
    std::printf("| %s | %.1f (%s) | %.1f (%s) | %.2f | %.2f / %.2f | %.2f / %.2f |\n", mc.name,
                median(uni), range(uni).c_str(), median(ada), range(ada).c_str(),
                median(ada) / median(uni), rmsOf(pulls[0]), rmsOf(pulls[1]), rmsOf(pulls[2]),
                rmsOf(pulls[3]));
  }
  speedTable(materials, runs, budget, noise);
  return 0;
}
