#include "app/report/campaign_report.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "app/store/shot_file.hpp"
#include "hw/rig_profile.hpp"

namespace collide::app {
namespace fs = std::filesystem;
using nlohmann::json;

const std::vector<std::string>& excludingFlags() {
  static const std::vector<std::string> flags = {
      "analysis_failed", "few_frames_before", "few_frames_after",     "collision_instant_disagree",
      "large_residuals", "unphysical",        "spin_poorly_measured", "spin_impulse_disagree"};
  return flags;
}

void useResults(CampaignEntry& entry, const std::string& results_json, bool include_flagged) {
  auto r = parseResultsJson(results_json);
  if (!r) {
    entry.excluded_because = r.error().message;
    return;
  }
  entry.results = *r;
  for (const auto& f : r->quality_flags)
    if (std::find(excludingFlags().begin(), excludingFlags().end(), f) != excludingFlags().end())
      entry.excluding_flags.push_back(f);
  if (!entry.excluding_flags.empty() && !include_flagged) {
    std::string list;
    for (const auto& f : entry.excluding_flags) list += (list.empty() ? "" : ", ") + f;
    entry.excluded_because = std::string("quality flag") +
                             (entry.excluding_flags.size() > 1 ? "s " : " ") + list +
                             " (--include-flagged keeps it)";
  } else if (auto cs = toCampaignShot(*r); !cs) {
    entry.excluded_because = cs.error().message;
  } else {
    entry.shot = *cs;
  }
}

Result<std::vector<CampaignEntry>> loadCampaign(const std::string& dir, bool include_flagged) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return fail(dir + ": no such folder");
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().extension() == ".h5") files.push_back(e.path().string());
  if (files.empty()) return fail(dir + ": no shot files (*.h5) in this folder");
  std::sort(files.begin(), files.end());
  return loadCampaignFiles(files, include_flagged);
}

std::vector<CampaignEntry> loadCampaignFiles(const std::vector<std::string>& files,
                                             bool include_flagged) {
  std::vector<CampaignEntry> entries;
  // A campaign's shots mostly share one profile: parse each text once.
  struct Stated {
    std::optional<double> launch_spin_rad_s, centre_offset_px;
  };
  std::map<std::string, Stated> stated_of;
  for (const auto& file : files) {
    CampaignEntry entry;
    entry.file = file;
    auto shot = readShot(file, ReadOptions{.frames = false, .contained = true});
    if (!shot) {
      entry.excluded_because = shot.error().message;
      entries.push_back(std::move(entry));
      continue;
    }
    entry.id = shot->id;
    auto [it, fresh] = stated_of.try_emplace(shot->rig_profile_toml);
    if (fresh)
      if (auto profile = hw::parseRigProfile(shot->rig_profile_toml, entry.id))
        it->second = {profile->analysis.launch_spin_rad_s, profile->analysis.centre_offset_px};
    entry.profile_launch_spin_rad_s = it->second.launch_spin_rad_s;
    entry.profile_centre_offset_px = it->second.centre_offset_px;
    if (shot->status == hw::ShotStatus::Failed) {
      entry.excluded_because = "failed shot: " + shot->failure_reason;
    } else if (shot->results_json.empty()) {
      entry.excluded_because =
          "not analysed (run `collide analyze " + fs::path(file).parent_path().string() + "`)";
    } else {
      useResults(entry, shot->results_json, include_flagged);
    }
    entries.push_back(std::move(entry));
  }
  return entries;
}

std::vector<CampaignShot> usableShots(const std::vector<CampaignEntry>& entries) {
  std::vector<CampaignShot> out;
  for (const auto& e : entries)
    if (e.shot) out.push_back(*e.shot);
  return out;
}

std::vector<Estimate3> measuredLaunchSpins(const std::vector<CampaignEntry>& entries) {
  static const std::vector<std::string> untrusted = {"no_spin_before", "spin_poorly_measured",
                                                     "spin_impulse_disagree"};
  std::vector<Estimate3> spins;
  for (const auto& e : entries) {
    if (!e.results || e.results->error) continue;
    const auto& flags = e.results->quality_flags;
    if (std::ranges::any_of(untrusted, [&](const std::string& f) {
          return std::ranges::find(flags, f) != flags.end();
        }))
      continue;
    for (const auto& sphere : e.results->sphere)
      // A spin partly taken from the profile's launch_spin_rad_s cannot measure it.
      if (sphere.spin_before_prior_directions == 0 && sphere.spin_before_rad_s.value.allFinite() &&
          sphere.spin_before_rad_s.sigma.allFinite())
        spins.push_back(sphere.spin_before_rad_s);
  }
  return spins;
}

