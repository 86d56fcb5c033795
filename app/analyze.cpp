#include "app/analyze.hpp"

#include <sched.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <numbers>
#include <thread>

#include "app/report/results_json.hpp"
#include "app/store/save.hpp"
#include "app/store/shot_file.hpp"
#include "app/wall_analyze.hpp"
#include "hw/camera_sim.hpp"
#include "hw/rig_profile.hpp"

namespace collide::app {
namespace fs = std::filesystem;

std::optional<PinholeCamera> recordedLens(const hw::RigProfile& profile) {
  if (profile.camera_calibration) return profile.camera_calibration->lens(profile.geometry);
  if (auto lens = hw::simulatedLens(profile); lens && *lens) return **lens;
  return std::nullopt;
}

void applyProfileToAnalysis(const hw::RigProfile& profile, vision::AnalysisSettings& s) {
  // The lens the frames were filmed through: centres through it, not one pixel size.
  s.camera = recordedLens(profile);
  // Footage that does not carry its scale takes the calibrated plane's (m/px).
  if (!(s.pixel_size_m > 0) && profile.camera_calibration &&
      profile.camera_calibration->plane_pixel_size_m)
    s.pixel_size_m = *profile.camera_calibration->plane_pixel_size_m;
  // The alignment the profile states ([analysis]): priors for the out-of-plane parts.
  s.line_of_centres_z_sigma =
      std::sin(profile.analysis.line_of_centres_tilt_deg * std::numbers::pi / 180.0);
  s.out_of_plane_speed_fraction = profile.analysis.launch_out_of_plane_fraction;
  s.unknown_spin_sigma_rad_s = profile.analysis.launch_spin_rad_s;
  s.contact_distance_sigma_px = profile.analysis.contact_distance_sigma_px;
  s.radius_systematic_px = profile.analysis.radius_systematic_px;
  s.centre_offset_px = profile.analysis.centre_offset_px;
  s.blur_offset_onset_px = profile.analysis.blur_offset_onset_px;
  s.blur_offset_per_px2 = profile.analysis.blur_offset_per_px2;
  s.air_density_kg_m3 = profile.analysis.air_density_kg_m3;
}

vision::AnalysisSettings analysisSettingsFor(const hw::Shot& shot) {
  vision::AnalysisSettings s;
  s.pixel_size_m = shot.scene.pixel_size_m;
  s.diameter_m = shot.scene.diameter_m;
  s.mass_kg = shot.scene.mass_kg;
  s.origin_u_px = shot.scene.origin_u_px;
  s.origin_v_px = shot.scene.origin_v_px;
  s.fps = shot.burst.fps > 0 ? shot.burst.fps : shot.camera.fps;
  if (auto profile = hw::parseRigProfile(shot.rig_profile_toml, shot.id + " (recorded profile)"))
    applyProfileToAnalysis(*profile, s);
  return s;
}

namespace {

vision::AnalysisSettings settingsFor(const hw::Shot& shot, const AnalyzeFolderOptions& options) {
  vision::AnalysisSettings s = analysisSettingsFor(shot);
  s.error_budget = options.error_budget;
  return s;
}

// Shared by one-file and folder analysis; `store_mutex` serialises the writes
// (the catalog is one SQLite file) while the analyses run in parallel.
AnalyzeOutcome analyzeOne(const std::string& path, const AnalyzeFolderOptions& options,
                          std::mutex& store_mutex) {
  AnalyzeOutcome out;
  out.file = path;
  auto shot = readShot(path, {.contained = true});
  if (!shot) {
    out.message = shot.error().message;
    return out;
  }
  out.id = shot->id;
  if (shot->status == hw::ShotStatus::Failed) {
    out.skipped = true;
    out.message = "failed shot (" + shot->failure_reason + "): nothing to analyse";
    return out;
  }
  if (options.skip_analysed && !shot->results_json.empty()) {
    out.skipped = true;
    out.message = "already analysed";
    return out;
  }
  if (auto wall = analyzeWallShot(*shot)) {  // a sphere-on-wall shot
    if (*wall) {
      out.results_json = **wall;
      out.analysed = true;
    } else {
      out.results_json = failedResultsJson(wall->error().message);
      out.message = wall->error().message;
      out.unmeasurable = true;
    }
  } else if (auto analysis = vision::analyzeBurst(shot->burst, settingsFor(*shot, options));
             analysis) {
    out.results_json = resultsToJson(*analysis);
    out.analysed = true;
  } else {
    out.results_json = failedResultsJson(analysis.error().message);
    out.message = analysis.error().message;
    out.unmeasurable = true;
  }
  const std::string dir = fs::path(path).parent_path().string();
  std::lock_guard lock(store_mutex);
  // A file not named <id>.h5 is not in a catalog by that name: store in the file only.
  const bool catalogued = fs::path(path).filename() == shotFileName(shot->id);
  Status stored = catalogued ? saveResults(dir.empty() ? "." : dir, shot->id, out.results_json)
                             : storeResults(path, out.results_json);
  if (!stored) {
    out.analysed = false;
    out.unmeasurable = false;
    out.message = "results not stored: " + stored.error().message;
  }
  return out;
}

}  // namespace

AnalyzeOutcome analyzeShotFile(const std::string& path, bool error_budget) {
  std::mutex m;
  return analyzeOne(path, {.error_budget = error_budget}, m);
}

Result<AnalyzeFolderReport> analyzeFolder(const std::string& dir,
                                          const AnalyzeFolderOptions& options,
                                          const AnalyzeProgress& progress, std::stop_token cancel) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return fail(dir + ": no such folder");
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().extension() == ".h5") files.push_back(e.path().string());
  if (ec) return fail(dir + ": cannot list the folder: " + ec.message());
  if (files.empty()) return fail(dir + ": no shot files (*.h5) in this folder");
  std::sort(files.begin(), files.end());
  return analyzeFiles(files, options, progress, std::move(cancel));
}

