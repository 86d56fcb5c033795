#pragma once
// V4l2Device: a thin wrapper over one V4L2 video capture node (libcamera's
// V4L2VideoDevice): the ioctls, memory-mapped buffers and nothing else. It
// knows no roles and no profiles; CameraV4l2 plays the Camera role on top of
// it. Every error names the device node and says what to do.
//
// Threads: one thread at a time, except dequeue() (the acquisition thread)
// with queue() of the buffer it returned.
#include <linux/videodev2.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"

namespace collide::hw {

/// "GREY", "YUYV", ... (unprintable bytes as '?').
std::string fourccText(std::uint32_t fourcc);
/// The fourcc for a 4-character code such as "Y16 " or "Y16" (padded); 0 if too long.
std::uint32_t fourccFromText(const std::string& text);

/// A control's name the way v4l2-ctl writes it: lowercase, runs of other
/// characters as one '_' ("Exposure Time, Absolute" -> "exposure_time_absolute").
std::string v4l2ControlKey(const std::string& name);

struct V4l2Format {
  std::uint32_t fourcc = 0;
  int width = 0;
  int height = 0;
  int bytes_per_line = 0;
  std::uint32_t size_image = 0;
};

struct V4l2Control {
  std::uint32_t id = 0;
  std::string name;  ///< as the driver names it
  std::string key;   ///< v4l2ControlKey(name)
  std::uint32_t type = 0;
  std::int64_t minimum = 0, maximum = 0, step = 1, default_value = 0;
  bool read_only = false;
};

/// One filled buffer, valid until it is queued again.
struct V4l2Capture {
  int index = -1;
  std::uint32_t sequence = 0;      ///< the driver's frame counter
  std::int64_t timestamp_ns = 0;   ///< as the driver stamped it
  bool monotonic = false;          ///< timestamp on CLOCK_MONOTONIC
  bool start_of_exposure = false;  ///< stamped at start of exposure (else end of frame)
  bool error = false;              ///< V4L2_BUF_FLAG_ERROR: content unusable
  const std::uint8_t* data = nullptr;
  std::uint32_t bytes_used = 0;
};

class V4l2Device {
 public:
  /// Opens a capture node. Errors: no such node, no permission, busy, not a
  /// V4L2 device, not a single-planar streaming capture device.
  static Result<std::unique_ptr<V4l2Device>> open(const std::string& path);
  ~V4l2Device();
  V4l2Device(const V4l2Device&) = delete;
  V4l2Device& operator=(const V4l2Device&) = delete;

  const std::string& path() const { return path_; }
  const std::string& driver() const { return driver_; }
  const std::string& card() const { return card_; }
  /// `/dev/video0 ("vivid", driver vivid)` for messages.
  std::string name() const;

  /// Pixel formats the node offers for capture (VIDIOC_ENUM_FMT).
  std::vector<std::uint32_t> pixelFormats() const;
  /// Frame sizes offered for `fourcc`, as text ("320x180", "16x16..1920x1080
  /// step 2x2"), and whether `width`x`height` is one of them.
  std::vector<std::string> frameSizes(std::uint32_t fourcc) const;
  bool offersSize(std::uint32_t fourcc, int width, int height) const;
  /// Frame rates offered at a size (frames/s); empty if the driver does not say.
  std::vector<double> frameRates(std::uint32_t fourcc, int width, int height) const;

  /// VIDIOC_S_FMT; returns what the driver chose (it may adjust the size).
  Result<V4l2Format> setFormat(std::uint32_t fourcc, int width, int height);
  /// VIDIOC_S_PARM; returns the frame rate the driver chose.
  Result<double> setFrameRate(double fps);

  std::vector<V4l2Control> controls() const;
  std::optional<V4l2Control> control(std::uint32_t id) const;
  std::optional<V4l2Control> control(const std::string& key) const;
  Status setControl(const V4l2Control& c, std::int64_t value);
  Result<std::int64_t> getControl(const V4l2Control& c) const;

  /// Allocates and maps `count` buffers (the driver may give more or fewer; at
  /// least 2 are needed) and queues them all.
  Status startStreaming(int count);
  /// STREAMOFF, unmaps and frees the buffers. Safe to call when not streaming.
  Status stopStreaming();
  /// Waits up to `timeout_ms` for a filled buffer, or until `wake_fd` becomes
  /// readable (nullopt in both cases).
  Result<std::optional<V4l2Capture>> dequeue(int timeout_ms, int wake_fd);
  Status queue(int index);
  int buffers() const { return static_cast<int>(maps_.size()); }
  /// What happened if a call found the device gone (ENODEV, ENXIO: unplugged
  /// or its driver unbound; EIO: the driver failed the stream for good), so
  /// nothing more can be asked of it until the node is opened again; none
  /// otherwise. Any thread.
  std::optional<std::string> gone() const;

 private:
  V4l2Device() = default;
  Error errnoError(const std::string& what, int err) const;

  int fd_ = -1;
  std::string path_, driver_, card_;
  struct Map {
    void* addr = nullptr;
    std::size_t length = 0;
  };
  std::vector<Map> maps_;
  bool streaming_ = false;
  // The first call that found the device gone (errnoError), under gone_mutex_.
  mutable std::mutex gone_mutex_;
  mutable std::optional<std::string> gone_;
};

/// One captured image as a one-channel frame, cropped to `roi` (which must
/// lie inside width x height): GREY and YUYV (its luma) give CV_8UC1, Y12
/// (values 0..4095) and Y16 (little-endian) give CV_16UC1. Errors: another
/// fourcc, or fewer bytes than the format needs.
Result<cv::Mat> v4l2ToMono(std::uint32_t fourcc, const std::uint8_t* data, std::size_t bytes,
                           int width, int height, int bytes_per_line, const cv::Rect& roi);

}  // namespace collide::hw
