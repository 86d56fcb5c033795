#pragma once
// `collide calibrate-camera` (issue 11): the camera's lens from pictures of a
// chessboard (vision/camera_calibration.hpp), shown as a table with units and
// uncertainties, written as JSON and into the rig profile's
// [camera.calibration] table (hw/rig_profile.hpp), which every shot then
// records with the rest of its profile and the analysis uses
// (app/analyze.hpp analysisSettingsFor). And the pictures themselves for a
// simulated camera: chessboard targets drawn through its own lens and sensor,
// so the whole path is tested against a known lens.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "hw/rig_profile.hpp"
#include "vision/camera_calibration.hpp"

namespace collide::app {

/// "9x6" -> 9 x 6 inner corners. Errors name the flag's expected form.
Result<cv::Size> parseBoardSize(const std::string& text);

struct CalibrationInput {
  std::vector<std::string> images;  ///< picture files (PNG, TIFF, ... 8 or 16 bit)
  std::string plane_image;          ///< the board lying in the collision plane; empty: none
  vision::ChessboardSpec board;
};

struct CalibrationRun {
  vision::CameraCalibration calibration;
  vision::ChessboardSpec board;
  std::vector<std::string> names;  ///< the pictures, in the calibration's order
  int plane_index = -1;            ///< index into names; -1: none
};

/// Reads the pictures (grey or colour, made grey) and calibrates. The plane
/// picture counts as a view too (added if it is not among `images`). Errors
/// name an unreadable file, and say how many usable views are needed.
Result<CalibrationRun> calibrateFromFiles(const CalibrationInput& in);

/// The result as a table with units and standard uncertainties, the
/// pictures left out, and each picture's reprojection error.
/// `pixel_pitch_um` (when known) adds the focal length in millimetres.
std::string calibrationTable(const CalibrationRun& run, std::optional<double> pixel_pitch_um);

/// The result as JSON (SI units and pixels, each value with a _sigma).
nlohmann::json calibrationJson(const CalibrationRun& run, std::optional<double> pixel_pitch_um);

/// `profile_text` with its [camera.calibration] table set to `run` (replaced
/// whole if present), checked by parsing the result as a rig profile
/// (`source` names it in errors).
Result<std::string> profileWithCalibration(const std::string& profile_text,
                                           const std::string& source, const CalibrationRun& run);

/// The pixel pitch a simulated camera's profile states ([camera.imaging]
/// pixel_pitch_um); none for other cameras.
std::optional<double> profilePixelPitchUm(const hw::RigProfile& profile);

struct TargetViews {
  std::vector<std::string> views;  ///< files of the tilted boards
  std::string plane;               ///< file of the board lying in the collision plane
  vision::ChessboardSpec board;    ///< as drawn
};

/// Draws `views` chessboard pictures in varied poses (tilted up to 40
/// degrees, shifted towards the corners, nearer and farther) and one lying
/// in the collision plane, through the profile's simulated camera (its lens,
/// sensor and noise; vision::Renderer::renderChessboard, at least 8 x 8
/// rays a pixel), as PNG files
/// (16-bit for Mono12/Mono16) in `dir` (created). `board.square_m` <= 0:
/// chosen so the board fills about 3/4 of the field. Errors: not a simulated
/// camera with a [camera.imaging] lens, a board that does not fit the field,
/// files that cannot be written.
Result<TargetViews> renderCalibrationTargets(const hw::RigProfile& profile, const std::string& dir,
                                             vision::ChessboardSpec board, int views);

}  // namespace collide::app
