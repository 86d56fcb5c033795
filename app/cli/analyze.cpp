// `collide analyze`: shot files or campaign folders (results stored in the
// files and the catalog), or footage recorded elsewhere (--frames, JSON out).
#include "app/analyze.hpp"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include "app/cli/command.hpp"
#include "app/cli/footage_options.hpp"
#include "app/cli/interrupt.hpp"
#include "app/cli/progress.hpp"
#include "app/footage_shot.hpp"
#include "app/manifest.hpp"
#include "app/report/results_json.hpp"
#include "app/report/wall_results_json.hpp"
#include "app/store/atomic_file.hpp"
#include "hw/rig_profile.hpp"
#include "vision/footage.hpp"
#include "vision/frame_io.hpp"
#include "vision/wall_shot_analysis.hpp"

namespace {

namespace fs = std::filesystem;
using collide::cli::kExitBadInput;
using collide::cli::kExitFailure;
using collide::cli::kExitOk;

/// Default of numeric options that must be told apart from a value given
/// wrongly (0, nan): "--fps nan" is a bad value, not a missing one.
constexpr double kNotGiven = -1.0;

struct Options {
  std::vector<std::string> paths;
  int jobs = 0;
  bool skip_analysed = false;
  std::string frames;
  double fps = kNotGiven;
  double exposure_us = kNotGiven;  // --frames: when the file does not say
  double diameter_mm = kNotGiven, diameter2_mm = 0;
  std::string json_out;
  std::string gravity_dir = "down";
  std::string polarity = "auto";
  std::string wall_line;  // "u1,v1,u2,v2": a sphere-on-wall shot, the plate's face
  bool wall = false;      // a sphere-on-wall shot, the face found in the frames
  std::string range;      // "FIRST:LAST" frame ids of a camera file
  std::string manifest;
  std::optional<long> index;
  std::optional<long> chunk;
  std::string profile;  // --frames: a rig profile whose [camera.calibration] gives the lens
  bool error_budget = false;
};

std::string pm(const collide::vision::Measured& m, int decimals) {
  if (!std::isfinite(m.value)) return "-";
  char buf[64];
  if (std::isfinite(m.sigma)) {
    std::snprintf(buf, sizeof buf, "%.*f±%.2g", decimals, m.value, m.sigma);
  } else {
    std::snprintf(buf, sizeof buf, "%.*f", decimals, m.value);
  }
  return buf;
}

// The error budget (--error-budget) under the summary: one row per source
// that contributes, its sigmas of e, beta and gamma.
std::string budgetTable(const collide::app::ShotResults& r) {
  if (r.error_budget.empty()) return "";
  const auto cell = [](double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%10.2g", v);
    return std::isfinite(v) ? std::string(buf) : std::string(9, ' ') + "-";
  };
  std::string out = "\n    sigma by source             e      beta  gamma (deg)";
  for (const auto& row : r.error_budget) {
    if (!(row.e > 0) && !(row.beta > 0) && !(row.gamma_deg > 0)) continue;  // nothing drawn
    char name[32];
    std::snprintf(name, sizeof name, "\n    %-18s", row.source.c_str());
    out += name + cell(row.e) + cell(row.beta) + cell(row.gamma_deg);
  }
  return out;
}

// One line per shot: what a physicist scans first; under it the analysis'
// notes (why a flag fired, what was set aside) and the error budget when
// asked for.
std::string summaryLine(const collide::app::ShotResults& r) {
  const auto& c = r.collision;
  std::string flags, notes;
  for (const auto& f : r.quality_flags) flags += (flags.empty() ? "" : ",") + f;
  for (const auto& n : r.notes) notes += "\n    note: " + n;
  return "e " + pm(c.e, 4) + "  beta " + pm(c.beta, 3) + "  f " + pm(c.f, 3) + "  gamma " +
         pm(c.gamma_deg, 1) + " deg  vn " + pm(c.vn_m_s, 3) + " m/s  vs " + pm(c.vs_m_s, 3) +
         " m/s" + (flags.empty() ? "" : "  [" + flags + "]") + notes + budgetTable(r);
}

std::string describe(const collide::app::AnalyzeOutcome& o) {
  const std::string name = o.id.empty() ? o.file : o.id;
  if (o.skipped) return name + ": skipped, " + o.message;
  if (o.unmeasurable)
    return name + ": no measurable collision (stored as its results): " + o.message;
  if (!o.analysed) return name + ": NOT analysed: " + o.message;
  auto r = collide::app::parseResultsJson(o.results_json);
  return name + ": " + (r ? summaryLine(*r) : r.error().message);
}

// "N analysed, U without a measurable collision, F could not be analysed, S
// skipped": what a folder or a manifest task came to.
std::string counts(const collide::app::AnalyzeFolderReport& r) {
  return std::to_string(r.analysed) + " analysed, " + std::to_string(r.unmeasurable) +
         " without a measurable collision, " + std::to_string(r.failed) +
         " could not be analysed, " + std::to_string(r.skipped) + " skipped";
}

// "down", "up", "left", "right", or "U,V" (image axes: u right, v down).
bool parseGravity(const std::string& s, std::array<double, 2>& out) {
  if (s == "down")
    out = {0, 1};
  else if (s == "up")
    out = {0, -1};
  else if (s == "left")
    out = {-1, 0};
  else if (s == "right")
    out = {1, 0};
  else {
    double u = 0, v = 0;
    char comma = 0;
    std::istringstream in(s);
    if (!(in >> u >> comma >> v) || comma != ',' || !in.eof()) return false;
    const double n = std::hypot(u, v);
    if (!(n > 0) || !std::isfinite(n)) return false;
    out = {u / n, v / n};
  }
  return true;
}

int writeJson(const std::string& text, const std::string& out) {
  if (out.empty() || out == "-") {
    std::cout << text << "\n";
    return kExitOk;
  }
  if (auto st = collide::app::writeTextFile(out, text + "\n"); !st) {
    std::cerr << "collide analyze: " << st.error().message << "\n";
    return kExitFailure;
  }
  return kExitOk;
}

// One sphere against a plate (--wall or --wall-line): vision/wall_shot_analysis.
int analyzeWallFootage(const Options& o, const collide::vision::Burst& burst, double pixel_m) {
  collide::vision::WallAnalysisSettings ws;
  ws.pixel_size_m = pixel_m;  // 0: from the sphere's radius and --diameter-mm
  ws.diameter_m = o.diameter_mm * 1e-3;
  ws.mass_kg = 1.0;  // e, beta, f and gamma do not depend on it
  ws.fps = burst.fps;
  if (!o.wall_line.empty()) {
    double u1, v1, u2, v2;
    char c1, c2, c3;
    std::istringstream in(o.wall_line);
    if (!(in >> u1 >> c1 >> v1 >> c2 >> u2 >> c3 >> v2) || c1 != ',' || c2 != ',' || c3 != ',' ||
        (u1 == u2 && v1 == v2)) {
      std::cerr << "collide analyze: --wall-line '" << o.wall_line
                << "': give two distinct pixels on the plate's face as u1,v1,u2,v2\n";
      return kExitBadInput;
    }
    collide::vision::WallLine line;
    line.point_px = {u1, v1};
    line.normal = Eigen::Vector2d(v2 - v1, -(u2 - u1)).normalized();
    ws.wall_line = line;
    ws.refine_wall_line = false;  // the user's line, as given
  }
  auto analysis = collide::vision::analyzeWallBurst(burst, ws);
  if (!analysis) {
    std::cerr << "collide analyze: " << o.frames << ": " << analysis.error().message << "\n";
    return kExitFailure;
  }
  const std::string text = collide::app::wallResultsToJson(*analysis);
  if (!o.json_out.empty() && o.json_out != "-") {
    auto r = collide::app::parseResultsJson(text);
    if (r) std::cout << o.frames << " (wall): " << summaryLine(*r) << "\n";
  }
  return writeJson(text, o.json_out);
}

// The frames' exposure (us), which the motion-blur model needs: the camera
// file's own; else --exposure-us; else, with --profile, its [camera] exposure
// (the rig's camera took them). Given both, --exposure-us wins, with a note.
collide::Status setExposure(const Options& o, const std::optional<collide::hw::RigProfile>& profile,
                            collide::vision::Burst& burst) {
  const double period_us = burst.fps > 0 ? 1e6 / burst.fps : 1e6;
  if (o.exposure_us != kNotGiven) {
    if (!(o.exposure_us > 0 && o.exposure_us <= period_us * (1 + 1e-9)))
      return collide::fail("--exposure-us " + std::to_string(o.exposure_us) +
                           ": give the exposure time in microseconds, > 0 and at most one frame "
                           "period (" +
                           std::to_string(period_us) + " us)");
    if (burst.exposure_us > 0 && std::abs(burst.exposure_us - o.exposure_us) > 1e-6)
      std::cerr << "collide analyze: note: " << o.frames << " says exposure " << burst.exposure_us
                << " us; using --exposure-us " << o.exposure_us << "\n";
    burst.exposure_us = o.exposure_us;
  } else if (!(burst.exposure_us > 0) && profile && profile->camera_config.exposure_us > 0) {
    const double from_profile = profile->camera_config.exposure_us;
    if (from_profile > period_us * (1 + 1e-9)) {  // not the settings these frames were taken with
      std::cerr << "collide analyze: note: " << o.profile << " [camera] exposure_us "
                << from_profile << " is longer than these frames' period (" << period_us
                << " us): motion blur not modelled; give --exposure-us\n";
      return collide::Ok{};
    }
    burst.exposure_us = from_profile;
    std::cerr << "collide analyze: exposure " << burst.exposure_us << " us from " << o.profile
              << " [camera] (the frames do not say; --exposure-us to give another)\n";
  }
  return collide::Ok{};
}

// A calibration holds for pictures of the size it was made on.
collide::Status checkCalibratedSize(const std::string& path,
                                    const collide::hw::CameraCalibrationProfile& cal,
                                    const collide::vision::Burst& burst) {
  if (burst.frames.empty() || (burst.frames[0].image.cols == cal.image_px[0] &&
                               burst.frames[0].image.rows == cal.image_px[1]))
    return collide::Ok{};
  return collide::fail("--profile " + path + ": calibrated on " + std::to_string(cal.image_px[0]) +
                       " x " + std::to_string(cal.image_px[1]) +
                       " px pictures, but the frames are " +
                       std::to_string(burst.frames[0].image.cols) + " x " +
                       std::to_string(burst.frames[0].image.rows) +
                       " px: calibrate with pictures of the footage's size");
}

// --diameter-mm, --fps and --diameter2-mm checked (o.fps 0: the file's own);
// false with the error said.
bool checkFootageNumbers(Options& o) {
  if (o.diameter_mm == kNotGiven) {
    std::cerr << "collide analyze: --diameter-mm is required with --frames (the spheres' "
                 "diameter in millimetres, e.g. 25.4)\n";
    return false;
  }
  if (!(o.diameter_mm > 0 && o.diameter_mm < 1000)) {
    std::cerr << "collide analyze: --diameter-mm " << o.diameter_mm
              << ": give the spheres' diameter in millimetres, between 0 and 1000 (e.g. 25.4)\n";
    return false;
  }
  if (o.fps != kNotGiven && !(o.fps > 0 && o.fps <= 2e7)) {
    std::cerr << "collide analyze: --fps " << o.fps
              << ": give the frame rate the camera recorded at, frames per second (> 0)\n";
    return false;
  }
  if (o.fps == kNotGiven) o.fps = 0;  // the loaders' "take the file's own"
  if (o.diameter2_mm < 0 || o.diameter2_mm >= 1000) {
    std::cerr << "collide analyze: --diameter2-mm must be a diameter in millimetres\n";
    return false;
  }
  return true;
}

// --gravity-dir, --polarity and --range into settings and range; false with
// the error said.
bool parseFootageChoices(const Options& o, collide::vision::AnalysisSettings& settings,
                         collide::vision::FootageRange& range) {
  if (!parseGravity(o.gravity_dir, settings.gravity_dir_image)) {
    std::cerr << "collide analyze: --gravity-dir '" << o.gravity_dir
              << "': use down, up, left, right, or U,V in image axes (u right, v down)\n";
    return false;
  }
  if (!collide::cli::parsePolarity(o.polarity, settings.polarity)) {
    std::cerr << "collide analyze: --polarity '" << o.polarity
              << "': give auto, dark (silhouettes on a backlight) or bright (lit spheres on a "
                 "dark background)\n";
    return false;
  }
  if (!o.range.empty() && !collide::cli::parseFrameRange(o.range, range)) {
    std::cerr << "collide analyze: --range '" << o.range
              << "': give FIRST:LAST frame ids (e.g. -200:300, or -200: or :300)\n";
    return false;
  }
  return true;
}

// --profile's rig profile: the lens the camera was calibrated with (collide
// calibrate-camera). nullopt when none is given; ok false (the error said)
// when it cannot be read or holds no [camera.calibration].
std::optional<collide::hw::RigProfile> footageProfile(const Options& o, bool& ok) {
  ok = true;
  if (o.profile.empty()) return std::nullopt;
  auto loaded = collide::hw::loadRigProfile(o.profile);
  if (loaded && loaded->camera_calibration) return std::move(*loaded);
  std::cerr << "collide analyze: --profile "
            << (loaded ? o.profile +
                             " has no [camera.calibration]: run collide calibrate-camera "
                             "... --profile " +
                             o.profile
                       : loaded.error().message)
            << "\n";
  ok = false;
  return std::nullopt;
}

int analyzeFootage(const Options& given) {
  Options o = given;
  if (!checkFootageNumbers(o)) return kExitBadInput;
  collide::vision::AnalysisSettings settings;
  collide::vision::FootageRange range;
  if (!parseFootageChoices(o, settings, range)) return kExitBadInput;
  auto loaded = collide::app::loadFootageAt(o.frames, o.fps, range);
  if (!loaded) {
    std::cerr << "collide analyze: " << loaded.error().message << "\n";
    return kExitBadInput;
  }
  const double file_pixel_size_m = loaded->file_pixel_size_m;
  auto* burst = &loaded->burst;
  bool profile_ok = true;
  const std::optional<collide::hw::RigProfile> profile = footageProfile(o, profile_ok);
  if (!profile_ok) return kExitBadInput;
  if (auto st = setExposure(o, profile, *burst); !st) {
    std::cerr << "collide analyze: " << st.error().message << "\n";
    return kExitBadInput;
  }
  if (loaded->kind == collide::app::FootageKind::CameraFile)
    std::cerr << "collide analyze: " << o.frames << ": " << burst->frames.size() << " frames, "
              << burst->fps << " frames/s" << (o.fps > 0 ? " (--fps)" : " (from the file)")
              << (file_pixel_size_m > 0 ? ", pixel size from the file" : "") << "\n";
  if (!burst->note.empty()) std::cerr << "collide analyze: note: " << burst->note << "\n";
  // The camera file's own calibration if it has one (checked against the
  // measured sphere diameters), else from the measured radius and the diameter.
  settings.pixel_size_m = file_pixel_size_m;
  settings.diameter_m = {o.diameter_mm * 1e-3,
                         (o.diameter2_mm > 0 ? o.diameter2_mm : o.diameter_mm) * 1e-3};
  settings.fps = burst->fps;
  if (profile) {
    if (auto st = checkCalibratedSize(o.profile, *profile->camera_calibration, *burst); !st) {
      std::cerr << "collide analyze: " << st.error().message << "\n";
      return kExitBadInput;
    }
    // Its lens, plane pixel size and [analysis] priors, as for the rig's own shots.
    collide::app::applyProfileToAnalysis(*profile, settings);
  }
  if (o.wall || !o.wall_line.empty()) {
    if (o.error_budget) {
      std::cerr << "collide analyze: --error-budget is for two-sphere shots; a sphere-on-wall "
                   "analysis has none (leave it out with --wall / --wall-line)\n";
      return kExitBadInput;
    }
    return analyzeWallFootage(o, *burst, file_pixel_size_m);
  }
  settings.error_budget = o.error_budget;
  collide::cli::ProgressBar bar("frames", static_cast<int>(burst->frames.size()));
  if (isatty(fileno(stderr))) settings.progress = [&](int done, int) { bar.update(done); };
  auto analysis = collide::vision::analyzeBurst(*burst, settings);
  if (!analysis) {
    std::cerr << "collide analyze: " << o.frames << ": " << analysis.error().message << "\n";
    return kExitFailure;
  }
  const std::string text = collide::app::resultsToJson(*analysis);
  if (!o.json_out.empty() && o.json_out != "-") {
    auto r = collide::app::parseResultsJson(text);
    if (r) std::cout << o.frames << ": " << summaryLine(*r) << "\n";
  }
  return writeJson(text, o.json_out);
}

int analyzeShots(const Options& o) {
  int failed = 0, bad = 0;
  collide::cli::StopOnInterrupt stop;
  for (const auto& path : o.paths) {
    if (stop.interrupted()) break;
    std::error_code ec;
    if (fs::is_directory(path, ec)) {
      collide::app::AnalyzeFolderOptions fo{o.jobs, o.skip_analysed, o.error_budget};
      std::unique_ptr<collide::cli::ProgressBar> bar;
      auto report = collide::app::analyzeFolder(
          path, fo,
          [&](int done, int total, const collide::app::AnalyzeOutcome& last) {
            if (!bar) bar = std::make_unique<collide::cli::ProgressBar>("analyze", total);
            bar->update(done, last.id.empty() ? fs::path(last.file).filename().string() : last.id);
          },
          stop.token());
      if (!report) {
        std::cerr << "collide analyze: " << report.error().message << "\n";
        ++bad;
        continue;
      }
      for (const auto& out : report->outcomes) std::cout << describe(out) << "\n";
      std::cout << path << ": " << counts(*report)
                << (report->cancelled ? " (stopped on request)" : "") << "\n";
      failed += report->failed;
    } else if (fs::is_regular_file(path, ec)) {
      auto out = collide::app::analyzeShotFile(path, o.error_budget);
      std::cout << describe(out) << "\n";
      if (!out.analysed && !out.skipped && !out.unmeasurable) ++failed;
    } else {
      std::cerr << "collide analyze: " << path << ": no such file or folder\n";
      ++bad;
    }
  }
  if (bad) return kExitBadInput;
  // Stopped by Ctrl-C or SIGTERM: some shots were never reached.
  return failed || stop.interrupted() ? kExitFailure : kExitOk;
}

// `collide analyze --manifest LIST [--index I] [--chunk K]`: one task of a
// job array (docs/cluster.md).
int analyzeManifest(const Options& o) {
  const std::string& list = o.manifest;
  std::optional<long> index = o.index;
  std::string index_from = "--index";
  if (!index) {
    if (const char* env = std::getenv("SLURM_ARRAY_TASK_ID"); env && *env) {
      char* end = nullptr;
      errno = 0;
      const long v = std::strtol(env, &end, 10);
      if (errno != 0 || *end != '\0' || end == env) {
        std::cerr << "collide analyze: SLURM_ARRAY_TASK_ID='" << env
                  << "' is not a task index: give --index I\n";
        return kExitBadInput;
      }
      index = v;
      index_from = "SLURM_ARRAY_TASK_ID";
    }
  }
  if (o.chunk && !index) {
    std::cerr << "collide analyze: --chunk " << *o.chunk
              << " needs a task index: --index I, or run as a Slurm array task "
                 "(SLURM_ARRAY_TASK_ID)\n";
    return kExitBadInput;
  }
  auto entries = collide::app::readManifest(list);
  if (!entries) {
    std::cerr << "collide analyze: " << entries.error().message << "\n";
    return kExitBadInput;
  }
  const long total = static_cast<long>(entries->size());
  std::vector<collide::app::ManifestEntry> chunk = *entries;
  long first = 0;
  if (index) {
    const long k = o.chunk.value_or(1);
    auto c = collide::app::manifestChunk(*entries, list, *index, k);
    if (!c) {
      std::cerr << "collide analyze: " << c.error().message
                << (index_from == "--index" ? "" : " (the index came from SLURM_ARRAY_TASK_ID)")
                << "\n";
      return kExitBadInput;
    }
    chunk = std::move(*c);
    first = *index * k;
  }
  std::vector<std::string> files;
  for (const auto& e : chunk) files.push_back(e.path);

  collide::cli::StopOnInterrupt stop;
  std::unique_ptr<collide::cli::ProgressBar> bar;
  const auto start = std::chrono::steady_clock::now();
  auto report = collide::app::analyzeFiles(
      files, {o.jobs, o.skip_analysed, o.error_budget},
      [&](int done, int n, const collide::app::AnalyzeOutcome& last) {
        if (!isatty(fileno(stderr))) return;
        if (!bar) bar = std::make_unique<collide::cli::ProgressBar>("analyze", n);
        bar->update(done, last.id.empty() ? fs::path(last.file).filename().string() : last.id);
      },
      stop.token());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  bar.reset();
  // Outcomes come back in chunk order; those a stop request never reached are missing.
  std::size_t next = 0;
  for (const auto& out : report.outcomes) {
    while (next < chunk.size() && chunk[next].path != out.file) ++next;
    const std::string where =
        next < chunk.size() ? list + ":" + std::to_string(chunk[next].line) + ": " : "";
    std::cout << where << describe(out) << "\n";
  }
  const long last = first + static_cast<long>(chunk.size()) - 1;
  char rate[64];
  std::snprintf(rate, sizeof rate, "%.1f s, %.3f shots/s", seconds,
                seconds > 0 ? static_cast<double>(report.analysed) / seconds : 0.0);
  std::cout << list << (index ? " task " + std::to_string(*index) : std::string()) << " (shots "
            << first << "-" << last << " of " << total << "): " << counts(report) << ", " << rate
            << (report.cancelled ? "; stopped on request before the end of the chunk" : "") << "\n";
  return report.failed > 0 || report.cancelled ? kExitFailure : kExitOk;
}

void setupAnalyze(CLI::App& sub, std::function<int()>& run) {
  auto o = std::make_shared<Options>();
  sub.add_option("paths", o->paths, "Shot files (.h5) or campaign folders");
  sub.add_option("-j,--jobs", o->jobs, "Shots analysed in parallel (default: one per core)")
      ->check(CLI::NonNegativeNumber);
  sub.add_flag("--skip-analysed", o->skip_analysed, "Leave shots that already have results");
  sub.add_option("--manifest", o->manifest,
                 "A text file of shot-file paths, one a line (collide manifest DIR... --out "
                 "LIST): analyse its chunk --index of --chunk shots, or all of it");
  sub.add_option("--index", o->index,
                 "With --manifest: this task's index, from 0 (default: $SLURM_ARRAY_TASK_ID; "
                 "without either, the whole manifest)");
  sub.add_option("--chunk", o->chunk,
                 "With --manifest: shots per task; task I takes lines [I*K, (I+1)*K) (default 1)");
  sub.add_option("--frames", o->frames,
                 "Footage recorded elsewhere: a folder of grey PNG/TIFF frames (name order), "
                 "a video file (AVI/MP4), or a camera file (.mraw/.cihx/.cih, .cine); a folder "
                 "may hold pco .b16 images");
  sub.add_option("--fps", o->fps,
                 "Frame rate of --frames, frames/s (a video's or camera file's own by default)");
  sub.add_option("--exposure-us", o->exposure_us,
                 "Exposure time of --frames, microseconds, for the motion-blur model (a camera "
                 "file's own, else --profile's [camera] exposure, by default)");
  sub.add_option("--range", o->range,
                 "Frames of a camera file to analyse, FIRST:LAST ids (trigger = 0 where the file "
                 "says; default all)");
  sub.add_option("--diameter-mm", o->diameter_mm, "Sphere diameter, mm (sets the pixel scale)");
  sub.add_option("--diameter2-mm", o->diameter2_mm, "Second sphere's diameter, mm, if different");
  sub.add_option("--profile", o->profile,
                 "With --frames: a rig profile whose [camera.calibration] (collide "
                 "calibrate-camera) is the lens the footage was filmed through; its [analysis] "
                 "priors (alignment, radius systematic) are used too");
  sub.add_option("--json", o->json_out, "Write the results JSON here (default: stdout)");
  sub.add_flag("--error-budget", o->error_budget,
               "Also say what each input (trajectory fits, centre drift, out-of-plane motion, "
               "contact distance, spins, ...) contributes to the sigmas of e, beta and gamma: "
               "printed under each shot and stored as \"error_budget\" (two-sphere shots; "
               "slower)");
  sub.add_option("--gravity-dir", o->gravity_dir,
                 "Gravity in the image: down (default), up, left, right, or U,V");
  sub.add_option("--polarity", o->polarity,
                 std::string("With --frames: ") + collide::cli::kPolarityHelp);
  sub.add_flag("--wall", o->wall,
               "With --frames: one sphere striking a plate, whose face is found in the frames "
               "(results with \"target\": \"wall\", docs/results-format.md)");
  sub.add_option("--wall-line", o->wall_line,
                 "With --frames: one sphere striking a plate whose face passes through pixels "
                 "u1,v1,u2,v2 (image axes: u right, v down)");
  sub.footer(
      "Shot files: the results are stored in each file and its catalog row; a shot with no\n"
      "measurable collision (a near miss, no sphere found) keeps its frames and gets results\n"
      "saying why. Ctrl-C stops after the shots in progress. Exit status: 0 every shot\n"
      "analysed or found to hold no measurable collision, 1 some could not be analysed\n"
      "(unreadable, results not stored, stopped), 2 bad input.\n"
      "Safe to run twice, and beside other tasks on the same folders (docs/cluster.md).");
  run = [o] {
    if (!o->manifest.empty()) {
      if (!o->paths.empty() || !o->frames.empty()) {
        std::cerr << "collide analyze: give either --manifest or shot files/folders/--frames, "
                     "not both\n";
        return kExitBadInput;
      }
      return analyzeManifest(*o);
    }
    if (o->index || o->chunk) {
      std::cerr << "collide analyze: --index and --chunk go with --manifest LIST\n";
      return kExitBadInput;
    }
    if (!o->frames.empty()) {
      if (!o->paths.empty()) {
        std::cerr << "collide analyze: give either shot files/folders or --frames, not both\n";
        return kExitBadInput;
      }
      return analyzeFootage(*o);
    }
    if (o->paths.empty()) {
      std::cerr << "collide analyze: name shot files or folders, or --frames DIR (see --help)\n";
      return kExitBadInput;
    }
    return analyzeShots(*o);
  };
}

}  // namespace

COLLIDE_COMMAND(analyze, "Measure e, beta, f from shot files, campaign folders or footage",
                setupAnalyze);
