#pragma once
// Footage recorded elsewhere (a folder of images, or a video file) read into a
// Burst, and bursts written out as PNG files, so recorded shots go through the
// same vision and analysis code as live or simulated ones.
//
// Exported file names: frame_<index>_id<id>.png, with index the frame's position
// in the burst zero-padded (so plain name order — ls, file dialogs, ImageJ,
// loadFrameFolder — is frame order) and id its trigger-relative id as a signed
// number a person can read: frame_0000_id-5.png ... frame_0005_id0.png.
// index has 4 digits, or more when the burst needs them; one burst uses one width.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "vision/frame.hpp"

namespace collide::vision {

/// Loads the images in `dir` (PNG, TIFF; also PGM/PPM/PNM, BMP, JPEG, pco .b16), sorted by
/// name in natural order (frame2 before frame10), as frames 0..N-1 with
/// timestamps i / fps. Grey 8-bit images give Mono8; 16-bit ones give Mono12 if
/// no pixel in the burst exceeds 4095, else Mono16; colour images are converted
/// to grey. Files with other extensions (and subfolders) are skipped and named
/// in Burst::note. Errors: fps <= 0; `dir` missing, not a folder, or without
/// images; an image file that cannot be decoded or has an unsupported pixel
/// type; frames of different sizes or bit depths. Any thread.
Result<Burst> loadFrameFolder(const std::string& dir, double fps);

/// The image files of a frame folder in loadFrameFolder's order, for reading
/// them one at a time (readFrameImage) instead of all at once.
struct FrameFolder {
  std::vector<std::string> paths;  ///< full paths, natural name order
  std::string note;                ///< entries skipped (not images), if any
};
/// Errors: `dir` missing, not a folder, unreadable, or without images.
Result<FrameFolder> listFrameFolder(const std::string& dir);

/// One frame file decoded as loadFrameFolder does (grey, 8- or 16-bit; pco
/// .b16 too). Errors: a file that cannot be decoded, an unsupported pixel type.
Result<cv::Mat> readFrameImage(const std::string& path);

/// Error unless `image` has `first`'s size and bit depth (the paths name them).
Status checkSameFrame(const cv::Mat& first, const std::string& first_path, const cv::Mat& image,
                      const std::string& path);

/// Decodes every frame of a video file with OpenCV (FFmpeg, or OpenCV's own
/// MJPEG reader), converting to grey. fps_or_0 = 0 takes the frame rate
/// recorded in the file. Frames are numbered 0..N-1. Errors: missing file, file
/// OpenCV cannot open or decode, no frames, fps_or_0 < 0, or no frame rate in
/// the file when fps_or_0 = 0. Any thread.
Result<Burst> loadVideo(const std::string& path, double fps_or_0);

/// A video read one frame at a time, for a pass over footage larger than
/// memory (collide track): a first pass counts the frames (decoding, not
/// converting); read(i) decodes forward from the frame read last and opens
/// the file again to go back, so reading in order costs one decode a frame.
/// Frames are grey and numbered as loadVideo's; read() is serialised.
struct VideoStream {
  std::int64_t count = 0;
  double fps = 0;
  int width = 0, height = 0;
  PixelFormat format = PixelFormat::Mono8;
  std::function<Result<Frame>(std::int64_t index)> read;
};
/// Errors: as loadVideo's (at opening, or from read() for a frame that does
/// not decode).
Result<VideoStream> openVideoStream(const std::string& path, double fps_or_0);

/// Writes one frame as a PNG: 8-bit for CV_8UC1, 16-bit for CV_16UC1 (Mono12
/// values stay 0..4095, not rescaled). Errors: empty or unsupported image,
/// file cannot be written (missing folder, permissions, disk full).
Status writeFramePng(const Frame& frame, const std::string& path);

struct PngExportOptions {
  /// Scale Mono12 values by 16 (0..4095 -> 0..65520) so image viewers show the
  /// real contrast. Such files no longer load back as Mono12: leave it off for
  /// a round trip through loadFrameFolder.
  bool stretch_mono12 = false;
};

struct PngExportReport {
  std::size_t written = 0;
  std::size_t skipped = 0;  ///< frames without image data (failed in transport)
};

/// Writes every frame of the burst that has image data into `dir` (created if
/// missing), named as described at the top of this file; frames without image
/// data are skipped and counted (their index is not reused, so gaps show).
/// Errors: the folder cannot be created; two frames share an id; `dir` already
/// holds frames of another export (they would be read back with these); a
/// file cannot be written. Any thread.
Result<PngExportReport> exportBurstPng(const Burst& burst, const std::string& dir,
                                       const PngExportOptions& options = {});

/// The file name exportBurstPng gives the frame at position `index` with id
/// `id`, with the index padded to `digits` >= 1 digits.
std::string frameFileName(std::size_t index, std::int64_t id, int digits = 4);

/// Natural order of names: runs of digits compare as numbers ("frame2" <
/// "frame10"), everything else byte by byte.
bool naturalLess(const std::string& a, const std::string& b);

}  // namespace collide::vision
