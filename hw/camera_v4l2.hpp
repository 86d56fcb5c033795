#pragma once
// CameraV4l2 ("v4l2"): a Video4Linux2 capture device (USB/UVC cameras,
// frame grabbers, vivid in the VM tests) on V4l2Device. It streams with
// memory-mapped buffers (REQBUFS, QBUF, DQBUF, STREAMON) on its own
// acquisition thread into the same pre-trigger ring as every camera.
//
// Frames: the driver's pixel format GREY or YUYV (luma kept) becomes Mono8,
// Y12 Mono12, Y16 Mono16; the capture size is frame_px and camera.roi is cut
// out of it in software. Timestamps are the driver's (CLOCK_MONOTONIC);
// drivers that stamp the end of the frame get the exposure time subtracted,
// so a frame's timestamp is always (about) its start of exposure. Lost frames
// show up as gaps in the driver's buffer sequence numbers and are counted by
// the burst. A buffer the driver flags V4L2_BUF_FLAG_ERROR becomes a Failed
// frame.
//
// [camera] settings (v4l2 backend); role keys as for every camera:
//   device = "/dev/video0"
//   pixel_format = "GREY"     "GREY" | "YUYV" (both Mono8) | "Y12" | "Y16";
//                             default: the first of those the device offers for camera.format
//   frame_px = [640, 480]     capture size; default: roi's x + width, y + height
//   buffers = 8               memory-mapped buffers (at least 2)
//   exposure_control = true   set exposure_time_absolute (100 us steps, manual
//                             mode) from camera.exposure_us; false: leave it to the device
//   gain_raw_per_db = 1.0     V4L2 gain has driver units: raw = gain_db x this;
//                             0: leave gain to the device (camera.gain_db must be 0)
//   [camera.controls]         any other control, by its v4l2-ctl name = integer
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "hw/camera.hpp"
#include "hw/settings.hpp"
#include "hw/v4l2_device.hpp"

namespace collide::hw {

struct CameraV4l2Settings {
  std::string path = "/dev/video0";
  std::uint32_t pixel_format = 0;  ///< 0: choose from camera.format
  int frame_width = 0;             ///< capture size; 0: from the ROI
  int frame_height = 0;
  int buffers = 8;
  bool exposure_control = true;
  double gain_raw_per_db = 1.0;
  std::vector<std::pair<std::string, std::int64_t>> controls;  ///< v4l2-ctl name, value

  /// From the [camera] table; `role` gives the ROI for the default frame size.
  static Result<CameraV4l2Settings> read(SettingsReader& r, const CameraConfig& role);
};

class CameraV4l2 final : public Camera {
 public:
  explicit CameraV4l2(CameraV4l2Settings settings);
  ~CameraV4l2() override;

  CameraInfo info() const override;
  /// The device (null unless open), e.g. to read controls. Control thread.
  V4l2Device* device() const { return device_.get(); }
  /// The pixel format chosen by configure() (0 before).
  std::uint32_t pixelFormat() const { return format_.fourcc; }
  /// Frames the driver's sequence numbers say were lost since start(). Any thread.
  std::uint64_t droppedSinceStart() const { return dropped_.load(); }
  /// Frames dequeued since start(). Any thread.
  std::uint64_t capturedSinceStart() const { return captured_.load(); }

 protected:
  Status onOpen() override;
  Status onConfigure(const CameraConfig& config) override;
  Status onStart() override;
  Status onStop() override;
  Status onClose() override;

 private:
  void run();
  void stopThread();
  // `s`, or when the device is gone (V4l2Device::gone()) the camera marked
  // lost and lostMessage(). Any thread.
  Status lostIfGone(Status s);
  Status configureDevice(const CameraConfig& config);
  Status applyControls(const CameraConfig& config);

  CameraV4l2Settings settings_;
  std::unique_ptr<V4l2Device> device_;
  CameraInfo info_;
  CameraConfig config_;
  V4l2Format format_;
  int wake_fd_ = -1;  // eventfd: tells the acquisition thread to stop
  std::thread thread_;
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint64_t> captured_{0};
};

}  // namespace collide::hw
