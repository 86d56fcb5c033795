#pragma once
// A burst written as a video file a person can play anywhere: AVI with Motion
// JPEG frames (OpenCV's own writer, no FFmpeg needed), 8-bit grey scaled as
// the GUI shows frames (displayGrey8), at a chosen playback rate.
#include <cstddef>
#include <string>

#include "analysis/result.hpp"
#include "vision/frame.hpp"

namespace collide::vision {

/// `image` as 8-bit grey the way the GUI displays it: 8-bit stays as is,
/// 16-bit words are scaled by 255 / maxValue(format) (Mono12: 4095 -> 255).
cv::Mat displayGrey8(const cv::Mat& image, PixelFormat format);

struct VideoExportOptions {
  /// Frames per second of the written video (playback time, not recording
  /// time): the recording's fps times the slow-down, e.g. 1000 x 1/100 = 10.
  double playback_fps = 25.0;
};

struct VideoExportReport {
  std::size_t written = 0;
  std::size_t skipped = 0;  ///< frames without image data (failed in transport)
};

/// Writes every frame of `burst` that has image data into the AVI file `path`
/// (must end in .avi; replaced if it exists), then reads the file back to
/// check that every frame is in it. Errors name the file and what to do: fps
/// not > 0, no frame with image data, frames of different sizes, the writer
/// cannot create the file (missing folder, permissions), the file is short
/// (disk full). A failed export removes the file it started. Any thread.
Result<VideoExportReport> exportBurstVideo(const Burst& burst, const std::string& path,
                                           const VideoExportOptions& options);

}  // namespace collide::vision
