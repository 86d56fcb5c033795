#pragma once
// Footage recorded outside Collide (a Photron MRAW/CIH/CIHX, a Phantom CINE,
// a pco .b16, a video or a folder of PNG/TIFF frames) as a shot that the GUI's
// Replay shows and the analysis measures like a recorded one: the file's
// frames, frame rate and pixel size; no rig, no launch record, no truth.
#include <array>
#include <cstdint>
#include <string>

#include "analysis/result.hpp"
#include "hw/shot.hpp"
#include "vision/footage.hpp"

namespace collide::app {

/// What footage at a path is: a camera file (.mraw/.cihx/.cih, .cine, .b16),
/// a folder of frames, or a video.
enum class FootageKind { CameraFile, Folder, Video };

/// The one decision between the three, for every reader of footage (`analyze
/// --frames`, `track`, the GUI's Open). Errors name the path: nothing there;
/// a frame range (`has_range`) on anything but a camera file; a folder
/// without its frame rate (`fps_given`).
Result<FootageKind> footageKind(const std::string& path, bool has_range = false,
                                bool fps_given = true);

/// Footage read into memory: its frames and the file's own pixel size (0:
/// the file has none; measure it from the spheres).
struct LoadedFootage {
  vision::Burst burst;
  FootageKind kind = FootageKind::CameraFile;
  double file_pixel_size_m = 0;
};

/// Reads the footage at `path`: `fps` > 0 replaces the file's frame rate
/// (required for a folder), `range` picks a camera file's frames, and more
/// decoded bytes than `max_bytes` are refused. Errors name the file.
Result<LoadedFootage> loadFootageAt(const std::string& path, double fps,
                                    const vision::FootageRange& range = {},
                                    std::uint64_t max_bytes = std::uint64_t{4} << 30);

struct FootageShotOptions {
  std::array<double, 2> diameter_m{0.0254, 0.0254};  ///< the spheres' diameters, m
  double fps = 0.0;  ///< > 0 replaces the file's frame rate (required for a frame folder)
  /// Decoded frames above this are refused (choose a range with `collide
  /// export`/`analyze --range` instead of filling memory).
  std::uint64_t max_bytes = std::uint64_t{2} << 30;
};

/// Reads the footage at `path` into a Shot whose id is the file's name.
/// Errors: those of the readers (the message names the file and what is
/// wrong), a frame folder without options.fps, no frames.
Result<hw::Shot> shotFromFootage(const std::string& path, const FootageShotOptions& options = {});

}  // namespace collide::app
