#pragma once
// High-speed camera vendors' own files read as footage: Photron MRAW (with its
// .cih text or .cihx XML header) and Phantom CINE. The file is memory-mapped
// and a frame is decoded only when asked for, so a 10 GB recording costs no
// more memory than the frames taken from it. Header numbers are checked
// against the file's size before anything is allocated or read: a damaged or
// truncated file gives an error naming the file and what is wrong, never a
// crash. docs/footage.md describes the formats and what is taken from them.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "analysis/result.hpp"
#include "vision/frame.hpp"

namespace collide::vision {

namespace detail {
class FootageReader;
}

/// What a vendor file says about its footage.
struct FootageInfo {
  std::string format;       ///< "Photron MRAW", "Phantom CINE" or "pco B16"
  std::string data_path;    ///< the file holding the pixels
  std::string header_path;  ///< separate header (.cih/.cihx next to a .mraw), else empty
  std::string camera;       ///< camera model, if the file names it
  int width = 0, height = 0;
  std::int64_t frame_count = 0;
  double fps = 0;          ///< recording frame rate, frames/s; 0 if the file has none
  double exposure_s = 0;   ///< exposure (shutter) time, s; 0 if the file has none
  int stored_bits = 0;     ///< bits per pixel as stored: 8, 16, or 10/12 when packed
  bool packed = false;     ///< pixels packed across byte boundaries (10- or 12-bit)
  int effective_bits = 0;  ///< bits of real data per pixel (12 for a 12-bit sensor in 16-bit words)
  /// Number of the first stored frame counted from the trigger (trigger frame = 0),
  /// when trigger_known; else 0 and frames are numbered from the first stored one.
  std::int64_t first_frame = 0;
  bool trigger_known = false;
  /// Object-plane size of one pixel from the file's own calibration, m; 0 if none.
  double pixel_size_m = 0;
  /// Sensor pixel pitch, m, if the file records it (CINE); not an object-plane scale.
  double sensor_pixel_m = 0;
  PixelFormat pixel_format = PixelFormat::Mono8;  ///< what frames decode to
  std::uint64_t frame_bytes = 0;                  ///< stored bytes of one frame's pixels
  std::string note;  ///< header facts that were noticed but not applied, if any
};

/// An open vendor file. Cheap to copy (copies share the mapping); frames may be
/// read from several threads at once.
class Footage {
 public:
  /// Opens a .mraw (header .cihx or .cih with the same name beside it), a
  /// .cih/.cihx (pixels in the .mraw beside it), a .cine, or a pco .b16 (one
  /// 16-bit image; a recording is a folder of them, see loadFrameFolder). Errors: missing
  /// file or header, unknown extension, bad magic, a header with absurd or
  /// inconsistent numbers, a file shorter than its header says, a pixel
  /// layout this reader does not decode (colour, compressed).
  static Result<Footage> open(const std::string& path);

  const FootageInfo& info() const;

  /// Decodes stored frame `index` (0 .. frame_count-1) into `out`, which is
  /// (re)allocated only if its size or type differ: CV_8UC1 for Mono8, else
  /// CV_16UC1, rows top to bottom as the camera saw them.
  Status read(std::int64_t index, cv::Mat& out) const;

  /// Stored frame `index` as a Frame: id = first_frame + index (trigger-relative
  /// when the file gives the trigger), timestamp id / fps (0 if no fps).
  Result<Frame> frame(std::int64_t index) const;

 private:
  explicit Footage(std::shared_ptr<const detail::FootageReader> reader);
  std::shared_ptr<const detail::FootageReader> reader_;
};

/// True for the extensions Footage::open reads: .mraw, .cih, .cihx, .cine,
/// .b16 (any case). Says nothing about the content.
bool isFootageFile(const std::string& path);

/// Frames to load, by frame id (trigger-relative when the file gives the
/// trigger, else 0-based), both ends included; unset ends mean the file's.
struct FootageRange {
  std::optional<std::int64_t> first_id, last_id;
};

/// Loads frames of a vendor file into a Burst. fps_or_0 > 0 replaces the
/// file's frame rate; 0 takes the file's. Frame ids and timestamps as in
/// Footage::frame. Errors: those of Footage::open; no frame rate in the file
/// and none given; a range outside the file's frames or empty; more than
/// max_bytes of decoded frames (choose a range instead of filling memory).
Result<Burst> loadFootage(const std::string& path, double fps_or_0 = 0,
                          const FootageRange& range = {},
                          std::uint64_t max_bytes = std::uint64_t{4} << 30);

/// The same for a file already open.
Result<Burst> loadFootage(const Footage& footage, double fps_or_0 = 0,
                          const FootageRange& range = {},
                          std::uint64_t max_bytes = std::uint64_t{4} << 30);

/// One multi-line, human-readable description of the file (`collide info`).
std::string describeFootage(const FootageInfo& info);

}  // namespace collide::vision
