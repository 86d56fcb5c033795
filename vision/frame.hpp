#pragma once
// The image types the program speaks: one camera frame, and a burst of frames
// around a trigger (EPICS areaDetector style: frames before the trigger have
// negative ids, frame 0 is the first at or after the trigger).
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace collide::vision {

/// Bits of real data per pixel. Mono12 is stored in 16-bit words (values 0..4095).
enum class PixelFormat { Mono8, Mono12, Mono16 };

inline int bitDepth(PixelFormat f) {
  return f == PixelFormat::Mono8 ? 8 : f == PixelFormat::Mono12 ? 12 : 16;
}
inline int maxValue(PixelFormat f) {
  return (1 << bitDepth(f)) - 1;
}
inline int cvType(PixelFormat f) {
  return f == PixelFormat::Mono8 ? CV_8UC1 : CV_16UC1;
}
const char* toString(PixelFormat f);
/// "Mono8", "Mono12", "Mono16" (case-insensitive); false if unknown.
bool parsePixelFormat(const std::string& s, PixelFormat& out);

/// The largest frame side (pixels) any reader or profile accepts: larger than
/// any scientific camera's sensor, small enough that a corrupt header's
/// dimensions are caught before they size an allocation.
inline constexpr int kMaxFrameSidePx = 32768;

enum class FrameStatus : std::uint8_t {
  Good = 0,        ///< complete frame, safe to analyse
  Failed = 1,      ///< transport reported a failed frame (image content unusable)
  Incomplete = 2,  ///< some packets/lines missing (image content unusable)
};

struct Frame {
  std::int64_t id = 0;            ///< relative to the trigger: <0 before, 0 at trigger
  std::int64_t timestamp_ns = 0;  ///< camera or host monotonic clock, nanoseconds
  FrameStatus status = FrameStatus::Good;
  cv::Mat image;  ///< CV_8UC1 (Mono8) or CV_16UC1 (Mono12/Mono16), one channel

  bool good() const { return status == FrameStatus::Good && !image.empty(); }
};

/// Per-burst stream statistics, modelled on Aravis' stream counters.
struct BurstStats {
  std::uint64_t completed = 0;  ///< frames received complete
  std::uint64_t failed = 0;     ///< frames received but failed or incomplete
  std::uint64_t dropped = 0;    ///< frame ids missing from the sequence
  std::uint64_t underruns = 0;  ///< no buffer available when a frame arrived
  std::uint64_t missing_packets = 0;
  std::uint64_t resent_packets = 0;
  std::vector<std::int64_t> missing_ids;  ///< trigger-relative ids never received
};

struct Burst {
  PixelFormat format = PixelFormat::Mono8;
  double fps = 1000.0;        ///< nominal frame rate, frames per second
  double exposure_us = 0;     ///< exposure time, microseconds
  std::vector<Frame> frames;  ///< ordered by id
  BurstStats stats;
  bool complete = true;  ///< false when the camera stopped before the burst was full
  std::string note;      ///< why incomplete, if it is

  int width() const { return frames.empty() ? 0 : frames.front().image.cols; }
  int height() const { return frames.empty() ? 0 : frames.front().image.rows; }
};

}  // namespace collide::vision
