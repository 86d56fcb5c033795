#pragma once
// Frames as PNG files, to look at in any image viewer. Mono8 frames become
// 8-bit PNGs and Mono16 16-bit ones, pixel for pixel; Mono12 frames are
// scaled by 16 into 16-bit PNGs so that a viewer shows them with their real
// contrast (0..4095 -> 0..65520).
#include <cstddef>
#include <string>

#include "analysis/result.hpp"
#include "vision/frame.hpp"

namespace collide::app {

struct PngExport {
  std::size_t written = 0;
  std::size_t skipped = 0;  ///< frames without image data (failed in transport)
};

/// Writes `dir`/frame_<index>_id<id>.png for every frame that has an image,
/// e.g. frame_0000_id-2.png (index = position in the burst, zero-padded to
/// sort; id = trigger-relative frame id). Creates `dir` if needed.
/// Errors: the folder cannot be created, a PNG cannot be written (named).
Result<PngExport> exportPng(const vision::Burst& burst, const std::string& dir);

}  // namespace collide::app
