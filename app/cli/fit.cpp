// `collide fit DIR`: the campaign's material (mu, beta_0, e, gamma_0, the
// e(|v_n|) law) as JSON, and the thesis' plots as PNG and SVG.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "app/cli/command.hpp"
#include "app/manifest.hpp"
#include "app/report/campaign_report.hpp"
#include "app/store/atomic_file.hpp"

namespace {

namespace fs = std::filesystem;
using collide::cli::kExitBadInput;
using collide::cli::kExitFailure;
using collide::cli::kExitOk;

struct Options {
  std::string dir;
  std::vector<std::string> dirs;  // several folders: a campaign spread out (docs/cluster.md)
  std::string manifest;
  std::string out;
  bool include_flagged = false;
  std::string loss = "huber";
  int resamples = 200;
  std::uint64_t seed = 1;
};

collide::Status writeText(const std::string& path, const std::string& text) {
  return collide::app::writeTextFile(path, text + "\n");
}

// The shots of several folders or of a manifest (the reduce step after a
// cluster's analysis); one folder as before.
collide::Result<std::vector<collide::app::CampaignEntry>> loadEntries(const Options& o) {
  if (o.manifest.empty() && o.dirs.size() == 1)
    return collide::app::loadCampaign(o.dir, o.include_flagged);
  std::vector<std::string> files;
  if (!o.manifest.empty()) {
    auto m = collide::app::readManifest(o.manifest);
    if (!m) return m.error();
    for (const auto& e : *m) files.push_back(e.path);
  }
  if (!o.dirs.empty()) {
    auto listed = collide::app::listShotFiles(o.dirs);
    if (!listed) return listed.error();
    files.insert(files.end(), listed->begin(), listed->end());
  }
  return collide::app::loadCampaignFiles(files, o.include_flagged);
}

// The options' own errors (exit kExitBadInput), and o.dir named for messages.
bool checkOptions(Options& o) {
  if (o.dirs.empty() && o.manifest.empty()) {
    std::cerr << "collide fit: name a campaign folder (or several), or --manifest LIST\n";
    return false;
  }
  if (o.dirs.size() + (o.manifest.empty() ? 0 : 1) > 1 && o.out.empty()) {
    std::cerr << "collide fit: a campaign from several folders or a manifest needs --out DIR "
                 "(where fit.json and the plots go)\n";
    return false;
  }
  o.dir = o.dirs.size() == 1 && o.manifest.empty() ? o.dirs[0]
          : o.manifest.empty()                     ? "the folders' campaign"
                                                   : o.manifest;
  if (o.resamples > 0 && o.resamples < 10) {
    std::cerr << "collide fit: --bootstrap needs at least 10 resamples (or 0 for none)\n";
    return false;
  }
  return true;
}

// fit.json and the plots into `out` (created); false with the error said.
bool writeReport(const std::string& out, const std::vector<collide::app::CampaignEntry>& entries,
                 const collide::app::CampaignFitReport& report, std::string& json_path) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) {
    std::cerr << "collide fit: cannot create " << out << ": " << ec.message() << "\n";
    return false;
  }
  json_path = (fs::path(out) / "fit.json").string();
  if (auto st = writeText(json_path, collide::app::campaignReportJson(entries, report)); !st) {
    std::cerr << "collide fit: " << st.error().message << "\n";
    return false;
  }
  for (const auto& p : collide::app::campaignPlots(entries, &report)) {
    if (auto st = collide::app::savePlot(p.plot, (fs::path(out) / p.name).string()); !st) {
      std::cerr << "collide fit: " << st.error().message << "\n";
      return false;
    }
  }
  return true;
}

