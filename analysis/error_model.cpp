#include "analysis/error_model.hpp"

#include <cmath>
#include <limits>

namespace collide {

double velocitySigma_m_s(const ImagingGeometry& g) {
  if (g.pixels_per_diameter <= 0 || g.frame_interval_s <= 0 || g.frames_per_side <= 0)
    return std::numeric_limits<double>::infinity();
  return g.position_sigma_px * g.diameter_m /
         (g.pixels_per_diameter * g.frame_interval_s * std::sqrt(double(g.frames_per_side)));
}

double relativeVelocityError(const ImagingGeometry& g, double v_m_s) {
  const double v = std::abs(v_m_s);
  if (v == 0) return std::numeric_limits<double>::infinity();
  return velocitySigma_m_s(g) / v;
}

}  // namespace collide
