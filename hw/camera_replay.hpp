#pragma once
// CameraReplay ("replay"): plays a stored burst back as if it were live. On
// trigger it streams the burst's frames so that the stored frame 0 lands on
// the trigger instant, keeping their original spacing, statuses and gaps
// (realtime = true: at their original pace; false: as fast as it can). The
// burst comes from RigHooks::load_burst when the caller gives one (hw cannot
// read shot files); otherwise `source` must be a folder of images or a video
// file, read with vision's loaders and numbered so that frame trigger_frame
// is frame 0.
//
// [camera] settings: source = "...", realtime (default true), trigger_frame (default 0).
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>

#include "hw/camera.hpp"
#include "hw/settings.hpp"

namespace collide::hw {

class CameraReplay final : public Camera {
 public:
  /// `burst` must hold at least one frame. `source` names it in messages.
  CameraReplay(vision::Burst burst, std::string source, bool realtime);
  ~CameraReplay() override;

  CameraInfo info() const override;

 protected:
  Status onOpen() override;
  /// Refuses settings that differ from the stored burst's (size, format, fps).
  Status onConfigure(const CameraConfig& config) override;
  Status onStart() override;
  Status onStop() override;
  Status onClose() override { return Ok{}; }
  void onArm() override;
  void onTrigger(std::int64_t at_ns) override;

 private:
  void run();
  void stopThread();

  const vision::Burst burst_;
  const std::string source_;
  const bool realtime_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::uint64_t generation_ = 0;  // bumped on every arm and trigger
  std::thread thread_;
};

}  // namespace collide::hw