// The fitted material, its speed law, the bootstrap and launch spin, on stdout.
void printReport(const collide::app::CampaignFitReport& report) {
  for (const auto& d : report.down_weighted)
    std::printf("down-weighted by the %s loss: %s (weight %.2f in the beta fit, %.2f in e)\n",
                collide::robustLossName(report.loss).c_str(), d.id.c_str(), d.beta_weight,
                d.e_weight);
  const auto& e = report.fit.restitution.e;
  if (const auto& fr = report.fit.friction) {
    std::printf("mu       %.4f ± %.4f\n", fr->mu.value, fr->mu.sigma);
    std::printf("beta_0   %.4f ± %.4f\n", fr->beta0.value, fr->beta0.sigma);
  } else {
    std::printf("mu, beta_0 not fitted: %s\n", fr.error().message.c_str());
  }
  std::printf("e        %.4f ± %.4f (mean of %d shots)\n", e.value, e.sigma,
              report.fit.restitution.count);
  if (const auto& fr = report.fit.friction)
    std::printf(
        "gamma_0  %.1f ± %.1f deg (incidence angle from head-on: rolling below, sliding above; "
        "%d sliding, %d rolling shots)\n",
        fr->switch_angle_deg.value, fr->switch_angle_deg.sigma, fr->sliding_count,
        fr->rolling_count);
  if (report.fit.laws) {
    const auto& laws = *report.fit.laws;
    std::printf("e(|v_n|) %s law preferred (delta BIC %.1f; evidence: %s)\n",
                collide::restitutionLawName(laws.preferred).c_str(), laws.bic_margin,
                collide::evidenceName(laws.evidence).c_str());
  } else {
    std::printf("e(|v_n|) not fitted: %s\n", report.fit.laws.error().message.c_str());
  }
  if (report.bootstrap)
    std::printf("bootstrap sigmas: mu %.4f, beta_0 %.4f (%d resamples)\n",
                report.bootstrap->mu_sigma, report.bootstrap->beta0_sigma,
                report.bootstrap->resamples_used);
  if (const auto& ls = report.launch_spin)
    std::printf(
        "launchers' spin %.1f ± %.1f rad/s per axis (x %.1f, y %.1f, z %.1f; RMS of %d measured "
        "pre-impact spins): the rig profile's [analysis] launch_spin_rad_s\n",
        ls->per_axis_rad_s, ls->sigma_rad_s, ls->rms_rad_s.x(), ls->rms_rad_s.y(),
        ls->rms_rad_s.z(), ls->spins);
  else
    std::printf("launchers' spin not measured: %s\n", report.launch_spin_error.c_str());
  if (!report.launch_spin_advice.empty())
    std::printf("note: %s\n", report.launch_spin_advice.c_str());
  if (const auto& t = report.track_offset) {
    std::printf(
        "tracks' centre offset beyond what the analysis drew: %+.4f px per axis (variance "
        "%+.2g ± %.1g px^2; the kinks' gaps of %d shots, pulls RMS %.2f)",
        t->excessPx(), t->excess_px2, t->sigma_px2, t->shots, t->pull_rms);
    if (const auto& stated = report.stated_centre_offset_px)
      std::printf(": the rig profile's [analysis] centre_offset_px %.4g would be %.4g px\n",
                  *stated, t->suggestedPx(*stated));
    else
      std::printf(": for the rig profile's [analysis] centre_offset_px\n");
  } else {
    std::printf("tracks' centre offset not measured: %s\n", report.track_offset_error.c_str());
  }
  if (!report.centre_offset_advice.empty())
    std::printf("note: %s\n", report.centre_offset_advice.c_str());
  if (!report.error_budget.empty()) {
    std::printf(
        "sigma by source, RMS over %d shots analysed with --error-budget:\n"
        "    source                      e      beta  gamma (deg)\n",
        report.error_budget_shots);
    for (const auto& r : report.error_budget)
      if (r.e > 0 || r.beta > 0 || r.gamma_deg > 0)
        std::printf("    %-18s %10.2g %9.2g %10.2g\n", r.source.c_str(), r.e, r.beta, r.gamma_deg);
  }
}

int runFit(const Options& given) {
  Options o = given;
  if (!checkOptions(o)) return kExitBadInput;
  auto entries = loadEntries(o);
  if (!entries) {
    std::cerr << "collide fit: " << entries.error().message << "\n";
    return kExitBadInput;
  }
  int used = 0;
  for (const auto& e : *entries) {
    if (e.shot) {
      ++used;
    } else {
      std::cerr << "left out " << (e.id.empty() ? e.file : e.id) << ": " << e.excluded_because
                << "\n";
    }
  }
  std::cout << used << " of " << entries->size() << " shots used\n";
  const collide::RobustLoss loss = o.loss == "least-squares" ? collide::RobustLoss::LeastSquares
                                   : o.loss == "cauchy"      ? collide::RobustLoss::Cauchy
                                                             : collide::RobustLoss::Huber;
  auto report = collide::app::fitCampaignFolder(*entries, o.resamples, o.seed, loss);
  if (!report) {
    std::cerr << "collide fit: " << o.dir << ": " << report.error().message << "\n";
    return kExitFailure;
  }
  const std::string out = o.out.empty() ? (fs::path(o.dir) / "fit").string() : o.out;
  std::string json_path;
  if (!writeReport(out, *entries, *report, json_path)) return kExitFailure;
  printReport(*report);
  std::cout << "wrote " << json_path << " and 5 plots (PNG, SVG) in " << out << "\n";
  return kExitOk;
}

void setupFit(CLI::App& sub, std::function<int()>& run) {
  auto o = std::make_shared<Options>();
  sub.add_option("dir", o->dirs,
                 "Campaign folder of analysed shot files (several: one campaign spread over them)");
  sub.add_option("--manifest", o->manifest,
                 "Fit the shot files a manifest lists (one path a line; see collide manifest)");
  sub.add_option("--out", o->out,
                 "Folder for fit.json and the plots (default: DIR/fit; required with several "
                 "folders or --manifest)");
  sub.add_flag("--include-flagged", o->include_flagged,
               "Also fit shots whose quality flags say their numbers are not to be trusted");
  sub.add_option("--loss", o->loss,
                 "Loss of the fits: huber (default), cauchy or least-squares; the robust "
                 "losses down-weight shots far off the model and list them")
      ->check(CLI::IsMember({"huber", "cauchy", "least-squares"}))
      ->capture_default_str();
  sub.add_option("--bootstrap", o->resamples,
                 "Bootstrap resamples for the sigma cross-check (0: none)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub.add_option("--seed", o->seed, "Seed of the bootstrap");
  sub.footer(
      "Plots: beta_vs_cot, tangent_form, f_vs_tan, e_vs_tan, e_vs_vn (each .png and .svg).\n"
      "Shots flagged few_frames_*, collision_instant_disagree, large_residuals, unphysical,\n"
      "spin_poorly_measured, spin_impulse_disagree or analysis_failed are left out unless\n"
      "--include-flagged; every left-out shot is listed with its flags, and every shot the\n"
      "robust loss down-weights with its weights. A shot whose spins were not measured\n"
      "(beta null, e.g. a bare backlit silhouette) counts for e only; when too few spins\n"
      "remain for mu and beta_0, e and its speed law are still fitted and the reason is said.");
  run = [o] { return runFit(*o); };
}

}  // namespace

COLLIDE_COMMAND(fit, "Fit a campaign: mu, beta_0, e and its speed law, with the thesis' plots",
                setupFit);
