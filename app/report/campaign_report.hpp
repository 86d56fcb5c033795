#pragma once
// A campaign folder's analysed shots fitted as one material (docs/SPEC.md
// "Measuring a material"): the shots read back from their results, which
// shots the fits use and why others are left out, the fits, the thesis' five
// plots (as PlotSpec, drawn to PNG/SVG by `collide fit` and to Qt Charts by
// the GUI, so both show the same data) and the fit report as JSON.
#include <optional>
#include <string>
#include <vector>

#include "analysis/campaign.hpp"
#include "analysis/launch_spin.hpp"
#include "analysis/result.hpp"
#include "analysis/track_offset.hpp"
#include "app/report/plot.hpp"
#include "app/report/results_json.hpp"

namespace collide::app {

struct CampaignEntry {
  std::string id;
  std::string file;
  std::optional<ShotResults> results;  ///< empty if not analysed
  std::optional<CampaignShot> shot;    ///< set when the fits can use it
  std::string excluded_because;        ///< why not used (empty when used)
  /// The shot's quality flags that leave it out of the fits (excludingFlags()),
  /// also when --include-flagged kept it.
  std::vector<std::string> excluding_flags;
  /// The shot's recorded rig profile's [analysis] launch_spin_rad_s (rad/s),
  /// when the profile parses.
  std::optional<double> profile_launch_spin_rad_s;
  /// Its [analysis] centre_offset_px (px), when the profile parses.
  std::optional<double> profile_centre_offset_px;
};

/// Quality flags that leave a shot out of the fits: its numbers are not to be
/// trusted at all (analysis_failed, few_frames_*, collision_instant_disagree,
/// large_residuals, unphysical). Geometry flags (eq. 5.1) do not: those shots carry their
/// own large uncertainties, which the weighted fits take into account.
const std::vector<std::string>& excludingFlags();

/// Fills `entry` from one shot's stored results JSON: the parsed results, and
/// the CampaignShot the fits use unless a quality flag (excludingFlags) or the
/// results themselves leave it out (excluded_because says why).
void useResults(CampaignEntry& entry, const std::string& results_json, bool include_flagged);

/// Reads every shot file in `dir` (without frames). Errors: `dir` missing or
/// without shot files. Unreadable files become entries with the reason.
Result<std::vector<CampaignEntry>> loadCampaign(const std::string& dir,
                                                bool include_flagged = false);
/// The same for the shot files `files` (several folders, a manifest), in the
/// given order; a missing or unreadable file becomes an entry with the reason.
std::vector<CampaignEntry> loadCampaignFiles(const std::vector<std::string>& files,
                                             bool include_flagged = false);
/// The shots the fits use, in entry order.
std::vector<CampaignShot> usableShots(const std::vector<CampaignEntry>& entries);

/// A used shot the robust loss set aside (weight below 0.5 in a fit).
struct DownWeightedShot {
  std::string id;
  double beta_weight = 1;  ///< robust weight in the friction fit (1 head-on)
  double e_weight = 1;     ///< robust weight in e's mean
};

struct CampaignFitReport {
  CampaignFit fit;
  RobustLoss loss = RobustLoss::Huber;
  std::vector<DownWeightedShot> down_weighted;  ///< in entry order
  std::optional<FrictionBootstrap> bootstrap;   ///< cross-check of the sigmas
  std::string bootstrap_error;                  ///< why there is none
  /// The launchers' spin spread from the pre-impact spins the dots showed
  /// (launchSpinSpread): the rig profile's [analysis] launch_spin_rad_s.
  std::optional<LaunchSpinSpread> launch_spin;
  std::string launch_spin_error;  ///< why there is none
  /// What the shots' rig profiles state for it, when they all state one value.
  std::optional<double> stated_launch_spin_rad_s;
  /// Set when that stated value and the measured one disagree beyond the
  /// measurement's 3 sigma and by more than 20 %: what to set it to, and why.
  std::string launch_spin_advice;
  /// What the fitted shots' sigmas are made of: per source, the RMS of its
  /// sigmas of e, beta and gamma over the fitted shots whose results carry an
  /// error budget (`collide analyze --error-budget`; NaN where none states
  /// one). Empty when no shot does.
  std::vector<ErrorBudgetLine> error_budget;
  int error_budget_shots = 0;  ///< how many shots that RMS is over
  /// The centre offset per track the shots' kinks imply beyond what their
  /// analyses drew (measuredKinkGaps, analysis/track_offset.hpp).
  std::optional<TrackOffsetExcess> track_offset;
  std::string track_offset_error;  ///< why there is none
  /// What the shots' rig profiles state for [analysis] centre_offset_px, when
  /// they all state one value.
  std::optional<double> stated_centre_offset_px;
  /// Set when the kinks' excess is beyond 3 of its sigmas and the offset it
  /// suggests differs from the stated one by more than 20 % and 0.005 px:
  /// what to set, and why.
  std::string centre_offset_advice;
};

/// The kinks' gaps (ShotResults::kink_gap) of every analysed shot that no
/// excluding quality flag leaves out (--include-flagged or not).
std::vector<KinkGap> measuredKinkGaps(const std::vector<CampaignEntry>& entries);

/// The pre-impact spins of both spheres of every analysed shot whose spins
/// before the impact were measured and trusted (no "no_spin_before",
/// "spin_poorly_measured" or "spin_impulse_disagree"), flagged shots of
/// other kinds included: their spins before the impact are as good. A spin
/// the analysis took partly from the launchers' spread (its dots pinned some
/// direction less well, spin_before_prior_directions > 0) is left out: it
/// would measure the profile's own value.
std::vector<Estimate3> measuredLaunchSpins(const std::vector<CampaignEntry>& entries);
/// Fits the usable shots (analysis/campaign.hpp fitCampaign, with `loss`)
/// and bootstraps the friction fit (`resamples` >= 10, or 0 for none).
Result<CampaignFitReport> fitCampaignFolder(const std::vector<CampaignEntry>& entries,
                                            int resamples = 200, std::uint64_t seed = 1,
                                            RobustLoss loss = RobustLoss::Huber);

/// The five plots, named for their files: beta_vs_cot (beta against -v_n/v_s
/// with the fitted Walton line), tangent_form (-v_s'/v_n against -v_s/v_n),
/// f_vs_tan (f against tan psi), e_vs_tan (e against tan psi), e_vs_vn (e
/// against |v_n| with the preferred law). `report` may be null (points only).
struct NamedPlot {
  std::string name;
  PlotSpec plot;
};
std::vector<NamedPlot> campaignPlots(const std::vector<CampaignEntry>& entries,
                                     const CampaignFitReport* report);

/// The fit report: material, laws, bootstrap, and the shots used/left out.
std::string campaignReportJson(const std::vector<CampaignEntry>& entries,
                               const CampaignFitReport& report);

}  // namespace collide::app
