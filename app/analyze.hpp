#pragma once
// Analysing recorded shots: one shot file, or every shot of a campaign folder
// in parallel. The results go back into each shot file and its catalog row
// (app/store/save.hpp), so `collide shots`, `collide fit` and the GUI see them.
// A shot whose analysis fails keeps its frames untouched and gets results that
// say why (results_json.hpp failedResultsJson), so nothing is lost or hidden.
#include <functional>
#include <stop_token>
#include <string>
#include <vector>

#include "analysis/camera_model.hpp"
#include "analysis/result.hpp"
#include "hw/rig_profile.hpp"
#include "hw/shot.hpp"
#include "vision/shot_analysis.hpp"

namespace collide::app {

/// The analysis settings a recorded shot implies: its scene (pixel size,
/// diameters, masses, world origin), frame rate and lens: the recorded
/// profile's [camera.calibration] when it has one, else its simulated
/// camera's perspective lens, else none (one pixel size).
vision::AnalysisSettings analysisSettingsFor(const hw::Shot& shot);

/// What a rig profile says about its frames, for their analysis: the lens
/// (recordedLens), the calibrated plane's pixel size when `settings` has none,
/// and the alignment priors of its [analysis] table (line of
/// centres tilt, out-of-plane launch, contact distance, radius systematic).
/// Used for the rig's own shots and for its footage (analyze --frames --profile).
void applyProfileToAnalysis(const hw::RigProfile& profile, vision::AnalysisSettings& settings);

/// The lens a rig profile says its frames were taken through: its
/// [camera.calibration] when it has one, else its simulated camera's
/// perspective lens, else none (one pixel size). Shared by both analyses.
std::optional<PinholeCamera> recordedLens(const hw::RigProfile& profile);

/// What happened to one shot file.
struct AnalyzeOutcome {
  std::string file;
  std::string id;         ///< empty if the file could not be read
  bool analysed = false;  ///< results computed and stored
  bool skipped = false;   ///< not analysed: failed shot, or already analysed
  /// Read and analysed, but it holds no collision that can be measured (the
  /// spheres missed each other, a sphere was never found): why is stored in
  /// the file as its results (failedResultsJson). A verdict on the shot, not a
  /// failure of the analysis: running it again gives the same.
  bool unmeasurable = false;
  std::string message;       ///< why it failed or was skipped (what to do)
  std::string results_json;  ///< what was stored (empty if nothing was)
};

/// Reads `path`, analyses its burst, stores the results in the file and its
/// catalog row. A failed shot (status failed) is skipped: it has no collision.
/// When the analysis itself fails, failedResultsJson is stored and the
/// outcome says why (analysed = false). Never throws.
/// `error_budget`: the results also say what each input contributes to the
/// sigmas (vision::AnalysisSettings::error_budget).
AnalyzeOutcome analyzeShotFile(const std::string& path, bool error_budget = false);

struct AnalyzeFolderOptions {
  int jobs = 0;                ///< worker threads; 0 = one per core
  bool skip_analysed = false;  ///< leave shots that already have results
  bool error_budget = false;   ///< vision::AnalysisSettings::error_budget
};
struct AnalyzeFolderReport {
  std::vector<AnalyzeOutcome> outcomes;  ///< in file-name order
  int analysed = 0, unmeasurable = 0, failed = 0, skipped = 0;
  bool cancelled = false;
};
using AnalyzeProgress = std::function<void(int done, int total, const AnalyzeOutcome& last)>;

/// Every *.h5 shot file in `dir`, in parallel. `progress` is called from one
/// thread at a time. Errors: `dir` missing or not a folder, no shot files.
Result<AnalyzeFolderReport> analyzeFolder(const std::string& dir,
                                          const AnalyzeFolderOptions& options = {},
                                          const AnalyzeProgress& progress = {},
                                          std::stop_token cancel = {});

/// The shot files `files` (from several folders, e.g. a manifest's chunk), in
/// parallel, outcomes in the given order. Each result is stored into its file
/// and, for a file named <id>.h5, into its folder's catalog: safe beside other
/// processes analysing the same folders (saveResults holds the folder's store
/// lock), and idempotent (the same shot analysed twice stores the same
/// results). A file that cannot be read is an outcome (failed), not an error.
AnalyzeFolderReport analyzeFiles(const std::vector<std::string>& files,
                                 const AnalyzeFolderOptions& options = {},
                                 const AnalyzeProgress& progress = {}, std::stop_token cancel = {});

}  // namespace collide::app
