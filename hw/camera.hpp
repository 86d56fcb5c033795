#pragma once
// Role: the high-speed camera (libcamera's Camera: one class plays the role,
// backends plug in underneath). While running it streams frames into a
// pre-trigger ring (BurstRecorder); a shot arms the ring, triggers it, and
// takes the burst of pre- and post-trigger frames with its stream statistics.
// Backends: CameraSim ("sim"), CameraReplay ("replay"), CameraV4l2 ("v4l2")
// and CameraAravis ("aravis": GigE Vision / USB3 Vision through Aravis).
//
// Threads: lifecycle calls, arm/trigger/waitBurst/takeBurst from the rig's
// control thread, one at a time; state() from any thread. Each backend owns
// its acquisition thread, which only pushes frames into the armed recorder
// (recorder()); it never calls back into the control side.
// Errors: wrong lifecycle state, settings the device cannot do, and device
// failures come back as Error values naming the device and what to do.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "hw/burst_recorder.hpp"
#include "hw/lifecycle.hpp"
#include "hw/truth_source.hpp"
#include "vision/frame.hpp"

namespace collide::hw {

struct CameraInfo {
  std::string backend;   ///< "sim", "replay", "aravis", "v4l2"
  std::string device;    ///< device id / path / address, as in the profile
  int sensor_width = 0;  ///< full sensor, pixels
  int sensor_height = 0;
  std::vector<vision::PixelFormat> formats;  ///< pixel formats it can deliver
  double max_fps = 0.0;                      ///< frames per second at full sensor
  double max_gain_db = 0.0;
};

struct CameraConfig {
  int roi_x = 0;  ///< region of interest, sensor pixels from the top-left corner
  int roi_y = 0;
  int width = 0;  ///< region of interest size, pixels
  int height = 0;
  vision::PixelFormat format = vision::PixelFormat::Mono8;
  double fps = 0.0;          ///< frames per second
  double exposure_us = 0.0;  ///< exposure time, microseconds, at most one frame period
  double gain_db = 0.0;      ///< analogue gain, dB

  std::int64_t framePeriodNs() const { return static_cast<std::int64_t>(1e9 / fps + 0.5); }
};

class Camera {
 public:
  virtual ~Camera() = default;
  Camera(const Camera&) = delete;
  Camera& operator=(const Camera&) = delete;

  /// Identity and capabilities; backend/device always, the rest once open.
  virtual CameraInfo info() const = 0;
  const std::string& label() const { return lifecycle_.device(); }
  DeviceState state() const { return lifecycle_.state(); }
  /// Where this device's health is kept (device_health.hpp): makeRig gives
  /// every device of a rig the rig's. Control thread, before use.
  void setHealth(std::shared_ptr<DeviceHealth> health) { lifecycle_.setHealth(std::move(health)); }
  /// Why the device is lost (it stopped answering), or none. Any thread.
  std::optional<DeviceLoss> loss() const { return lifecycle_.loss(); }
  /// Marks the device lost: every later call (configure, start, arm,
  /// trigger) is refused at once until a re-check (recheck() in rig.hpp)
  /// clears it; waitBurst() and takeBurst() still hand back the frames that
  /// arrived before. Called by a backend whose device went away, timed out or
  /// whose connection failed (from any thread, its acquisition thread
  /// included), or by the sequencer when a wait on the device ran out.
  /// Returns the Error those calls get (lostMessage()).
  Error markLost(std::string what_happened, std::string what_to_check) {
    return lifecycle_.markLost(std::move(what_happened), std::move(what_to_check));
  }
  /// What the camera was shown, if it knows (a simulated camera); null for a
  /// real camera. Any thread.
  virtual std::shared_ptr<const TruthSource> groundTruth() const { return nullptr; }

  // Lifecycle (see lifecycle.hpp). configure() refuses a region outside the
  // sensor, a format the camera cannot deliver, fps <= 0 or above max_fps,
  // an exposure <= 0 or longer than a frame period, gain outside 0..max.
  // start() starts streaming (frames are discarded until arm()); stop() ends
  // the stream (an armed burst keeps what arrived; takeBurst() still works).
  Status open();
  Status configure(const CameraConfig& config);
  Status start();
  Status stop();
  Status close();
  const CameraConfig& config() const { return config_; }

