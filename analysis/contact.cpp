#include "analysis/contact.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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

double inPlaneContactDistance(double contact_m, double nz_mean, double nz_sigma) {
  const double m = std::isfinite(nz_mean) ? nz_mean : 0.0;
  const double s = std::isfinite(nz_sigma) ? nz_sigma : 0.0;
  return contact_m * std::sqrt(std::max(0.0, 1.0 - m * m - s * s));
}

double beforeInstantWeight(double sigma_before_s, double sigma_after_s) {
  const double vb = sigma_before_s * sigma_before_s, va = sigma_after_s * sigma_after_s;
  return (std::isfinite(vb) && std::isfinite(va) && vb + va > 0) ? va / (va + vb) : 0.5;
}

double beforeInstantWeight(double sigma_before_s, double sigma_after_s, double contact_sigma_m,
                           double vn_before_m_s, double vn_after_m_s) {
  const double vb = sigma_before_s * sigma_before_s, va = sigma_after_s * sigma_after_s;
  if (!(contact_sigma_m > 0) || !(vn_before_m_s > 0) || !(vn_after_m_s > 0) || !std::isfinite(vb) ||
      !std::isfinite(va))
    return beforeInstantWeight(sigma_before_s, sigma_after_s);
  // Covariance of (t_before, t_after): [[vb + a^2, -a b], [-a b, va + b^2]]
  // with a = dd / |v_n|, b = dd / |v_n'|; w = (C^-1 1)_0 / (1' C^-1 1).
  const double a = contact_sigma_m / vn_before_m_s, b = contact_sigma_m / vn_after_m_s;
  const double r0 = va + b * b + a * b, r1 = vb + a * a + a * b;
  return r0 + r1 > 0 ? r0 / (r0 + r1) : 0.5;
}

double kinkTime(const PlaneTrack& pre, const PlaneTrack& post, double t0_s) {
  double t = t0_s;
  for (int it = 0; it < 3; ++it) {
    const Eigen::Vector2d dr = pre.pos(t) - post.pos(t), dv = pre.vel(t) - post.vel(t);
    const double dv2 = dv.squaredNorm();
    if (!(dv2 > 0)) break;
    t -= dr.dot(dv) / dv2;
  }
  return std::isfinite(t) ? t : t0_s;
}

InstantAgreement compareInstants(double t_before_s, double t_after_s,
                                 const InstantAgreementModel& m) {
  InstantAgreement r;
  r.difference_s = t_after_s - t_before_s;
  const double fit = std::isfinite(m.fit_sigma_s) ? m.fit_sigma_s : 0.0;
  double dist = 0;
  if (m.contact_distance_sigma_m > 0 && m.vn_before_m_s > 0 && m.vn_after_m_s > 0)
    dist = m.contact_distance_sigma_m * (1 / m.vn_before_m_s + 1 / m.vn_after_m_s);
  r.sigma_s = std::sqrt(fit * fit + dist * dist);
  const double lo = 0, hi = std::max(0.0, m.contact_duration_s);
  const double outside = r.difference_s < lo   ? lo - r.difference_s
                         : r.difference_s > hi ? r.difference_s - hi
                                               : 0.0;
  r.outside_s = outside;
  if (outside > 0)
    r.excess_sigmas = r.sigma_s > 0 ? outside / r.sigma_s : std::numeric_limits<double>::infinity();
  r.disagree = r.excess_sigmas > m.k_sigma;
  return r;
}

}  // namespace collide
