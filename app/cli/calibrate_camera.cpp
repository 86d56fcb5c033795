// `collide calibrate-camera`: the camera's lens from chessboard pictures
// (app/calibrate.hpp), shown as a table, written as JSON and into a rig
// profile's [camera.calibration]; or, with --render-targets, the pictures a
// simulated camera takes of a chessboard through its own lens.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "app/calibrate.hpp"
#include "app/cli/command.hpp"
#include "app/profile_edit.hpp"
#include "app/store/atomic_file.hpp"

namespace {

using collide::cli::kExitBadInput;
using collide::cli::kExitFailure;
using collide::cli::kExitOk;

struct Options {
  std::vector<std::string> images;
  std::string plane;
  double square_mm = 0;
  std::string board = "9x6";
  std::string profile;  // written into
  std::string json;
  std::optional<double> pitch_um;
  std::string render_dir;
  std::string rig;
  int views = 16;
};

int fail(const std::string& message, int code = kExitBadInput) {
  std::cerr << "collide calibrate-camera: " << message << "\n";
  return code;
}

int renderTargets(const Options& o, const cv::Size& corners) {
  if (o.rig.empty())
    return fail("--render-targets needs --rig FILE: the simulated camera's profile");
  auto profile = collide::hw::loadRigProfile(o.rig);
  if (!profile) return fail(profile.error().message);
  collide::vision::ChessboardSpec board{corners, o.square_mm * 1e-3};
  auto views = collide::app::renderCalibrationTargets(*profile, o.render_dir, board, o.views);
  if (!views) return fail(views.error().message, kExitFailure);
  std::cout << "Wrote " << views->views.size() << " views and the collision plane picture "
            << views->plane << " of a " << corners.width << " x " << corners.height
            << " board (inner corners) of " << views->board.square_m * 1e3
            << " mm squares, through " << o.rig << "'s camera. Calibrate with:\n  collide "
            << "calibrate-camera " << o.render_dir << "/view-*.png --plane " << views->plane
            << " --board " << corners.width << "x" << corners.height << " --square-mm "
            << views->board.square_m * 1e3 << "\n";
  return kExitOk;
}

int calibrate(const Options& o, const cv::Size& corners) {
  if (!(o.square_mm > 0)) return fail("--square-mm: give the side of one square in mm (> 0)");
  if (o.images.empty() && o.plane.empty())
    return fail("name the chessboard pictures (at least " +
                std::to_string(collide::vision::kMinCalibrationViews) + ")");
  for (const auto& f : o.images)
    if (std::error_code ec; !std::filesystem::is_regular_file(f, ec))
      return fail(f + ": no such picture file; check the path");
  if (std::error_code ec; !o.plane.empty() && !std::filesystem::is_regular_file(o.plane, ec))
    return fail("--plane " + o.plane + ": no such picture file; check the path");
  collide::app::CalibrationInput in{o.images, o.plane, {corners, o.square_mm * 1e-3}};
  // The profile to write into is read (and checked) before the work.
  std::optional<collide::hw::RigProfile> profile;
  if (!o.profile.empty()) {
    auto p = collide::hw::loadRigProfile(o.profile);
    if (!p) return fail(p.error().message);
    profile = std::move(*p);
  }
  auto run = collide::app::calibrateFromFiles(in);
  if (!run) return fail(run.error().message, kExitFailure);
  std::optional<double> pitch = o.pitch_um;
  if (!pitch && profile) pitch = collide::app::profilePixelPitchUm(*profile);
  std::cout << collide::app::calibrationTable(*run, pitch);
  if (!o.json.empty()) {
    if (auto s = collide::app::writeTextFile(
            o.json, collide::app::calibrationJson(*run, pitch).dump(2) + "\n");
        !s)
      return fail(s.error().message, kExitFailure);
    std::cout << "\nWrote " << o.json << "\n";
  }
  if (profile) {
    auto text = collide::app::profileWithCalibration(profile->text, o.profile, *run);
    if (!text) return fail(text.error().message, kExitFailure);
    std::string backup;
    if (auto s = collide::app::writeProfileFile(o.profile, *text, &backup); !s)
      return fail(s.error().message, kExitFailure);
    std::cout << "\nWrote [camera.calibration] into " << o.profile
              << (backup.empty() ? "" : " (the previous file is " + backup + ")") << "\n";
  }
  return kExitOk;
}

void setupCalibrateCamera(CLI::App& sub, std::function<int()>& run) {
  auto o = std::make_shared<Options>();
  sub.add_option("images", o->images, "Chessboard pictures (PNG, TIFF, ...; 8 or 16 bit)");
  sub.add_option("--square-mm", o->square_mm, "Side of one square, mm");
  sub.add_option("--board", o->board,
                 "Inner corners (where four squares meet) across x down, e.g. 9x6")
      ->capture_default_str();
  sub.add_option("--plane", o->plane,
                 "A picture of the board lying in the collision plane: its distance and the "
                 "pixel scale there");
  sub.add_option("--profile", o->profile,
                 "Rig profile to write the result into as [camera.calibration] (a .bak is kept)");
  sub.add_option("--json", o->json, "Write the result as JSON to this file");
  sub.add_option("--pixel-pitch-um", o->pitch_um,
                 "Sensor pixel pitch, um: the focal length in mm too (a simulated camera's "
                 "profile states it)");
  sub.add_option("--render-targets", o->render_dir,
                 "Instead: draw chessboard pictures through --rig's simulated camera into DIR");
  sub.add_option("--rig", o->rig, "With --render-targets: the simulated rig's profile");
  sub.add_option("--views", o->views, "With --render-targets: tilted views to draw (3..16)")
      ->capture_default_str();
  sub.footer(
      "Calibrates from 10 or more pictures of a flat chessboard in varied poses (tilted up to "
      "~30 degrees, near the corners of the field), and one of it lying in the collision plane "
      "(--plane). Prints f, the principal point and distortion k1 k2 p1 p2 with their standard "
      "uncertainties, the reprojection error and the pixel scale at the collision plane.\n"
      "Example (simulated camera):\n"
      "  collide calibrate-camera --render-targets targets --rig config/sim-lab.toml "
      "--square-mm 8.5\n"
      "  collide calibrate-camera targets/view-*.png --plane targets/plane.png --board 9x6 "
      "--square-mm 8.5 --profile my-lab.toml");
  run = [o] {
    auto corners = collide::app::parseBoardSize(o->board);
    if (!corners) return fail(corners.error().message);
    if (!o->render_dir.empty()) return renderTargets(*o, *corners);
    return calibrate(*o, *corners);
  };
}

}  // namespace

// The name has a dash: keep the macro's argument without spaces.
// clang-format off
COLLIDE_COMMAND(calibrate-camera,
                "The camera's lens from chessboard pictures, into the rig profile (or draw them)",
                setupCalibrateCamera);
// clang-format on
