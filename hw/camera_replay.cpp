#include "hw/camera_replay.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "hw/backend_registry.hpp"
#include "hw/clock.hpp"
#include "hw/format.hpp"
#include "hw/rig.hpp"
#include "hw/try.hpp"
#include "vision/frame_io.hpp"

namespace collide::hw {

namespace {

// Stored ids can be negative; the stream's sequence numbers must not be.
constexpr std::int64_t kSequenceBase = 1'000'000'000;

}  // namespace

CameraReplay::CameraReplay(vision::Burst burst, std::string source, bool realtime)
    : Camera("camera \"replay " + source + "\""),
      burst_(std::move(burst)),
      source_(std::move(source)),
      realtime_(realtime) {}

CameraReplay::~CameraReplay() {
  stopThread();
}

CameraInfo CameraReplay::info() const {
  return {"replay", source_, burst_.width(), burst_.height(), {burst_.format}, burst_.fps, 0.0};
}

Status CameraReplay::onOpen() {
  if (burst_.frames.empty() || burst_.width() <= 0)
    return fail("the burst in " + source_ + " holds no frames: nothing to replay");
  return Ok{};
}

Status CameraReplay::onConfigure(const CameraConfig& c) {
  const std::string want = std::to_string(burst_.width()) + "x" + std::to_string(burst_.height());
  if (c.roi_x != 0 || c.roi_y != 0 || c.width != burst_.width() || c.height != burst_.height())
    return fail("the replayed burst is " + want + ": set camera.roi = [0, 0, " +
                std::to_string(burst_.width()) + ", " + std::to_string(burst_.height()) + "]");
  if (std::abs(c.fps - burst_.fps) > 1e-6 * burst_.fps)
    return fail("the replayed burst was taken at " + num(burst_.fps) +
                " frames/s: set camera.fps = " + num(burst_.fps));
  return Ok{};
}

Status CameraReplay::onStart() {
  {
    std::lock_guard lock(mutex_);
    stop_ = false;
  }
  thread_ = std::thread(&CameraReplay::run, this);
  return Ok{};
}

void CameraReplay::stopThread() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    cv_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
}

Status CameraReplay::onStop() {
  stopThread();
  return Ok{};
}

void CameraReplay::onArm() {
  std::lock_guard lock(mutex_);
  ++generation_;
  cv_.notify_all();
}

void CameraReplay::onTrigger(std::int64_t) {
  std::lock_guard lock(mutex_);
  ++generation_;
  cv_.notify_all();
}

void CameraReplay::run() {
  const double period_ns = 1e9 / burst_.fps;
  // Where the stored frame 0 started exposing, from any stored frame.
  const vision::Frame& any = burst_.frames.front();
  const double stored_zero_ns = static_cast<double>(any.timestamp_ns) - any.id * period_ns;

  std::shared_ptr<BurstRecorder> played;  // the last burst already played into
  std::unique_lock lock(mutex_);
  for (;;) {
    const std::uint64_t generation = generation_;
    lock.unlock();
    std::shared_ptr<BurstRecorder> rec = recorder();
    const std::optional<std::int64_t> trigger = rec ? rec->triggerNs() : std::nullopt;
    if (rec && rec != played && trigger) {
      played = rec;
      for (const vision::Frame& stored : burst_.frames) {
        vision::Frame f = stored;
        f.timestamp_ns =
            *trigger + std::llround(static_cast<double>(stored.timestamp_ns) - stored_zero_ns);
        if (realtime_) {
          // Deliver a frame once it would have been exposed.
          const std::int64_t ready = f.timestamp_ns + std::llround(burst_.exposure_us * 1000.0);
          std::unique_lock wait(mutex_);
          if (cv_.wait_until(wait,
                             std::chrono::steady_clock::time_point(std::chrono::nanoseconds(ready)),
                             [&] { return stop_; }))
            return;
        } else {
          std::lock_guard check(mutex_);
          if (stop_) return;
        }
        const std::uint64_t sequence = static_cast<std::uint64_t>(kSequenceBase + stored.id);
        publishFrame(f);
        if (!rec->push(sequence, std::move(f))) break;
      }
      rec->endOfStream("the replayed burst " + source_ + " ends at frame " +
                       std::to_string(burst_.frames.back().id));
    }
    lock.lock();
    cv_.wait(lock, [&] { return stop_ || generation_ != generation; });
    if (stop_) return;
  }
}

namespace {

// Without a loader from the caller, footage hw can read itself: a folder of
// images or a video file (vision/frame_io.hpp), numbered from trigger_frame.
Result<vision::Burst> loadFootage(const std::string& source, double fps,
                                  std::int64_t trigger_frame) {
  std::error_code ec;
  Result<vision::Burst> burst = std::filesystem::is_directory(source, ec)
                                    ? vision::loadFrameFolder(source, fps)
                                    : vision::loadVideo(source, fps);
  if (!burst) return burst;
  const std::int64_t shift = trigger_frame * std::llround(1e9 / fps);
  for (vision::Frame& f : burst->frames) {
    f.id -= trigger_frame;
    f.timestamp_ns -= shift;
  }
  return burst;
}

Result<std::unique_ptr<Camera>> makeReplay(BackendContext& ctx) {
  SettingsReader r = ctx.device.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(const std::string source, r.text("source"));
  COLLIDE_ASSIGN_OR_RETURN(const bool realtime, r.boolean("realtime", true));
  COLLIDE_ASSIGN_OR_RETURN(const std::int64_t trigger_frame,
                           r.integer("trigger_frame", 0, {.ge = 0}));
  COLLIDE_RETURN_IF_ERROR(r.finish("the replay camera backend"));
  Result<vision::Burst> burst =
      ctx.hooks.load_burst ? ctx.hooks.load_burst(source)
                           : loadFootage(source, ctx.profile.camera_config.fps, trigger_frame);
  if (!burst) return r.invalid("source", burst.error().message);
  if (burst->frames.empty()) return r.invalid("source", "the burst holds no frames");
  return std::unique_ptr<Camera>(
      std::make_unique<CameraReplay>(std::move(burst).value(), source, realtime));
}

const bool registered = BackendRegistry<Camera>::instance().add("replay", &makeReplay);

}  // namespace

}  // namespace collide::hw
