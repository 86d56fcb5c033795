#include "hw/device_health.hpp"

#include <algorithm>

namespace collide::hw {

std::string lostMessage(const DeviceLoss& loss) {
  return loss.device + " is lost (" + loss.what_happened +
         "): no shot is fired until it answers again, and retrying will not help before then: "
         "check " +
         loss.what_to_check +
         ", then reconnect (run the command again, or press Reconnect in the GUI's rig panel)";
}

void DeviceHealth::markLost(DeviceLoss loss) {
  std::lock_guard lock(mutex_);
  const auto same = [&](const DeviceLoss& l) { return l.device == loss.device; };
  if (std::none_of(lost_.begin(), lost_.end(), same)) lost_.push_back(std::move(loss));
}

void DeviceHealth::clear(const std::string& device) {
  std::lock_guard lock(mutex_);
  std::erase_if(lost_, [&](const DeviceLoss& l) { return l.device == device; });
}

std::optional<DeviceLoss> DeviceHealth::loss(const std::string& device) const {
  std::lock_guard lock(mutex_);
  for (const DeviceLoss& l : lost_)
    if (l.device == device) return l;
  return std::nullopt;
}

std::vector<DeviceLoss> DeviceHealth::lost() const {
  std::lock_guard lock(mutex_);
  return lost_;
}

Status DeviceHealth::ready() const {
  std::lock_guard lock(mutex_);
  if (lost_.empty()) return Ok{};
  std::string message = lostMessage(lost_.front());
  if (lost_.size() > 1)
    message += " (" + std::to_string(lost_.size() - 1) + " other device" +
               (lost_.size() > 2 ? "s are" : " is") + " lost too)";
  return fail(message);
}

}  // namespace collide::hw
