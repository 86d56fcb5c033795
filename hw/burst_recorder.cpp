#include "hw/burst_recorder.hpp"

#include <algorithm>
#include <chrono>
#include <vector>

#include "hw/clock.hpp"

namespace collide::hw {

BurstRecorder::BurstRecorder(BurstLayout layout)
    : layout_(layout),
      armed_ns_(monotonicNowNs()),
      ring_(static_cast<std::size_t>(std::max(0, layout.pre_trigger_frames) +
                                     std::max(1, layout.post_trigger_frames))) {
  layout_.pre_trigger_frames = std::max(0, layout_.pre_trigger_frames);
  layout_.post_trigger_frames = std::max(1, layout_.post_trigger_frames);
  layout_.frame_period_ns = std::max<std::int64_t>(1, layout_.frame_period_ns);
}

bool BurstRecorder::wants(std::int64_t exposure_start_ns) const {
  std::lock_guard lock(mutex_);
  if (complete_ || ended_) return false;
  if (!trigger_ns_) return true;
  // Two periods of slack: a frame a little older than the window may still be
  // needed if a later one gets lost.
  return exposure_start_ns >=
         *trigger_ns_ - (layout_.pre_trigger_frames + 2) * layout_.frame_period_ns;
}

void BurstRecorder::resolveFrameZero(std::uint64_t sequence, std::int64_t ts,
                                     const Entry* previous) {
  if (previous && previous->sequence + 1 == sequence) {
    frame_zero_ = sequence;  // the frame just before it was exposed before the trigger
    return;
  }
  // Frames between the last one seen before the trigger and this one were
  // lost: count whole periods back from this frame to the trigger.
  const std::int64_t periods_after = (ts - *trigger_ns_) / layout_.frame_period_ns;
  std::uint64_t zero =
      sequence - static_cast<std::uint64_t>(std::min<std::int64_t>(periods_after, sequence));
  if (previous && zero <= previous->sequence) zero = previous->sequence + 1;
  frame_zero_ = zero;
}

void BurstRecorder::updateComplete() {
  if (!frame_zero_ || ring_.empty()) return;
  if (idOf(ring_.newest().sequence) >= layout_.post_trigger_frames - 1) {
    complete_ = true;
    changed_.notify_all();
  }
}

bool BurstRecorder::push(std::uint64_t sequence, vision::Frame frame) {
  std::lock_guard lock(mutex_);
  if (complete_ || ended_) return false;
  if (!ring_.empty() && sequence <= ring_.newest().sequence) return true;
  ++arrivals_;
  if (!first_sequence_) first_sequence_ = sequence;
  if (trigger_ns_ && !frame_zero_ && frame.timestamp_ns >= *trigger_ns_)
    resolveFrameZero(sequence, frame.timestamp_ns, ring_.empty() ? nullptr : &ring_.newest());
  if (frame_zero_ && idOf(sequence) >= layout_.post_trigger_frames) {
    // Frame post-1 was lost, but the burst's span is over.
    complete_ = true;
    changed_.notify_all();
    return false;
  }
  ring_.push(Entry{sequence, std::move(frame)});
  updateComplete();
  return !complete_;
}

void BurstRecorder::endOfStream(std::string why) {
  std::lock_guard lock(mutex_);
  if (complete_ || ended_) return;
  ended_ = true;
  end_reason_ = std::move(why);
  changed_.notify_all();
}

void BurstRecorder::trigger(std::int64_t at_ns) {
  std::lock_guard lock(mutex_);
  if (trigger_ns_) return;
  trigger_ns_ = at_ns;
  // A trigger in the past: frames already exposed after it are in the ring.
  for (std::size_t i = 0; i < ring_.size(); ++i) {
    if (ring_[i].frame.timestamp_ns >= at_ns) {
      resolveFrameZero(ring_[i].sequence, ring_[i].frame.timestamp_ns,
                       i > 0 ? &ring_[i - 1] : nullptr);
      break;
    }
  }
  updateComplete();
}

bool BurstRecorder::triggered() const {
  std::lock_guard lock(mutex_);
  return trigger_ns_.has_value();
}

std::optional<std::int64_t> BurstRecorder::triggerNs() const {
  std::lock_guard lock(mutex_);
  return trigger_ns_;
}

bool BurstRecorder::waitUntil(std::int64_t deadline_ns) {
  std::unique_lock lock(mutex_);
  // steady_clock is CLOCK_MONOTONIC on Linux (libstdc++), the clock of deadline_ns.
  const auto deadline =
      std::chrono::steady_clock::time_point(std::chrono::nanoseconds(deadline_ns));
  return changed_.wait_until(lock, deadline, [&] { return complete_ || ended_; });
}

bool BurstRecorder::complete() const {
  std::lock_guard lock(mutex_);
  return complete_;
}

std::uint64_t BurstRecorder::arrivals() const {
  std::lock_guard lock(mutex_);
  const auto window =
      static_cast<std::uint64_t>(layout_.pre_trigger_frames + layout_.post_trigger_frames);
  return std::min(arrivals_, window);
}

vision::Burst BurstRecorder::take() {
  std::lock_guard lock(mutex_);
  vision::Burst burst;
  const int pre = layout_.pre_trigger_frames;
  const int post = layout_.post_trigger_frames;
  std::vector<Entry> entries = ring_.drain();

  if (!trigger_ns_) {
    burst.complete = false;
    burst.note = "the camera was never triggered";
  } else {
    if (!frame_zero_ && !entries.empty()) {
      // No frame exposed after the trigger arrived: number the ones before it.
      const Entry& last = entries.back();
      const std::int64_t gap = *trigger_ns_ - last.frame.timestamp_ns;
      const std::int64_t periods = (gap + layout_.frame_period_ns - 1) / layout_.frame_period_ns;
      frame_zero_ = last.sequence + static_cast<std::uint64_t>(std::max<std::int64_t>(1, periods));
    }
    std::vector<std::int64_t> present;
    for (Entry& e : entries) {
      const std::int64_t id = idOf(e.sequence);
      if (id < -pre || id >= post) continue;
      e.frame.id = id;
      present.push_back(id);
      if (e.frame.good())
        ++burst.stats.completed;
      else
        ++burst.stats.failed;
      burst.frames.push_back(std::move(e.frame));
    }
    // Ids missing after the first frame pushed and up to the last one
    // expected (or received, if the stream stopped early) were lost in transport.
    const std::int64_t first_expected =
        first_sequence_ ? std::max<std::int64_t>(-pre, idOf(*first_sequence_)) : 0;
    if (!present.empty()) {
      const std::int64_t last_expected = complete_ ? post - 1 : present.back();
      std::size_t k = 0;
      for (std::int64_t id = first_expected; id <= last_expected; ++id) {
        if (k < present.size() && present[k] == id)
          ++k;
        else
          burst.stats.missing_ids.push_back(id);
      }
    }
    burst.stats.dropped = burst.stats.missing_ids.size();
    burst.complete = complete_;

    const auto received_post =
        std::count_if(present.begin(), present.end(), [](std::int64_t id) { return id >= 0; });
    if (!complete_) {
      burst.note = (ended_ ? "the camera stopped early (" + end_reason_ + ")"
                           : std::string("the burst timed out")) +
                   ": " + std::to_string(received_post) + " of " + std::to_string(post) +
                   " post-trigger frames arrived";
    }
    if (pre > 0 && first_expected > -pre) {
      if (!burst.note.empty()) burst.note += "; ";
      burst.note += "only " + std::to_string(std::max<std::int64_t>(0, -first_expected)) + " of " +
                    std::to_string(pre) +
                    " pre-trigger frames (the camera started too close to the trigger)";
    }
  }
  trigger_ns_.reset();
  frame_zero_.reset();
  first_sequence_.reset();
  complete_ = false;
  ended_ = false;
  end_reason_.clear();
  return burst;
}

}  // namespace collide::hw
