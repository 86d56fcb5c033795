#include "hw/sim_silence.hpp"

#include <map>
#include <mutex>

namespace collide::hw {

namespace {

std::mutex& registryMutex() {
  static std::mutex m;
  return m;
}

std::map<std::string, std::shared_ptr<SimSilence>>& registry() {
  static std::map<std::string, std::shared_ptr<SimSilence>> r;
  return r;
}

}  // namespace

std::shared_ptr<SimSilence> SimSilence::forDevice(const std::string& device, std::int64_t answers) {
  std::lock_guard lock(registryMutex());
  std::shared_ptr<SimSilence>& s = registry()[device];
  if (!s) s = std::make_shared<SimSilence>(answers);
  return s;
}

std::shared_ptr<SimSilence> SimSilence::find(const std::string& device) {
  std::lock_guard lock(registryMutex());
  const auto it = registry().find(device);
  return it == registry().end() ? nullptr : it->second;
}

bool SimSilence::answer(bool budgeted) {
  std::lock_guard lock(mutex_);
  if (budgeted && answers_left_ == 0) silent_ = true;
  if (silent_) {
    unanswered_.fetch_add(1);
    return false;
  }
  if (budgeted && answers_left_ > 0) --answers_left_;
  return true;
}

void SimSilence::goSilent() {
  std::lock_guard lock(mutex_);
  silent_ = true;
}

void SimSilence::answerAgain() {
  std::lock_guard lock(mutex_);
  silent_ = false;
  answers_left_ = -1;
}

}  // namespace collide::hw
