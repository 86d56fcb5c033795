#pragma once
// A shot's analysis results as JSON: what `collide analyze` prints and stores
// in the shot file (results_json) and what `collide fit` and the GUI read back.
// Layout (docs/results-format.md), every quantity in SI units named by its key:
//
//   {"schema": "collide.results/1",
//    "e", "beta", "f", "gamma_deg", "vn_m_s", "vs_m_s": the headline numbers
//                                    (also under "collision"; null if unknown),
//    "quality_flags": ["..."],
//    "pixel_size_m": s,
//    "radius_scatter_px": the outlines' radius scatter from frame to frame,
//    "radius_systematic_px": the radius bias' change along a track the
//                            sigmas carry,
//    "kink_gap": {"gap_s", "sigma_s", "var_per_px2_s2"}: where the spheres'
//                tracks bend, sphere 1's minus sphere 2's, its spread over
//                the draws and its variance per px^2 of further centre
//                offset per track (analysis/track_offset.hpp),
//    "notes": ["sentences explaining flags and what was set aside"],
//    "sphere1"/"sphere2": {"velocity_before_m_s": [x,y,z], "velocity_after_m_s",
//                          "spin_before_rad_s", "spin_after_rad_s",
//                          "frames_before", "frames_after",
//                          "spin_before_prior_directions": directions of the
//                          spin before that the dots pinned less well than the
//                          launchers' spread, combined with it, 0-3},
//    "collision": {"e", "beta" (beta_from_spins and beta_from_impulse
//                  combined, beta_spin_weight on the first), "beta_from_spins",
//                  "beta_from_impulse", "beta_spin_weight", "f", "gamma_deg", "vn_m_s",
//                  "vs_m_s", "vs_after_m_s", "t_collision_s",
//                  "t_collision_before_s", "t_collision_after_s"},
//    "uncertainty": {same keys as "collision" (standard uncertainties),
//                    "sphere1"/"sphere2": {same vector keys}},
//    "error_budget": [{"source": "trajectory_fits", "e", "beta", "gamma_deg"}, ...]
//                    (only when asked for: the sigmas with one source drawn),
//    "error": "why the analysis failed" (only then; the rest may be missing)}
//
// sphere1 is the sphere on the left before impact. Axes: x right, y up, z
// towards the camera. Times from the first analysed frame.
#include <array>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/campaign.hpp"
#include "analysis/result.hpp"
#include "vision/shot_analysis.hpp"

namespace collide::app {

inline constexpr const char* kResultsSchema = "collide.results/1";

/// The results JSON (pretty-printed with `indent` spaces, or one line for -1).
std::string resultsToJson(const vision::ShotAnalysis& analysis, int indent = 2);
/// The JSON stored for a shot whose analysis failed: the reason, and the flag
/// "analysis_failed", so the catalog shows it and nothing else is lost.
std::string failedResultsJson(const std::string& reason);

/// One row of the results' error budget (vision::ShotAnalysis::error_budget).
struct ErrorBudgetLine {
  std::string source;                     ///< e.g. "trajectory_fits"
  double e = 0, beta = 0, gamma_deg = 0;  ///< sigmas with only it drawn (NaN: unknown)
};

/// Rows as the results JSON and the campaign fit write them: an array of
/// {"source", "e", "beta", "gamma_deg"} (NaN as null).
nlohmann::json errorBudgetJson(const std::vector<ErrorBudgetLine>& rows);

/// The results read back (for fits, tables and the GUI).
struct ShotResults {
  std::optional<std::string> error;  ///< set when the analysis failed
  double pixel_size_m = 0;
  std::array<vision::SphereKinematics, 2> sphere;
  vision::CollisionProperties collision;  ///< NaN where the JSON has null
  std::vector<std::string> quality_flags;
  std::vector<ErrorBudgetLine> error_budget;  ///< empty unless the analysis was asked for it
  /// vision::ShotAnalysis's, NaN where the JSON has none (written before them).
  double radius_scatter_px = 0, radius_systematic_px = 0;
  KinkGap kink_gap;  ///< NaN where the JSON has none
  std::vector<std::string> notes;
};
/// Errors: not JSON, not an object, another schema, a key of the wrong type
/// (named, e.g. "collision.e").
Result<ShotResults> parseResultsJson(const std::string& json);

/// A shot's collision as the campaign fits take it (non-finite sigmas of
/// v_n, v_s and f become 0; the values are copied as they are).
CampaignShot campaignShotFrom(const vision::CollisionProperties& collision);

/// The shot as the campaign fits see it. Errors: the analysis failed, or a
/// quantity the fits need is missing (named).
Result<CampaignShot> toCampaignShot(const ShotResults& results);

}  // namespace collide::app
