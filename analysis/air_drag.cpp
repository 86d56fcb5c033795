#include "analysis/air_drag.hpp"

#include <cmath>
#include <limits>
#include <numbers>

namespace collide {

double sphereDragCoefficient(double re) {
  if (!(re > 0) || !std::isfinite(re)) return std::numeric_limits<double>::quiet_NaN();
  const double a = re / 5.0, b = re / 2.63e5, c = re / 1e6;
  // 0.411 b^-7.94 / (1 + b^-8) written as b^0.06 / (b^8 + 1): no overflow at small Re.
  return 24.0 / re + 2.6 * a / (1.0 + std::pow(a, 1.52)) +
         0.411 * std::pow(b, 0.06) / (std::pow(b, 8.0) + 1.0) + 0.25 * c / (1.0 + c);
}

Vec3 AirDrag::acceleration(const Vec3& v_m_s) const {
  const double speed = v_m_s.norm();
  if (!acts() || !(speed > 0)) return Vec3::Zero();
  const double re = air_density_kg_m3 * speed * diameter_m / air_viscosity_Pa_s;
  const double area = std::numbers::pi * diameter_m * diameter_m / 4.0;
  const double cd = drag_coefficient > 0 ? drag_coefficient : sphereDragCoefficient(re);
  const double k = 0.5 * air_density_kg_m3 * cd * area / mass_kg;
  return -k * speed * v_m_s;
}

double AirDrag::travelTime_s(double distance_m, double speed_m_s) const {
  if (!acts() || !(speed_m_s > 0)) return distance_m / speed_m_s;
  // dv/dx = -k v with k = |a| / v^2.
  const double k = acceleration(Vec3(speed_m_s, 0, 0)).norm() / (speed_m_s * speed_m_s);
  return std::expm1(k * distance_m) / (k * speed_m_s);
}

}  // namespace collide