std::vector<KinkGap> measuredKinkGaps(const std::vector<CampaignEntry>& entries) {
  std::vector<KinkGap> gaps;
  for (const auto& e : entries)
    if (e.results && !e.results->error && e.excluding_flags.empty() && e.results->kink_gap.usable())
      gaps.push_back(e.results->kink_gap);
  return gaps;
}

namespace {

// The value the analysed shots' profiles state (`field`), when they agree.
std::optional<double> statedValue(const std::vector<CampaignEntry>& entries,
                                  std::optional<double> CampaignEntry::*field) {
  std::optional<double> stated;
  for (const auto& e : entries) {
    if (!e.results || !(e.*field)) continue;
    if (stated && *stated != *(e.*field)) return std::nullopt;
    stated = e.*field;
  }
  return stated;
}

std::string launchSpinAdvice(const CampaignFitReport& r) {
  if (!r.launch_spin || !r.stated_launch_spin_rad_s) return "";
  const double measured = r.launch_spin->per_axis_rad_s, sigma = r.launch_spin->sigma_rad_s;
  const double stated = *r.stated_launch_spin_rad_s;
  const double gap = stated - measured;
  if (std::abs(gap) <= 3 * sigma || std::abs(gap) <= 0.2 * std::max(measured, stated)) return "";
  // A spread the noise hides entirely measures 0: the field wants a value
  // above 0 (and at most 1000), and the data cannot tell below its sigma.
  const double suggest = std::min(1000.0, std::max(measured, sigma));
  if (!(suggest > 0)) return "";
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "the shots' rig profile states [analysis] launch_spin_rad_s = %.3g, the "
                "launchers measure %.3g ± %.2g rad/s: set it to %.3g (%s)",
                stated, measured, sigma, suggest,
                gap > 0 ? "a wider value makes the sigmas of gamma, beta and f of shots whose "
                          "dots are not seen pessimistic"
                        : "a narrower value makes the sigmas of gamma, beta and f of shots whose "
                          "dots are not seen optimistic");
  return buf;
}

std::string centreOffsetAdvice(const CampaignFitReport& r) {
  if (!r.track_offset || !r.stated_centre_offset_px) return "";
  const TrackOffsetExcess& t = *r.track_offset;
  const double stated = *r.stated_centre_offset_px, suggest = t.suggestedPx(stated);
  const double gap = std::abs(suggest - stated);
  if (std::abs(t.excess_px2) <= 3 * t.sigma_px2 || gap <= 0.2 * std::max(suggest, stated) ||
      gap <= 0.005)
    return "";
  char buf[480];
  std::snprintf(buf, sizeof buf,
                "the kinks of %d shots put each track's centre %.3g px %s than the analysis "
                "drew (the rig profile states [analysis] centre_offset_px = %.3g): set it to "
                "%.3g and analyse again (%s)",
                t.shots, std::sqrt(std::abs(t.excess_px2)),
                t.excess_px2 > 0 ? "further off" : "less far off", stated, suggest,
                t.excess_px2 > 0 ? "the sigmas of e and gamma at grazing impacts are optimistic"
                                 : "the sigmas of e and gamma at grazing impacts are pessimistic");
  return buf;
}

// report.error_budget: per source, the RMS over the fitted shots that carry
// one of each quantity's finite sigma.
void addErrorBudget(const std::vector<CampaignEntry>& entries, CampaignFitReport& report) {
  std::vector<ErrorBudgetLine>& rows = report.error_budget;
  std::vector<std::array<int, 3>> counts;
  for (const auto& e : entries) {
    if (!e.shot || !e.results || e.results->error_budget.empty()) continue;
    ++report.error_budget_shots;
    for (const ErrorBudgetLine& line : e.results->error_budget) {
      auto it = std::find_if(rows.begin(), rows.end(),
                             [&](const ErrorBudgetLine& r) { return r.source == line.source; });
      if (it == rows.end()) {
        it = rows.insert(rows.end(), {line.source});
        counts.push_back({0, 0, 0});
      }
      std::array<int, 3>& n = counts[static_cast<std::size_t>(it - rows.begin())];
      const std::array<double, 3> v{line.e, line.beta, line.gamma_deg};
      const std::array<double*, 3> sum{&it->e, &it->beta, &it->gamma_deg};
      for (int q = 0; q < 3; ++q)
        if (std::isfinite(v[q])) *sum[q] += v[q] * v[q], ++n[q];
    }
  }
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::array<double*, 3> sum{&rows[i].e, &rows[i].beta, &rows[i].gamma_deg};
    for (int q = 0; q < 3; ++q)
      *sum[q] = counts[i][q] > 0 ? std::sqrt(*sum[q] / counts[i][q]) : std::nan("");
  }
}

}  // namespace

