#include "app/adaptive_campaign.hpp"

#include <cmath>
#include <cstdio>
#include <random>

#include "app/analyze.hpp"
#include "app/report/campaign_report.hpp"

namespace collide::app {

namespace {

// "sigma(mu) 0.0061 > 0.005" (compare) or "sigma(mu) 0.0061 (target 0.005)".
std::string sigmaAgainst(const char* name, double sigma, double target, bool compare) {
  char b[128];
  if (compare)
    std::snprintf(b, sizeof b, "%s %.3g %s %.3g", name, sigma, sigma <= target ? "<=" : ">",
                  target);
  else
    std::snprintf(b, sizeof b, "%s %.3g (target %.3g)", name, sigma, target);
  return b;
}

std::string sigmas(const AdaptiveStatus& st, const AdaptiveOptions& design, bool compare) {
  if (!st.friction) return "no friction fit yet: " + st.fit_error;
  return sigmaAgainst("sigma(mu)", st.friction->mu.sigma, design.target_sigma_mu, compare) + ", " +
         sigmaAgainst("sigma(beta_0)", st.friction->beta0.sigma, design.target_sigma_beta0,
                      compare);
}

}  // namespace

std::string adaptiveSigmasText(const AdaptiveStatus& status, const AdaptiveOptions& design) {
  return sigmas(status, design, false);
}

std::string adaptiveStopText(const AdaptiveCampaignReport& r, const CampaignOptions& o,
                             const AdaptiveOptions& design) {
  const int fired = r.campaign.fired;
  const std::string figures = sigmas(r.status, design, true);
  if (r.targets_met) return "targets reached after " + std::to_string(fired) + " shots: " + figures;
  if (r.campaign.cancelled)
    return "stopped on request after " + std::to_string(fired) + " of at most " +
           std::to_string(o.shots) + " shots: " + figures;
  if (!r.campaign.stopped_because.empty())
    return "stopped after " + std::to_string(fired) + " shots: " + r.campaign.stopped_because +
           "; " + figures;
  return "targets not reached within " + std::to_string(o.shots) +
         " shots (the budget): " + figures;
}

Result<AdaptiveCampaignReport> runAdaptiveCampaign(const hw::RigProfile& profile,
                                                   const CampaignOptions& o,
                                                   const AdaptiveOptions& design_in,
                                                   const AdaptiveProgress& progress,
                                                   std::stop_token cancel) {
  if (auto ready = prepareCampaign(profile, o); !ready) return ready.error();
  AdaptiveOptions design = design_in;
  design.angle_min_deg = o.angle_min_deg;
  design.angle_max_deg = o.angle_max_deg;
  // The contact speeds the exit speeds give: the two spheres' speeds add
  // (they fly at each other); a wall shot's is the one sphere's.
  const double launchers = profile.wall ? 1.0 : 2.0;
  design.speed_min_m_s = launchers * o.speed_min_m_s;
  design.speed_max_m_s = launchers * o.speed_max_m_s;
  // The design's options are checked before anything is fired.
  if (auto first = chooseNextShot({}, {}, design); !first) return first.error();

  AdaptiveCampaignReport out;
  std::vector<CampaignShot> measured;
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> speed(o.speed_min_m_s, o.speed_max_m_s);
  int failed_in_a_row = 0;
  for (int i = 0; i < o.shots; ++i) {
    out.status = assessCampaign(measured, design);
    if (out.status.targets_met) break;
    out.campaign.stopped_because = stopReason(o, failed_in_a_row, out.campaign);
    if (cancel.stop_requested() || !out.campaign.stopped_because.empty()) {
      out.campaign.cancelled = cancel.stop_requested();
      out.campaign.not_fired = o.shots - i;
      break;
    }
    auto next = chooseNextShot(measured, out.status, design);
    if (!next) return next.error();
    PlannedShot planned;
    planned.incidence_deg = next->incidence_deg;
    planned.speed_m_s = {speed(rng), speed(rng)};
    if (std::isfinite(next->speed_m_s))  // chosen: each launcher its share
      planned.speed_m_s = {next->speed_m_s / launchers, next->speed_m_s / launchers};
    AdaptiveShot record;
    record.incidence_deg = next->incidence_deg;
    record.why = next->why;
    const std::size_t replanned_before = out.campaign.replanned.size();
    auto shot = fireCampaignShot(profile, planned, o, i, out.campaign, cancel);
    if (!shot) return shot.error();
    if (out.campaign.replanned.size() > replanned_before)
      record.note = out.campaign.replanned.back();
    if (!*shot) {
      record.note = out.campaign.failures.back();
    } else if ((*shot)->status != hw::ShotStatus::Ok) {
      record.id = (*shot)->id;
      record.note = "failed on the rig: " + (*shot)->failure_reason;
      ++failed_in_a_row;
    } else {
      failed_in_a_row = 0;
      record.id = (*shot)->id;
      // Analysed as `collide analyze` does: results into the file and catalog.
      const AnalyzeOutcome analysed = analyzeShotFile(out.campaign.files.back());
      CampaignEntry entry;
      entry.id = record.id;
      entry.file = out.campaign.files.back();
      if (!analysed.analysed) {
        record.note = "not analysed: " + analysed.message;
      } else {
        useResults(entry, analysed.results_json, false);
        if (entry.shot) {
          measured.push_back(*entry.shot);
          record.used = true;
        } else {
          record.note = "left out of the fits: " + entry.excluded_because;
        }
      }
    }
    out.shots.push_back(record);
    if (progress) progress(i + 1, o.shots, out.shots.back(), assessCampaign(measured, design));
  }
  out.status = assessCampaign(measured, design);
  out.targets_met = out.status.targets_met;
  return out;
}

}  // namespace collide::app