  /// Starts recording a burst of `pre_trigger_frames` (>= 0) frames before
  /// the trigger and `post_trigger_frames` (>= 1) from it on. Running. Drops
  /// any burst armed before.
  Status arm(int pre_trigger_frames, int post_trigger_frames);
  /// Frame 0 is the first frame whose exposure starts at or after `at_ns`
  /// (CLOCK_MONOTONIC; may be in the future). Running and armed.
  Status trigger(std::int64_t at_ns);
  /// Blocks until the burst is complete or the stream ended (true), or until
  /// `deadline_ns` (CLOCK_MONOTONIC) passes (false). Running or configured,
  /// and armed.
  Result<bool> waitBurst(std::int64_t deadline_ns);
  /// Frames the armed burst has taken in so far (0 when not armed): the
  /// sequencer waits on while this grows. Any thread.
  std::uint64_t burstArrivals() const;
  /// The armed burst as it stands (complete or not; see Burst::complete and
  /// note), with format, fps and exposure filled in; disarms. Running or
  /// configured, and armed.
  Result<vision::Burst> takeBurst();

  // ---- live view ----------------------------------------------------------
  /// Asks the backend to publish frames for a live view (off by default, so a
  /// camera nobody watches does no extra work). While on, every frame the
  /// stream delivers is published, and a backend that only produces frames
  /// when armed (the simulator) also publishes an idle frame about 25 times a
  /// second. Any thread.
  void setLiveView(bool on) {
    live_view_.store(on);
    onLiveView(on);
  }
  bool liveView() const { return live_view_.load(); }
  /// The newest published frame, or null. Any thread. The acquisition thread
  /// only swaps a pointer under a mutex to publish, so a viewer that polls this
  /// at screen rate never stalls acquisition; the frame is shared, read-only.
  std::shared_ptr<const vision::Frame> latestFrame() const;
  /// How many frames have been published (to tell a new one from the last seen).
  std::uint64_t publishedFrames() const { return published_.load(); }

 protected:
  explicit Camera(std::string label) : lifecycle_(std::move(label)) {}

  virtual Status onOpen() = 0;
  virtual Status onConfigure(const CameraConfig& config) = 0;
  /// Start the acquisition thread.
  virtual Status onStart() = 0;
  /// Stop and join the acquisition thread.
  virtual Status onStop() = 0;
  virtual Status onClose() = 0;
  /// A fresh recorder was armed (control thread). Default: nothing.
  virtual void onArm() {}
  /// The trigger instant was set (control thread). Default: nothing.
  virtual void onTrigger(std::int64_t at_ns) {}
  /// Live view switched on or off (any thread). Default: nothing.
  virtual void onLiveView(bool on) {}
  /// The burst was taken (control thread): a backend adds what only it knows,
  /// e.g. its transport's packet counters. Default: nothing.
  virtual void onTakeBurst(vision::Burst& burst) {}

  /// The armed recorder, or null: what the acquisition thread pushes into.
  /// Any thread.
  std::shared_ptr<BurstRecorder> recorder() const;
  /// Acquisition thread: `frame` is the newest one (for the live view). Does
  /// nothing unless liveView() is on. Shares the image, does not copy it: the
  /// frame must not be written to afterwards.
  void publishFrame(const vision::Frame& frame);

 private:
  Result<std::shared_ptr<BurstRecorder>> armed(const char* call) const;

  Lifecycle lifecycle_;
  CameraConfig config_;
  mutable std::mutex recorder_mutex_;
  std::shared_ptr<BurstRecorder> recorder_;
  std::atomic<bool> live_view_{false};
  std::atomic<std::uint64_t> published_{0};
  mutable std::mutex latest_mutex_;
  std::shared_ptr<const vision::Frame> latest_;
};

}  // namespace collide::hw