Result<CampaignFitReport> fitCampaignFolder(const std::vector<CampaignEntry>& entries,
                                            int resamples, std::uint64_t seed, RobustLoss loss) {
  const auto shots = usableShots(entries);
  FrictionOptions options = campaignOptions();
  options.robust.loss = loss;
  auto fit = fitCampaign(shots, options);
  if (!fit) return fit.error();
  CampaignFitReport report{*fit, loss, {}, std::nullopt, "", std::nullopt, ""};
  if (auto spread = launchSpinSpread(measuredLaunchSpins(entries)))
    report.launch_spin = *spread;
  else
    report.launch_spin_error = spread.error().message;
  report.stated_launch_spin_rad_s = statedValue(entries, &CampaignEntry::profile_launch_spin_rad_s);
  report.launch_spin_advice = launchSpinAdvice(report);
  // Its bootstrap is cheap: always 200 resamples (`resamples` is the friction fit's).
  const std::vector<KinkGap> gaps = measuredKinkGaps(entries);
  if (gaps.empty())
    report.track_offset_error =
        "no analysed shot states where its two spheres' tracks bend (kink_gap): sphere-on-wall "
        "shots have one sphere, and shots analysed by an earlier collide need `collide analyze` "
        "again";
  else if (auto offset = trackOffsetFromKinkGaps(gaps, 200, seed))
    report.track_offset = *offset;
  else
    report.track_offset_error = offset.error().message;
  report.stated_centre_offset_px = statedValue(entries, &CampaignEntry::profile_centre_offset_px);
  report.centre_offset_advice = centreOffsetAdvice(report);
  addErrorBudget(entries, report);
  std::size_t k = 0;  // index into the fitted shots
  for (const auto& e : entries) {
    if (!e.shot) continue;
    const double wb = fit->friction && k < fit->friction->robust_weight.size()
                          ? fit->friction->robust_weight[k]
                          : 1;
    const double we =
        k < fit->restitution.robust_weight.size() ? fit->restitution.robust_weight[k] : 1;
    if (wb < 0.5 || we < 0.5)
      report.down_weighted.push_back({e.id.empty() ? e.file : e.id, wb, we});
    ++k;
  }
  if (resamples > 0 && !fit->friction) {
    report.bootstrap_error = "no friction fit to cross-check";
  } else if (resamples > 0) {
    // Head-on shots, and shots whose spins were not measured, have no beta:
    // the friction bootstrap takes the others.
    std::vector<CampaignShot> oblique;
    for (const auto& s : shots)
      if (s.v_s_m_s > 0 && !std::isnan(s.beta)) oblique.push_back(s);
    auto boot = bootstrapFriction(oblique, resamples, seed, options);
    if (boot) {
      report.bootstrap = *boot;
    } else {
      report.bootstrap_error = boot.error().message;
    }
  }
  return report;
}

namespace {

// Evenly spaced abscissae over [lo, hi] for model curves.
std::vector<double> linspace(double lo, double hi, int n = 200) {
  std::vector<double> x(n);
  for (int i = 0; i < n; ++i) x[i] = lo + (hi - lo) * i / (n - 1);
  return x;
}

Series curve(const std::string& label, const std::vector<double>& x,
             const std::function<double(double)>& f, int colour) {
  Series s{label, Series::Style::Line, x, {}, {}, colour};
  for (double v : x) s.y.push_back(f(v));
  return s;
}

double maxOr(const std::vector<double>& v, double fallback) {
  return v.empty() ? fallback : *std::max_element(v.begin(), v.end());
}

}  // namespace

