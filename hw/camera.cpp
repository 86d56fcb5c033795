#include "hw/camera.hpp"

#include <algorithm>
#include <cmath>

#include "hw/format.hpp"

namespace collide::hw {

Status Camera::open() {
  return lifecycle_.open([&] { return prefixed(label(), onOpen()); });
}

Status Camera::configure(const CameraConfig& c) {
  return lifecycle_.configure([&]() -> Status {
    const CameraInfo i = info();
    const std::string me = label() + ": ";
    if (c.width <= 0 || c.height <= 0 || c.roi_x < 0 || c.roi_y < 0 ||
        c.roi_x + c.width > i.sensor_width || c.roi_y + c.height > i.sensor_height)
      return fail(me + "region of interest " + std::to_string(c.width) + "x" +
                  std::to_string(c.height) + " at (" + std::to_string(c.roi_x) + ", " +
                  std::to_string(c.roi_y) + ") does not fit the " + std::to_string(i.sensor_width) +
                  "x" + std::to_string(i.sensor_height) + " sensor: check camera.roi");
    if (std::find(i.formats.begin(), i.formats.end(), c.format) == i.formats.end())
      return fail(me + "cannot deliver " + vision::toString(c.format) + ": check camera.format");
    if (!(c.fps > 0.0) || c.fps > i.max_fps)
      return fail(me + num(c.fps) + " frames/s is outside 0.." + num(i.max_fps) +
                  ": check camera.fps");
    if (!(c.exposure_us > 0.0) || c.exposure_us > 1e6 / c.fps)
      return fail(me + "exposure " + num(c.exposure_us) +
                  " us must be > 0 and at most one frame (" + num(1e6 / c.fps) + " us at " +
                  num(c.fps) + " frames/s): check camera.exposure_us");
    if (!(c.gain_db >= 0.0) || c.gain_db > i.max_gain_db)
      return fail(me + "gain " + num(c.gain_db) + " dB is outside 0.." + num(i.max_gain_db) +
                  ": check camera.gain_db");
    if (Status s = prefixed(label(), onConfigure(c)); !s) return s;
    config_ = c;
    return Ok{};
  });
}

Status Camera::start() {
  return lifecycle_.start([&] { return prefixed(label(), onStart()); });
}

Status Camera::stop() {
  return lifecycle_.stop([&]() -> Status {
    Status s = prefixed(label(), onStop());
    if (auto r = recorder()) r->endOfStream("acquisition stopped");
    return s;
  });
}

Status Camera::close() {
  return lifecycle_.close(
      [&]() -> Status {
        Status s = prefixed(label(), onStop());
        if (auto r = recorder()) r->endOfStream("camera closed");
        return s;
      },
      [&]() -> Status {
        std::lock_guard lock(recorder_mutex_);
        recorder_.reset();
        return prefixed(label(), onClose());
      });
}

std::uint64_t Camera::burstArrivals() const {
  const std::shared_ptr<BurstRecorder> r = recorder();
  return r ? r->arrivals() : 0;
}

std::shared_ptr<BurstRecorder> Camera::recorder() const {
  std::lock_guard lock(recorder_mutex_);
  return recorder_;
}

void Camera::publishFrame(const vision::Frame& frame) {
  if (!live_view_.load()) return;
  auto shared = std::make_shared<const vision::Frame>(frame);
  {
    std::lock_guard lock(latest_mutex_);
    latest_.swap(shared);
  }
  published_.fetch_add(1);
  // `shared` (the previous frame) is released here, outside the lock.
}

std::shared_ptr<const vision::Frame> Camera::latestFrame() const {
  std::lock_guard lock(latest_mutex_);
  return latest_;
}

Status Camera::arm(int pre_trigger_frames, int post_trigger_frames) {
  if (Status s = lifecycle_.require("arm()", {DeviceState::Running}); !s) return s;
  if (pre_trigger_frames < 0 || post_trigger_frames < 1)
    return fail(label() + ": arm(): " + std::to_string(pre_trigger_frames) + " pre- and " +
                std::to_string(post_trigger_frames) +
                " post-trigger frames: need >= 0 and >= 1 (burst.pre_trigger_frames, "
                "burst.post_trigger_frames)");
  {
    std::lock_guard lock(recorder_mutex_);
    recorder_ = std::make_shared<BurstRecorder>(
        BurstLayout{pre_trigger_frames, post_trigger_frames, config_.framePeriodNs()});
  }
  onArm();
  return Ok{};
}

Result<std::shared_ptr<BurstRecorder>> Camera::armed(const char* call) const {
  auto r = recorder();
  if (!r) return fail(label() + ": " + call + " refused: no burst is armed; call arm() first");
  return r;
}

Status Camera::trigger(std::int64_t at_ns) {
  if (Status s = lifecycle_.require("trigger()", {DeviceState::Running}); !s) return s;
  auto r = armed("trigger()");
  if (!r) return r.error();
  (*r)->trigger(at_ns);
  onTrigger(at_ns);
  return Ok{};
}

Result<bool> Camera::waitBurst(std::int64_t deadline_ns) {
  // Asks the device nothing: a lost camera still hands back what arrived.
  if (Status s =
          lifecycle_.requireState("waitBurst()", {DeviceState::Configured, DeviceState::Running});
      !s)
    return s.error();
  auto r = armed("waitBurst()");
  if (!r) return r.error();
  return (*r)->waitUntil(deadline_ns);
}

Result<vision::Burst> Camera::takeBurst() {
  // Asks the device nothing: a lost camera still hands back what arrived.
  if (Status s =
          lifecycle_.requireState("takeBurst()", {DeviceState::Configured, DeviceState::Running});
      !s)
    return s.error();
  auto r = armed("takeBurst()");
  if (!r) return r.error();
  {
    std::lock_guard lock(recorder_mutex_);
    recorder_.reset();
  }
  vision::Burst burst = (*r)->take();
  burst.format = config_.format;
  burst.fps = config_.fps;
  burst.exposure_us = config_.exposure_us;
  onTakeBurst(burst);
  return burst;
}

}  // namespace collide::hw
