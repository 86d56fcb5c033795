#include "analysis/contact.hpp"

#include <algorithm>
#include <cmath>

namespace collide {

double contactTime(const PlaneTrack& a, const PlaneTrack& b, double dist_m, double t0_s) {
  double t = t0_s;
  for (int it = 0; it < 6; ++it) {
    const Eigen::Vector2d dr = a.pos(t) - b.pos(t), dv = a.vel(t) - b.vel(t);
    const double f = dr.squaredNorm() - dist_m * dist_m, df = 2 * dr.dot(dv);
    if (df == 0) break;
    t -= f / df;
  }
  return t;
}

double beforeInstantWeight(double sigma_before_s, double sigma_after_s) {
  const double vb = sigma_before_s * sigma_before_s, va = sigma_after_s * sigma_after_s;
  return (std::isfinite(vb) && std::isfinite(va) && vb + va > 0) ? va / (va + vb) : 0.5;
}

}  // namespace collide