namespace {

// The points of the campaign's plots, one series each.
struct PlotPoints {
  Series beta{"shots", Series::Style::Points, {}, {}, {}, 0};
  Series tangent = beta, f = beta, e_tan = beta, e_vn = beta;
};

PlotPoints plotPoints(const std::vector<CampaignEntry>& entries) {
  PlotPoints pts;
  for (const auto& entry : entries) {
    if (!entry.shot) continue;
    const CampaignShot& s = *entry.shot;
    if (s.v_s_m_s > 0 && std::isfinite(s.beta)) {
      pts.beta.x.push_back(s.cotIncidence());
      pts.beta.y.push_back(s.beta);
      pts.beta.y_err.push_back(s.beta_sigma);
    }
    const double t = s.tanIncidence();
    const auto& c = entry.results->collision;
    if (std::isfinite(c.vs_after_m_s.value)) {
      // y = -v_s'/v_n with v_s' signed along the pre-impact tangent.
      const double y = -c.vs_after_m_s.value / s.v_n_m_s;
      const double sy =
          std::hypot(c.vs_after_m_s.sigma / s.v_n_m_s, y * s.v_n_sigma_m_s / s.v_n_m_s);
      pts.tangent.x.push_back(t);
      pts.tangent.y.push_back(y);
      pts.tangent.y_err.push_back(std::isfinite(sy) ? sy : 0.0);
    }
    if (std::isfinite(s.f)) {
      pts.f.x.push_back(t);
      pts.f.y.push_back(s.f);
      pts.f.y_err.push_back(s.f_sigma);
    }
    pts.e_tan.x.push_back(t);
    pts.e_tan.y.push_back(s.e);
    pts.e_tan.y_err.push_back(s.e_sigma);
    pts.e_vn.x.push_back(-s.v_n_m_s);
    pts.e_vn.y.push_back(s.e);
    pts.e_vn.y_err.push_back(s.e_sigma);
  }
  return pts;
}

// Walton's model with the fitted material over the friction plots.
void addWaltonCurves(const CampaignFitReport& report, const PlotPoints& pts, PlotSpec& p1,
                     PlotSpec& p2, PlotSpec& p3) {
  const Material m = report.fit.friction->material();
  const double K = report.fit.friction->inertia_factor_K;
  char label[160];
  std::snprintf(label, sizeof label, ": mu %.3f, beta0 %.3f, e %.3f", m.mu, m.beta0, m.e);
  for (PlotSpec* p : {&p1, &p2, &p3}) p->title += label;
  std::snprintf(label, sizeof label, "Walton fit");
  const double x_hi = std::max(1.0, 1.1 * maxOr(pts.beta.x, 1.0));
  p1.series.push_back(curve(
      label, linspace(0, x_hi), [&](double x) { return campaignBetaCurve(x, m, K); }, 1));
  const double t_hi = std::max(0.5, 1.1 * maxOr(pts.tangent.x, 0.5));
  p2.series.push_back(curve(
      label, linspace(0, t_hi), [&](double t) { return campaignTangentFormCurve(t, m, K); }, 1));
  const double tf_hi = std::max(0.5, 1.1 * maxOr(pts.f.x, 0.5));
  p3.series.push_back(curve(
      label, linspace(0, tf_hi), [&](double t) { return campaignImpulseRatioCurve(t, m, K); }, 1));
}

// The mean e, and the preferred law of e against |v_n|.
void addRestitutionCurves(const CampaignFitReport& report, const PlotPoints& pts, PlotSpec& p4,
                          PlotSpec& p5) {
  char label[160];
  const auto& mean = report.fit.restitution.e;
  std::snprintf(label, sizeof label, "mean e %.4f", mean.value);
  const double te_hi = std::max(0.5, 1.1 * maxOr(pts.e_tan.x, 0.5));
  p4.series.push_back(curve(
      label, linspace(0, te_hi), [&](double) { return mean.value; }, 1));
  if (report.fit.laws) {
    const auto& laws = *report.fit.laws;
    const auto& law = laws.fit(laws.preferred);
    const double v_hi = 1.1 * maxOr(pts.e_vn.x, 1.0);
    p5.series.push_back(curve(
        law.formula + " (preferred, " + evidenceName(laws.evidence) + ")",
        linspace(v_hi / 200, v_hi), [&](double v) { return law.restitutionAt(v); }, 1));
  }
}

}  // namespace

