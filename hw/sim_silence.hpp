#pragma once
// Fault injection for the simulated backends: a device that stops answering.
//
// A SimSilence stands for the hardware behind one device label (e.g.
// `regulator "sim"`): it answers a budget of requests, then none. It outlives
// the software objects that speak to it, as real hardware outlives a rig
// rebuilt for every shot of a campaign: every simulated device of one label in
// one process shares it, so a regulator set to go silent after 4 setpoints
// goes silent on the third shot of a campaign, not on every shot's fourth.
// It counts the requests that went unanswered, so a test can see that a lost
// device is not asked again.
//
// Threads: any thread.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

namespace collide::hw {

class SimSilence {
 public:
  /// The one for `device`, made on first use answering `answers` more
  /// budgeted requests (answer(true)); later calls get the same one, its
  /// budget as it stands.
  static std::shared_ptr<SimSilence> forDevice(const std::string& device, std::int64_t answers);
  /// The one for `device` if a simulated device made it, else null (tests).
  static std::shared_ptr<SimSilence> find(const std::string& device);

  /// One request: true when answered. A `budgeted` request spends one answer;
  /// one that finds none left makes the device silent. A silent device
  /// answers nothing (false, counted as unanswered).
  bool answer(bool budgeted);
  /// Requests that went unanswered so far.
  std::int64_t unanswered() const { return unanswered_.load(); }
  /// The device answers again from now on (its cable is plugged back in).
  void answerAgain();
  /// The device answers nothing from now on (its cable is pulled now).
  void goSilent();

  explicit SimSilence(std::int64_t answers) : answers_left_(answers) {}

 private:
  std::mutex mutex_;
  std::int64_t answers_left_;  ///< -1: answers forever
  bool silent_ = false;
  std::atomic<std::int64_t> unanswered_{0};
};

}  // namespace collide::hw