AnalyzeFolderReport analyzeFiles(const std::vector<std::string>& files,
                                 const AnalyzeFolderOptions& options,
                                 const AnalyzeProgress& progress, std::stop_token cancel) {
  AnalyzeFolderReport report;
  report.outcomes.resize(files.size());
  std::atomic<std::size_t> next{0};
  std::mutex store_mutex, progress_mutex;
  int done = 0;
  auto worker = [&] {
    for (std::size_t i; !cancel.stop_requested() && (i = next++) < files.size();) {
      AnalyzeOutcome o = analyzeOne(files[i], options, store_mutex);
      std::lock_guard lock(progress_mutex);
      report.outcomes[i] = std::move(o);
      ++done;
      if (progress) progress(done, static_cast<int>(files.size()), report.outcomes[i]);
    }
  };
  // The cores this process may run on: a Slurm task (or taskset) gets fewer
  // than the machine has.
  unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof allowed, &allowed) == 0 && CPU_COUNT(&allowed) > 0)
    cores = static_cast<unsigned>(CPU_COUNT(&allowed));
  const std::size_t jobs = std::max<std::size_t>(
      1, std::min<std::size_t>(files.size(), options.jobs > 0 ? options.jobs : cores));
  std::vector<std::jthread> threads;
  for (std::size_t t = 1; t < jobs; ++t) threads.emplace_back(worker);
  worker();
  threads.clear();  // joins

  report.cancelled = cancel.stop_requested() && done < static_cast<int>(files.size());
  std::vector<AnalyzeOutcome> kept;
  for (auto& o : report.outcomes) {
    if (o.file.empty()) continue;  // not reached before a cancel
    if (o.analysed) {
      ++report.analysed;
    } else if (o.unmeasurable) {
      ++report.unmeasurable;
    } else if (o.skipped) {
      ++report.skipped;
    } else {
      ++report.failed;
    }
    kept.push_back(std::move(o));
  }
  report.outcomes = std::move(kept);
  return report;
}

}  // namespace collide::app