std::vector<NamedPlot> campaignPlots(const std::vector<CampaignEntry>& entries,
                                     const CampaignFitReport* report) {
  const PlotPoints pts = plotPoints(entries);
  std::vector<NamedPlot> plots;
  PlotSpec p1{"beta against -v_n/v_s (Fig. 5.9)",
              "-v_n / v_s",
              "beta",
              {pts.beta},
              0.0,
              std::nullopt,
              -1.0,
              1.0};
  PlotSpec p2{"Tangent form (Fig. 3.4)",
              "-v_s / v_n",
              "-v_s' / v_n",
              {pts.tangent},
              0.0,
              std::nullopt,
              std::nullopt,
              std::nullopt};
  PlotSpec p3{"Impulse ratio (Fig. 5.11)",
              "tan psi = -v_s / v_n",
              "f = |dP_t| / |dP_n|",
              {pts.f},
              0.0,
              std::nullopt,
              0.0,
              std::nullopt};
  PlotSpec p4{"e against incidence", "tan psi = -v_s / v_n", "e",         {pts.e_tan}, 0.0,
              std::nullopt,          std::nullopt,           std::nullopt};
  PlotSpec p5{"e against |v_n| (Figs. 5.12, 5.13)",
              "|v_n| (m/s)",
              "e",
              {pts.e_vn},
              0.0,
              std::nullopt,
              std::nullopt,
              std::nullopt};
  if (report && report->fit.friction) addWaltonCurves(*report, pts, p1, p2, p3);
  if (report) addRestitutionCurves(*report, pts, p4, p5);
  plots.push_back({"beta_vs_cot", p1});
  plots.push_back({"tangent_form", p2});
  plots.push_back({"f_vs_tan", p3});
  plots.push_back({"e_vs_tan", p4});
  plots.push_back({"e_vs_vn", p5});
  return plots;
}

