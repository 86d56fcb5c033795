#pragma once
// The pre/post-trigger buffer around a camera trigger (EPICS areaDetector's
// circular buffer plugin): while armed it keeps the newest frames in a ring;
// the first frame whose exposure starts at or after the trigger instant becomes
// frame 0; frames before it are numbered -1, -2, ... and the burst is complete
// once frame post-1 is in. Every camera backend feeds one from its acquisition
// thread (push), and the control thread triggers it and takes the Burst.
//
// Frame numbering comes from the camera's own running frame counter
// ("sequence": GigE Vision block id, V4L2 sequence, the simulator's counter),
// so a frame lost in transport leaves a gap that is reported, not silently
// closed. Timestamps are the start of exposure on CLOCK_MONOTONIC, nanoseconds.
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>

#include "hw/ring_buffer.hpp"
#include "vision/frame.hpp"

namespace collide::hw {

struct BurstLayout {
  int pre_trigger_frames = 0;   ///< frames kept from before the trigger, >= 0
  int post_trigger_frames = 1;  ///< frames 0 .. post-1, >= 1
  /// Nominal frame period, ns (> 0). Used only to number frames when frame 0
  /// itself was lost, and to know how far back a frame can still be wanted.
  std::int64_t frame_period_ns = 1'000'000;
};

class BurstRecorder {
 public:
  explicit BurstRecorder(BurstLayout layout);

  const BurstLayout& layout() const { return layout_; }
  /// When the burst was armed (CLOCK_MONOTONIC ns): the ring takes frames
  /// exposed from then on, however late the acquisition thread notices.
  std::int64_t armedNs() const { return armed_ns_; }

  // ---- acquisition thread -------------------------------------------------
  /// Whether a frame whose exposure starts at `exposure_start_ns` could end up
  /// in the burst. Lets a backend skip work on frames that would be thrown away
  /// (the simulator does not render them). Any thread.
  bool wants(std::int64_t exposure_start_ns) const;
  /// One frame from the camera. `sequence` is the camera's running frame
  /// counter (strictly increasing; a gap means lost frames); the frame's
  /// timestamp_ns is its start of exposure; its id is assigned here. Frames
  /// that arrive out of order are ignored. Returns false once the burst is
  /// complete (later frames are not needed). Any thread.
  bool push(std::uint64_t sequence, vision::Frame frame);
  /// The stream ended early (camera stopped, link lost): `why` goes into the
  /// burst's note. Wakes waitUntil(). Any thread.
  void endOfStream(std::string why);

  // ---- control thread -----------------------------------------------------
  /// Marks the trigger instant (CLOCK_MONOTONIC ns). It may lie in the future
  /// (frame 0 will be the first frame exposed from then on) or in the recent
  /// past (frames still in the ring are renumbered). A second call is ignored.
  void trigger(std::int64_t at_ns);
  bool triggered() const;
  /// The trigger instant, once set. Any thread.
  std::optional<std::int64_t> triggerNs() const;
  /// Blocks until the burst is complete or the stream ended, or until
  /// `deadline_ns` (CLOCK_MONOTONIC) has passed. True if complete or ended.
  bool waitUntil(std::int64_t deadline_ns);
  /// Complete: frame post-1 (or a later one) has arrived.
  bool complete() const;
  /// Frames taken in since arming (out-of-order ones not counted), at most
  /// pre + post: grows while the camera delivers what a burst can hold, and
  /// stops growing after that (a camera whose frames never reach the window,
  /// e.g. with a wrong clock, does not keep it growing). Any thread.
  std::uint64_t arrivals() const;
  /// The burst as it stands: frames with ids in [-pre, post) in id order,
  /// their statistics (completed = good frames, failed = frames the camera
  /// marked failed/incomplete, dropped/missing_ids = ids of the window missing
  /// after the first frame pushed and up to the last one expected, or the
  /// last one received if the stream stopped early), complete, and a note
  /// saying what is missing and why. format/fps/exposure are left for the
  /// camera to fill. Empties the recorder.
  vision::Burst take();

 private:
  struct Entry {
    std::uint64_t sequence = 0;
    vision::Frame frame;
  };
  // Sets frame 0's sequence number from the first frame exposed at or after
  // the trigger (`sequence`, `ts`); `previous` is the newest earlier frame.
  void resolveFrameZero(std::uint64_t sequence, std::int64_t ts, const Entry* previous);
  void updateComplete();
  std::int64_t idOf(std::uint64_t sequence) const {
    return static_cast<std::int64_t>(sequence) - static_cast<std::int64_t>(*frame_zero_);
  }

  BurstLayout layout_;
  std::int64_t armed_ns_ = 0;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  // pre + post slots: after the trigger every frame of the window fits, and
  // before it a late trigger can still find up to `post` frames exposed after it.
  RingBuffer<Entry> ring_;
  std::optional<std::int64_t> trigger_ns_;
  std::optional<std::uint64_t> frame_zero_;  // sequence number of frame 0
  // The first frame pushed since arming: ids after it that never arrived were
  // lost, ids before it were never exposed while armed.
  std::optional<std::uint64_t> first_sequence_;
  bool complete_ = false;
  bool ended_ = false;
  std::uint64_t arrivals_ = 0;
  std::string end_reason_;
};

}  // namespace collide::hw
