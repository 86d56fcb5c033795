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

namespace collide::app {

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
