#include "hw/pressure_line.hpp"

#include <algorithm>
#include <cmath>

namespace collide::hw {

double PressureLine::pressureKPa(std::int64_t t_ns) const {
  const double dt = std::max<std::int64_t>(0, t_ns - since_ns_) * 1e-9;
  // A leaking line reaches only part of a rise; falls (venting) always complete.
  const double rise = target_kPa_ - start_kPa_;
  const double goal = rise > 0 ? start_kPa_ + model_.reach * rise : target_kPa_;
  const double gap = (start_kPa_ - goal) * std::exp(-dt / model_.time_constant_s);
  return std::abs(gap) <= model_.hold_band_kPa ? goal : goal + gap;
}

void PressureLine::command(double kPa, std::int64_t now_ns) {
  start_kPa_ = pressureKPa(now_ns);  // the line carries on from where it is
  since_ns_ = now_ns;
  target_kPa_ = kPa;
}

void PressureLine::setModel(const LineModel& model, std::int64_t now_ns) {
  start_kPa_ = pressureKPa(now_ns);
  since_ns_ = now_ns;
  model_ = model;
}

}  // namespace collide::hw