namespace {
json fitted(const FittedValue& v) {
  return {{"value", v.value}, {"sigma", v.sigma}};
}

// "friction_fit", and mu, beta0 and the switch angle into `material`.
json frictionJson(const CampaignFitReport& report, json& material) {
  if (!report.fit.friction) return {{"error", report.fit.friction.error().message}};
  const auto& fr = *report.fit.friction;
  material.update({{"mu", fitted(fr.mu)},
                   {"beta0", fitted(fr.beta0)},
                   {"switch_angle_deg", fitted(fr.switch_angle_deg)},
                   {"switch_cot", fitted(fr.switch_cot)}});
  return {{"slope", fitted(fr.slope)},
          {"chi2", fr.chi2},
          {"dof", fr.dof},
          {"scale_factor", fr.scale_factor},
          {"sliding_shots", fr.sliding_count},
          {"rolling_shots", fr.rolling_count},
          {"inertia_factor_K", fr.inertia_factor_K}};
}

json restitutionLawsJson(const CampaignFitReport& report) {
  if (!report.fit.laws) return {{"error", report.fit.laws.error().message}};
  const auto& laws = *report.fit.laws;
  json list = json::array();
  for (const auto& law : laws.fits) {
    json params = json::object();
    for (std::size_t i = 0; i < law.parameters.size(); ++i)
      params[law.parameter_names[i]] = fitted(law.parameters[i]);
    list.push_back({{"law", restitutionLawName(law.law)},
                    {"formula", law.formula},
                    {"parameters", params},
                    {"chi2", law.chi2},
                    {"dof", law.dof},
                    {"bic", law.bic},
                    {"delta_bic", law.delta_bic}});
  }
  return {{"preferred", restitutionLawName(laws.preferred)},
          {"evidence", evidenceName(laws.evidence)},
          {"bic_margin", laws.bic_margin},
          {"fits", list}};
}

json bootstrapJson(const CampaignFitReport& report) {
  if (!report.bootstrap) return {{"error", report.bootstrap_error}};
  const auto& b = *report.bootstrap;
  return {{"mu_sigma", b.mu_sigma},
          {"beta0_sigma", b.beta0_sigma},
          {"e_sigma", b.e_sigma},
          {"slope_sigma", b.slope_sigma},
          {"switch_cot_sigma", b.switch_cot_sigma},
          {"resamples_used", b.resamples_used},
          {"resamples_failed", b.resamples_failed}};
}

json launchSpinJson(const CampaignFitReport& report) {
  if (!report.launch_spin) return {{"error", report.launch_spin_error}};
  const auto& ls = *report.launch_spin;
  json j = {{"launch_spin_rad_s", {{"value", ls.per_axis_rad_s}, {"sigma", ls.sigma_rad_s}}},
            {"rms_per_axis_rad_s", {ls.rms_rad_s.x(), ls.rms_rad_s.y(), ls.rms_rad_s.z()}},
            {"spins", ls.spins}};
  if (report.stated_launch_spin_rad_s) j["profile_states_rad_s"] = *report.stated_launch_spin_rad_s;
  if (!report.launch_spin_advice.empty()) j["advice"] = report.launch_spin_advice;
  return j;
}

json trackOffsetJson(const CampaignFitReport& report) {
  if (!report.track_offset) return {{"error", report.track_offset_error}};
  const TrackOffsetExcess& t = *report.track_offset;
  json j = {{"excess_px2", {{"value", t.excess_px2}, {"sigma", t.sigma_px2}}},
            {"excess_px", t.excessPx()},
            {"kink_gap_pull_rms", t.pull_rms},
            {"shots", t.shots}};
  if (const auto& stated = report.stated_centre_offset_px) {
    j["profile_states_px"] = *stated;
    j["suggested_centre_offset_px"] = t.suggestedPx(*stated);
  }
  if (!report.centre_offset_advice.empty()) j["advice"] = report.centre_offset_advice;
  return j;
}

// "shots_used" (with each one's regime and robust weights) and
// "shots_left_out" (with the reason), into `j`.
void shotsJson(const std::vector<CampaignEntry>& entries, const CampaignFitReport& report,
               json& j) {
  json used = json::array(), left_out = json::array();
  std::size_t k = 0;  // index into the fitted shots (regime is per fitted shot)
  for (const auto& e : entries) {
    const std::string name = e.id.empty() ? fs::path(e.file).filename().string() : e.id;
    if (!e.shot) {
      json row = {{"id", name}, {"reason", e.excluded_because}};
      if (!e.excluding_flags.empty()) row["flags"] = e.excluding_flags;
      left_out.push_back(row);
      continue;
    }
    json row = {{"id", name},
                {"e", e.shot->e},
                {"beta", e.shot->beta},
                {"f", e.shot->f},
                {"vn_m_s", e.shot->v_n_m_s},
                {"vs_m_s", e.shot->v_s_m_s}};
    if (const auto& fr = report.fit.friction; fr && k < fr->regime.size()) {
      row["regime"] = fr->regime[k] == CollisionRegime::Sliding ? "sliding" : "rolling";
      row["beta_weight"] = fr->robust_weight[k];
    }
    if (k < report.fit.restitution.robust_weight.size())
      row["e_weight"] = report.fit.restitution.robust_weight[k];
    if (!e.excluding_flags.empty()) row["kept_despite_flags"] = e.excluding_flags;
    ++k;
    used.push_back(row);
  }
  j["shots_used"] = used;
  j["shots_left_out"] = left_out;
}
}  // namespace

std::string campaignReportJson(const std::vector<CampaignEntry>& entries,
                               const CampaignFitReport& report) {
  const auto& em = report.fit.restitution;
  json j;
  j["schema"] = "collide.campaign-fit/1";
  j["material"] = {{"e", fitted(em.e)}};
  j["friction_fit"] = frictionJson(report, j["material"]);
  j["restitution_mean"] = {
      {"e", fitted(em.e)}, {"scatter", em.scatter},           {"chi2", em.chi2},
      {"dof", em.dof},     {"scale_factor", em.scale_factor}, {"shots", em.count}};
  j["restitution_laws"] = restitutionLawsJson(report);
  j["bootstrap"] = bootstrapJson(report);
  j["launch_spin"] = launchSpinJson(report);
  j["track_offset"] = trackOffsetJson(report);
  j["loss"] = robustLossName(report.loss);
  json down = json::array();
  for (const auto& d : report.down_weighted)
    down.push_back({{"id", d.id}, {"beta_weight", d.beta_weight}, {"e_weight", d.e_weight}});
  j["shots_down_weighted"] = down;
  if (!report.error_budget.empty())
    j["error_budget"] = {{"shots", report.error_budget_shots},
                         {"rms_by_source", errorBudgetJson(report.error_budget)}};
  shotsJson(entries, report, j);
  return j.dump(2);
}

}  // namespace collide::app
