// `collide track FOOTAGE`: one to three spheres followed through footage, with
// their free-flight segments fitted (JSON, CSV, PNG).
#include "app/track.hpp"

#include <cmath>
#include <filesystem>
#include <iostream>

#include "app/cli/command.hpp"
#include "app/cli/footage_options.hpp"
#include "app/cli/progress.hpp"
#include "app/store/atomic_file.hpp"

namespace {

using collide::cli::kExitBadInput;
using collide::cli::kExitFailure;
using collide::cli::kExitOk;

constexpr double kNotGiven = -1.0;

struct Options {
  std::string footage, json_out, csv_out, png_out, rig;
  std::string spheres = "auto", polarity = "auto", range;
  std::vector<double> diameters_mm;
  double fps = kNotGiven;
};

/// Checks the flags into TrackOptions; prints why and returns false if wrong.
bool toTrackOptions(const Options& o, collide::app::TrackOptions& t) {
  t.footage = o.footage;
  t.rig = o.rig;
  if (std::error_code ec; !o.rig.empty() && !std::filesystem::is_regular_file(o.rig, ec)) {
    std::cerr << "collide track: --profile " << o.rig
              << ": no such file; give a rig profile (e.g. config/sim-lab.toml)\n";
    return false;
  }
  if (o.spheres == "auto") {
    t.spheres = 0;
  } else if (o.spheres == "1" || o.spheres == "2" || o.spheres == "3") {
    t.spheres = std::stoi(o.spheres);
  } else {
    std::cerr << "collide track: --spheres '" << o.spheres << "': give 1, 2, 3 or auto\n";
    return false;
  }
  if (!collide::cli::parsePolarity(o.polarity, t.polarity)) {
    std::cerr << "collide track: --polarity '" << o.polarity
              << "': give auto, dark (silhouettes on a backlight) or bright (lit spheres on a "
                 "dark background)\n";
    return false;
  }
  if (o.diameters_mm.size() > 3) {
    std::cerr << "collide track: --diameter-mm: " << o.diameters_mm.size()
              << " values; give one for all spheres, or one per sphere (at most 3)\n";
    return false;
  }
  for (const double d : o.diameters_mm)
    if (!(d > 0 && d < 1000)) {
      std::cerr << "collide track: --diameter-mm " << d
                << ": give the spheres' diameter in millimetres, between 0 and 1000 (e.g. 25.4, "
                   "or 25.4,19.05 for two sizes)\n";
      return false;
    }
  t.diameters_mm = o.diameters_mm;
  if (o.fps != kNotGiven && !(o.fps > 0 && o.fps <= 2e7)) {
    std::cerr << "collide track: --fps " << o.fps
              << ": give the frame rate the camera recorded at, frames per second (> 0)\n";
    return false;
  }
  t.fps = o.fps == kNotGiven ? 0 : o.fps;
  if (!o.range.empty() && !collide::cli::parseFrameRange(o.range, t.range)) {
    std::cerr << "collide track: --range '" << o.range
              << "': give FIRST:LAST frame ids (e.g. -200:300, or -200: or :300)\n";
    return false;
  }
  return true;
}

std::string pm(double v, double s, const char* spec) {
  char buf[96];
  std::snprintf(buf, sizeof buf, spec, v);
  std::string out = buf;
  if (std::isfinite(s)) {
    std::snprintf(buf, sizeof buf, "±%.2g", s);
    out += buf;
  }
  return out;
}

void printSummary(const collide::app::TrackResult& r) {
  std::cout << r.footage << ": " << r.tracks.frames.size() << " frames at " << r.fps
            << " frames/s, " << r.tracks.spheres << " sphere" << (r.tracks.spheres > 1 ? "s" : "")
            << ", pixel " << r.pixel_size_m * 1e3 << " mm (from the " << r.pixel_size_from << ")\n";
  for (int t = 0; t < r.tracks.spheres; ++t) {
    const auto& ss = r.spheres[t];
    std::cout << "sphere " << t + 1 << ": " << ss.segments.size() << " segment"
              << (ss.segments.size() == 1 ? "" : "s") << "\n";
    for (std::size_t k = 0; k < ss.segments.size(); ++k) {
      const auto& g = ss.segments[k];
      std::cout << "  frames " << ss.first_frame[k] << "-" << ss.last_frame[k] << ": v ("
                << pm(g.velocity_m_s.x(), g.velocity_sigma_m_s.x(), "%.4f") << ", "
                << pm(g.velocity_m_s.y(), g.velocity_sigma_m_s.y(), "%.4f") << ") m/s, at the end ("
                << pm(g.end_velocity_m_s.x(), g.end_velocity_sigma_m_s.x(), "%.4f") << ", "
                << pm(g.end_velocity_m_s.y(), g.end_velocity_sigma_m_s.y(), "%.4f") << ") m/s  a ("
                << pm(g.acceleration_m_s2.x(), g.acceleration_sigma_m_s2.x(), "%.3f") << ", "
                << pm(g.acceleration_m_s2.y(), g.acceleration_sigma_m_s2.y(), "%.3f")
                << ") m/s^2  rms " << pm(g.residual_rms_m / r.pixel_size_m, NAN, "%.3f")
                << " px  ends: " << g.ends_at << "\n";
    }
  }
  for (const auto& n : r.notes) std::cerr << "collide track: note: " << n << "\n";
}

int runTrack(const Options& o) {
  collide::app::TrackOptions t;
  if (!toTrackOptions(o, t)) return kExitBadInput;
  auto footage = collide::app::openFootage(t);
  if (!footage) {
    std::cerr << "collide track: " << footage.error().message << "\n";
    return kExitBadInput;
  }
  const int total = static_cast<int>(footage->source.count);
  // Long footage only: a bar on a terminal (>= 200 frames), one line per 10 %
  // in a log (>= 2000 frames).
  const bool tty = isatty(fileno(stderr));
  collide::cli::ProgressBar bar("frames", total);
  int shown = -1;
  auto progress = [&](int done, int n) {
    if (n < (tty ? 200 : 2000)) return;
    const int step = (tty ? 50 : 10) * done / n;
    if (step == shown && done != n) return;
    shown = step;
    bar.update(done);
  };
  auto result = collide::app::trackFootage(t, *footage, progress);
  if (!result) {
    std::cerr << "collide track: " << result.error().message << "\n";
    return kExitFailure;
  }
  const bool json_to_stdout =
      o.json_out == "-" || (o.json_out.empty() && o.csv_out.empty() && o.png_out.empty());
  if (!json_to_stdout) printSummary(*result);
  auto write = [](const std::string& path, const std::string& text) {
    if (auto st = collide::app::writeTextFile(path, text); !st) {
      std::cerr << "collide track: " << st.error().message << "\n";
      return false;
    }
    return true;
  };
  const std::string json = collide::app::trackToJson(*result);
  if (json_to_stdout) std::cout << json << "\n";
  if (!o.json_out.empty() && o.json_out != "-" && !write(o.json_out, json + "\n"))
    return kExitFailure;
  if (!o.csv_out.empty() && !write(o.csv_out, collide::app::trackToCsv(*result)))
    return kExitFailure;
  if (!o.png_out.empty()) {
    if (auto st = collide::app::writeTrackPng(*result, *footage, o.png_out); !st) {
      std::cerr << "collide track: " << st.error().message << "\n";
      return kExitFailure;
    }
  }
  return kExitOk;
}

void setupTrack(CLI::App& sub, std::function<int()>& run) {
  auto o = std::make_shared<Options>();
  sub.add_option("FOOTAGE", o->footage,
                 "A folder of grey PNG/TIFF (or pco .b16) frames, a video file, or a camera file "
                 "(.mraw/.cihx/.cih, .cine)")
      ->required();
  sub.add_option("--json", o->json_out,
                 "Write the tracks and segments as JSON here (- or nothing else given: stdout)");
  sub.add_option("--csv", o->csv_out, "Write one row per sphere per frame here");
  sub.add_option("--png", o->png_out, "Draw the tracks and fitted segments over a frame (PNG)");
  sub.add_option("--spheres", o->spheres, "How many spheres: 1, 2, 3 or auto (default)");
  sub.add_option("--diameter-mm", o->diameters_mm,
                 "Sphere diameter, mm: the scale, unless the camera file has a pixel size; "
                 "spheres of different sizes: one per sphere, comma-separated (25.4,19.05), "
                 "matched to the spheres by size")
      ->delimiter(',');
  sub.add_option("--profile,--rig", o->rig,
                 "A rig profile: pixels to metres through its camera's lens (then each "
                 "segment's depth and speed towards the camera from the apparent size), or its "
                 "pixel size; its spheres' diameter unless --diameter-mm");
  sub.add_option("--fps", o->fps,
                 "Frame rate, frames/s (required for a folder; a file's own by default)");
  sub.add_option("--polarity", o->polarity, collide::cli::kPolarityHelp);
  sub.add_option("--range", o->range,
                 "Frames of a camera file, FIRST:LAST ids (trigger = 0 where the file says)");
  sub.footer(
      "Per frame each sphere's centre and radius; per sphere the free-flight segments between\n"
      "contacts and bounces, each fitted with constant acceleration (velocity at its first\n"
      "frame, acceleration, uncertainties, residual RMS). docs/results-format.md describes the\n"
      "JSON. Exit status: 0 tracked, 1 nothing could be tracked, 2 bad input.");
  run = [o] { return runTrack(*o); };
}

}  // namespace

COLLIDE_COMMAND(track, "Follow 1-3 spheres through footage and fit their free flight", setupTrack);
