// Accuracy of the vision core on simulated shots fired through the whole
// simulated rig (hw's SimWorld and CameraSim, launched by the sequencer as
// `collide campaign` does), against the shots' ground truth (TruthRecord).
//
//   build/bench/accuracy_bench [--shots N] [--campaign N] [--thesis N] [--seed S]
//                              [--verbose] [--save-bad DIR]
//
// Sections (issue 4 §3):
//  1. 640 x 480 (config/sim.toml): per-shot errors of e, beta, spins, centres
//     and radii, and the pulls (error / stated uncertainty).
//  2. A campaign of Nylon shots at 640 x 480 fitted with analysis/campaign.hpp:
//     mu and beta_0 against the material's truth.
//  3. The thesis' imaging (config/sim-thesis.toml, 240 x 192, 37 px spheres):
//     per-shot errors and the same campaign fit.
// Figures and the command used go in docs/benchmarks.md ("Vision").
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include "analysis/campaign.hpp"
#include "analysis/walton.hpp"
#include "app/analyze.hpp"
#include "app/campaign.hpp"
#include "app/rig_setup.hpp"
#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"
#include "hw/rig_profile.hpp"
#include "vision/shot_analysis.hpp"

using namespace collide;

namespace {

bool g_verbose = false;
std::string g_save_bad;  // --save-bad DIR: shots with an error beyond 5 sigma are saved there

void saveBad(const hw::Shot& shot, const std::string& why) {
  if (g_save_bad.empty()) return;
  if (auto st = app::saveShot(g_save_bad, shot); !st)
    std::printf("  (could not save: %s)\n", st.error().message.c_str());
  else
    std::printf("  saved %s to %s: %s\n", st->c_str(), g_save_bad.c_str(), why.c_str());
}

struct Stat {
  std::vector<double> v;
  void add(double x) {
    if (std::isfinite(x)) v.push_back(x);
  }
  double rms() const {
    double s = 0;
    for (double x : v) s += x * x;
    return v.empty() ? NAN : std::sqrt(s / v.size());
  }
  double maxAbs() const {
    double m = 0;
    for (double x : v) m = std::max(m, std::abs(x));
    return m;
  }
  double mean() const {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? NAN : s / v.size();
  }
};

// The truth at the collision: free flight (gravity only) is exact, so the
// states of the last frame before and the first frame after the contact,
// carried to the contact instant, are the states just before and after it.
bool truthAtContact(const hw::Shot& shot, std::array<Sphere, 2>& before,
                    std::array<Sphere, 2>& after) {
  const hw::TruthRecord& t = *shot.truth;
  int kb = -1, ka = -1;
  for (std::size_t k = 0; k < t.t_s.size(); ++k) {
    if (t.t_s[k] < t.t_collision_s) kb = static_cast<int>(k);
    if (t.t_s[k] > t.t_collision_s && ka < 0) ka = static_cast<int>(k);
  }
  if (kb < 0 || ka < 0) return false;
  for (int i = 0; i < 2; ++i) {
    for (const bool pre : {true, false}) {
      const SphereState& st = t.states[pre ? kb : ka][i];
      const double dt = t.t_collision_s - t.t_s[pre ? kb : ka];
      Sphere s;
      s.mass_kg = shot.scene.mass_kg[i];
      s.diameter_m = shot.scene.diameter_m[i];
      s.position_m = st.position_m + st.velocity_m_s * dt + 0.5 * kGravity_m_s2 * dt * dt;
      s.velocity_m_s = st.velocity_m_s + kGravity_m_s2 * dt;
      s.spin_rad_s = st.spin_rad_s;
      (pre ? before : after)[i] = s;
    }
    after[i].position_m = before[i].position_m;
  }
  return true;
}

struct SectionResult {
  std::vector<CampaignShot> points;
  Material truth;
};

SectionResult runSection(const char* title, const hw::RigProfile& base, int shots,
                         std::uint64_t seed, bool print_shots) {
  std::printf("\n== %s: %d shots (%s, %dx%d, %.0f frames/s)\n", title, shots, base.source.c_str(),
              base.camera_config.width, base.camera_config.height, base.camera_config.fps);
  app::CampaignOptions o;
  o.shots = shots;
  o.seed = seed;
  const std::vector<app::PlannedShot> plan = app::planCampaign(o);
  Stat de, db, dbi, pe, pb, dc, dr, spin_rel, dvn, dt_us;
  int ok = 0, failed = 0, flagged = 0;
  SectionResult out;
  out.truth = base.spheres.material;
  double analysis_s = 0;
  int frames_total = 0;
  for (std::size_t i = 0; i < plan.size(); ++i) {
    auto aimed = app::aimForIncidence(base, plan[i].incidence_deg, plan[i].speed_m_s);
    if (!aimed) {
      std::printf("shot %2zu: not aimed: %s\n", i, aimed.error().message.c_str());
      ++failed;
      continue;
    }
    aimed->simulation.seed = seed * 1000003ULL + i;
    auto fired =
        app::fireShot(*aimed, hw::ShotRequest::atSpeeds(plan[i].speed_m_s[0], plan[i].speed_m_s[1]),
                      "bench-" + std::to_string(i));
    if (!fired || fired->status != hw::ShotStatus::Ok || !fired->truth) {
      std::printf("shot %2zu: not fired: %s\n", i,
                  fired ? fired->failure_reason.c_str() : fired.error().message.c_str());
      ++failed;
      continue;
    }
    const hw::Shot& shot = *fired;
    const auto t0 = std::chrono::steady_clock::now();
    auto r = vision::analyzeBurst(shot.burst, app::analysisSettingsFor(shot));
    analysis_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    frames_total += static_cast<int>(shot.burst.frames.size());
    std::array<Sphere, 2> tb, ta;
    if (!truthAtContact(shot, tb, ta)) {
      std::printf("shot %2zu: no collision in the truth\n", i);
      ++failed;
      continue;
    }
    auto truth = measureCollision(tb, ta);
    if (!r || !truth) {
      std::printf("shot %2zu: analysis failed: %s\n", i,
                  r ? truth.error().message.c_str() : r.error().message.c_str());
      if (!r) saveBad(shot, r.error().message);
      ++failed;
      continue;
    }
    ++ok;
    const vision::CollisionProperties& c = r->collision;
    const double e_err = c.e.value - truth->e, b_err = c.beta.value - truth->beta;
    de.add(e_err);
    pe.add(e_err / c.e.sigma);
    dvn.add(c.vn_m_s.value - truth->before.v_n_m_s);
    const bool beta_range = std::abs(truth->before.v_n_m_s) >= 0.3 && truth->before.v_s_m_s >= 0.3;
    if (beta_range) {
      db.add(b_err);
      dbi.add(c.beta_from_impulse.value - truth->beta);
      pb.add(b_err / c.beta.sigma);
    }
    if (!r->quality_flags.empty()) ++flagged;
    if (std::abs(e_err) > 5 * c.e.sigma + 1e-4 || std::abs(b_err) > 5 * c.beta.sigma + 1e-3) {
      std::printf("shot %2zu: e error %+.5f (sigma %.5f), beta error %+.4f (sigma %.4f)\n", i,
                  e_err, c.e.sigma, b_err, c.beta.sigma);
      saveBad(shot, "error beyond 5 sigma");
    }
    // Collision instant on the truth's clock (seconds after frame 0's mid-exposure).
    const hw::TruthRecord& t = *shot.truth;
    std::size_t first = 0;
    while (first < shot.burst.frames.size() && !shot.burst.frames[first].good()) ++first;
    dt_us.add((c.t_collision_s.value + t.t_s[first] - t.t_collision_s) * 1e6);
    // Centres and radii, every frame and sphere.
    const double px = shot.scene.pixel_size_m;
    for (const vision::FrameDetections& fd : r->frames) {
      const auto it = std::find(t.frame_id.begin(), t.frame_id.end(), fd.frame_id);
      if (it == t.frame_id.end()) continue;
      const auto& st = t.states[it - t.frame_id.begin()];
      for (int s = 0; s < 2; ++s) {
        if (!fd.sphere[s] || fd.sphere[s]->cut_by_border) continue;
        dc.add(fd.sphere[s]->u_px - (shot.scene.origin_u_px + st[s].position_m.x() / px));
        dc.add(fd.sphere[s]->v_px - (shot.scene.origin_v_px - st[s].position_m.y() / px));
        dr.add(fd.sphere[s]->radius_px - 0.5 * shot.scene.diameter_m[s] / px);
      }
    }
    for (int s = 0; s < 2; ++s) {
      const vision::SphereKinematics& k = r->sphere[s];
      if (tb[s].spin_rad_s.norm() >= 50)
        spin_rel.add((k.spin_before_rad_s.value - tb[s].spin_rad_s).norm() /
                     tb[s].spin_rad_s.norm());
      if (ta[s].spin_rad_s.norm() >= 50)
        spin_rel.add((k.spin_after_rad_s.value - ta[s].spin_rad_s).norm() /
                     ta[s].spin_rad_s.norm());
    }
    if (print_shots) {
      std::printf(
          "shot %2zu: psi %4.1f deg vn %+.2f vs %.2f | e %.4f (truth %.4f, sigma %.4f) "
          "beta %+.4f (truth %+.4f, sigma %.4f)",
          i, plan[i].incidence_deg, c.vn_m_s.value, c.vs_m_s.value, c.e.value, truth->e, c.e.sigma,
          c.beta.value, truth->beta, c.beta.sigma);
      for (const std::string& f : r->quality_flags) std::printf(" [%s]", f.c_str());
      std::printf("\n");
      if (g_verbose)
        for (int s = 0; s < 2; ++s) {
          const vision::SphereKinematics& k = r->sphere[s];
          const auto row = [](const char* what, const Estimate3& e, const Vec3& truth) {
            const Vec3 d = e.value - truth;
            std::printf("    %-10s err (%+.5f %+.5f %+.5f) sigma (%.5f %.5f %.5f)\n", what, d.x(),
                        d.y(), d.z(), e.sigma.x(), e.sigma.y(), e.sigma.z());
          };
          std::printf("  sphere %d:\n", s + 1);
          row("v before", k.velocity_before_m_s, tb[s].velocity_m_s);
          row("v after", k.velocity_after_m_s, ta[s].velocity_m_s);
          row("w before", k.spin_before_rad_s, tb[s].spin_rad_s);
          row("w after", k.spin_after_rad_s, ta[s].spin_rad_s);
        }
    }
    CampaignShot p;
    p.v_n_m_s = c.vn_m_s.value;
    p.v_n_sigma_m_s = c.vn_m_s.sigma;
    p.v_s_m_s = c.vs_m_s.value;
    p.v_s_sigma_m_s = c.vs_m_s.sigma;
    p.e = c.e.value;
    p.e_sigma = c.e.sigma;
    p.beta = c.beta.value;
    p.beta_sigma = c.beta.sigma;
    p.f = c.f.value;
    p.f_sigma = c.f.sigma;
    if (std::isfinite(p.beta) && p.beta_sigma > 0 && p.e_sigma > 0) out.points.push_back(p);
  }
  std::printf(
      "analysed %d of %d (%d not fired/failed), %d with quality flags; analysis %.1f ms "
      "per shot (%.0f frames/s end to end)\n",
      ok, shots, failed, flagged, 1e3 * analysis_s / std::max(1, ok),
      frames_total / std::max(1e-9, analysis_s));
  std::printf(
      "centre error RMS %.4f px per axis (max %.4f, %zu samples), radius RMS %.4f px "
      "(mean %+.4f)\n",
      dc.rms(), dc.maxAbs(), dc.v.size(), dr.rms(), dr.mean());
  std::printf(
      "e error RMS %.5f (max %.5f); beta error RMS %.4f (max %.4f) and from impulse "
      "%.4f, over %zu shots with |v_n|, v_s >= 0.3 m/s\n",
      de.rms(), de.maxAbs(), db.rms(), db.maxAbs(), dbi.rms(), db.v.size());
  std::printf("v_n error RMS %.5f m/s; collision instant error RMS %.2f us\n", dvn.rms(),
              dt_us.rms());
  std::printf("spin error RMS %.3f %% of |omega| (max %.3f %%, %zu spins >= 50 rad/s)\n",
              100 * spin_rel.rms(), 100 * spin_rel.maxAbs(), spin_rel.v.size());
  std::printf("pull RMS (error / stated sigma): e %.2f, beta %.2f\n", pe.rms(), pb.rms());
  return out;
}

void fitSection(const SectionResult& s) {
  auto e = fitRestitutionMean(s.points);
  if (!e) {
    std::printf("campaign fit: %s\n", e.error().message.c_str());
    return;
  }
  auto f = fitFriction(s.points, e->e);
  if (!f) {
    std::printf("campaign fit: %s\n", f.error().message.c_str());
    return;
  }
  std::printf(
      "campaign fit over %zu shots: e %.4f +- %.4f (truth %.3f), mu %.4f +- %.4f "
      "(truth %.3f, error %+.4f), beta0 %.4f +- %.4f (truth %.3f, error %+.4f); "
      "%d sliding, %d rolling\n",
      s.points.size(), e->e.value, e->e.sigma, s.truth.e, f->mu.value, f->mu.sigma, s.truth.mu,
      f->mu.value - s.truth.mu, f->beta0.value, f->beta0.sigma, s.truth.beta0,
      f->beta0.value - s.truth.beta0, f->sliding_count, f->rolling_count);
}

}  // namespace

