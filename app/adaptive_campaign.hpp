#pragma once
// `collide campaign --adaptive` (issue 16 §2): fire, analyse, refit, and choose
// the next shot's incidence where the uncertainty of mu or beta_0 falls most
// (analysis/adaptive_design.hpp), until both reach their targets or the shot
// budget is spent. Every shot is saved and analysed as in a plain campaign.
#include <functional>
#include <stop_token>
#include <string>
#include <vector>

#include "analysis/adaptive_design.hpp"
#include "analysis/result.hpp"
#include "app/campaign.hpp"
#include "hw/rig_profile.hpp"

namespace collide::app {

/// One shot of the adaptive campaign and why it was chosen.
struct AdaptiveShot {
  std::string id;
  double incidence_deg = 0.0;  ///< as chosen (psi, 0 head-on)
  std::string why;             ///< the design's reason
  std::string note;            ///< replanned / not analysed / left out of the fits, and why
  bool used = false;           ///< its measurement entered the fits
};

struct AdaptiveCampaignReport {
  CampaignReport campaign;  ///< shots fired, saved, failed (as a plain campaign)
  std::vector<AdaptiveShot> shots;
  AdaptiveStatus status;  ///< the fits after the last shot
  bool targets_met = false;
};

/// Called after each shot is fired, saved and analysed.
using AdaptiveProgress =
    std::function<void(int done, int budget, const AdaptiveShot& shot, const AdaptiveStatus&)>;

/// `options.shots` is the budget; the angle range and exit speeds come from
/// `options` as for a plain campaign (speeds drawn per shot until the design
/// knows how the noise scales with speed, then one end of the range, each
/// launcher the same). Errors as
/// runCampaign's, and bad design options (named).
/// The fit's sigmas against the targets, e.g. "sigma(mu) 0.00612 (target
/// 0.005), sigma(beta_0) 0.0133 (target 0.02)"; before a friction fit, why
/// there is none. Shown after each shot by the CLI and the GUI.
std::string adaptiveSigmasText(const AdaptiveStatus& status, const AdaptiveOptions& design);

/// Why the adaptive campaign ended, with the figures: "targets reached after 8
/// shots: sigma(mu) 0.0042 <= 0.005, ...", "targets not reached within 20
/// shots (the budget): sigma(mu) 0.0061 > 0.005, ...", "stopped on request
/// after 3 of at most 20 shots: ...", or the rig's reason for stopping.
std::string adaptiveStopText(const AdaptiveCampaignReport& report, const CampaignOptions& options,
                             const AdaptiveOptions& design);

Result<AdaptiveCampaignReport> runAdaptiveCampaign(const hw::RigProfile& profile,
                                                   const CampaignOptions& options,
                                                   const AdaptiveOptions& design,
                                                   const AdaptiveProgress& progress = {},
                                                   std::stop_token cancel = {});

}  // namespace collide::app