int main(int argc, char** argv) {
  int shots = 30, campaign = 40, thesis = 40;
  std::uint64_t seed = 4;
  for (int i = 1; i < argc; ++i)
    if (!std::strcmp(argv[i], "--verbose")) g_verbose = true;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--shots")) shots = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--campaign")) campaign = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--thesis")) thesis = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--seed")) seed = std::strtoull(argv[i + 1], nullptr, 10);
    if (!std::strcmp(argv[i], "--save-bad")) g_save_bad = argv[i + 1];
  }
  for (int i = 1; i + 1 < argc; ++i)
    if (!std::strcmp(argv[i], "--reanalyse")) {
      // One saved shot again, with the per-sphere errors.
      auto shot = app::readShot(argv[i + 1]);
      if (!shot || !shot->truth) {
        std::fprintf(stderr, "%s\n", shot ? "no truth in the shot" : shot.error().message.c_str());
        return 1;
      }
      auto r = vision::analyzeBurst(shot->burst, app::analysisSettingsFor(*shot));
      std::array<Sphere, 2> tb, ta;
      if (!r || !truthAtContact(*shot, tb, ta)) {
        std::fprintf(stderr, "%s\n", r ? "no collision in the truth" : r.error().message.c_str());
        return 1;
      }
      auto truth = measureCollision(tb, ta);
      const vision::CollisionProperties& c = r->collision;
      std::printf(
          "e %.5f (truth %.5f, sigma %.5f) beta %.4f (truth %.4f, sigma %.4f) vn %.3f vs %.3f\n",
          c.e.value, truth->e, c.e.sigma, c.beta.value, truth->beta, c.beta.sigma, c.vn_m_s.value,
          c.vs_m_s.value);
      for (const std::string& f : r->quality_flags) std::printf("flag %s\n", f.c_str());
      if (g_verbose)
        for (const vision::FrameDetections& fd : r->frames) {
          std::printf("frame %3lld:", static_cast<long long>(fd.frame_id));
          for (int s = 0; s < 2; ++s)
            if (fd.sphere[s])
              std::printf("  s%d (%.2f, %.2f) r %.2f %s%s dots %zu", s + 1, fd.sphere[s]->u_px,
                          fd.sphere[s]->v_px, fd.sphere[s]->radius_px,
                          fd.sphere[s]->cut_by_border ? "C" : "", fd.sphere[s]->touching ? "T" : "",
                          fd.dots[s].size());
          std::printf("\n");
        }
      for (int s = 0; s < 2; ++s) {
        const vision::SphereKinematics& k = r->sphere[s];
        const auto row = [](const char* what, const Estimate3& e, const Vec3& t) {
          std::printf(
              "  %-9s (%+.4f %+.4f %+.4f) truth (%+.4f %+.4f %+.4f) sigma (%.4f %.4f %.4f)\n", what,
              e.value.x(), e.value.y(), e.value.z(), t.x(), t.y(), t.z(), e.sigma.x(), e.sigma.y(),
              e.sigma.z());
        };
        std::printf("sphere %d: frames %d/%d\n", s + 1, k.frames_before, k.frames_after);
        row("v before", k.velocity_before_m_s, tb[s].velocity_m_s);
        row("v after", k.velocity_after_m_s, ta[s].velocity_m_s);
        row("w before", k.spin_before_rad_s, tb[s].spin_rad_s);
        row("w after", k.spin_after_rad_s, ta[s].spin_rad_s);
      }
      return 0;
    }
  const std::string root = COLLIDE_SOURCE_DIR;
  auto sim = hw::loadRigProfile(root + "/config/sim.toml");
  auto sim_thesis = hw::loadRigProfile(root + "/config/sim-thesis.toml");
  if (!sim || !sim_thesis) {
    std::fprintf(stderr, "%s\n", (sim ? sim_thesis : sim).error().message.c_str());
    return 1;
  }
  if (shots > 0) runSection("640 x 480 shots", *sim, shots, seed, true);
  if (campaign > 0)
    fitSection(runSection("640 x 480 Nylon campaign", *sim, campaign, seed + 1, false));
  if (thesis > 0)
    fitSection(runSection("thesis imaging campaign", *sim_thesis, thesis, seed + 2, g_verbose));
  return 0;
}
