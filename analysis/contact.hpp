#pragma once
// The collision instant (docs/SPEC.md step 3) from two sphere tracks: where
// the fitted centres are one contact distance apart, from the pre-impact fits
// and, independently, from the post-impact fits; how the two are combined;
// and whether they disagree beyond what the measurement and the model allow.
// Pure maths: seconds, metres.
#include <Eigen/Dense>
#include <array>

namespace collide {

/// A centre's quadratic in time in the image plane:
/// r_k(t) = c[k][0] + c[k][1] (t - t_ref) + c[k][2] (t - t_ref)^2, k = x, y.
struct PlaneTrack {
  double t_ref = 0;
  std::array<Eigen::Vector3d, 2> c{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Vector2d pos(double t) const {
    const double tau = t - t_ref;
    return {c[0][0] + c[0][1] * tau + c[0][2] * tau * tau,
            c[1][0] + c[1][1] * tau + c[1][2] * tau * tau};
  }
  Eigen::Vector2d vel(double t) const {
    const double tau = t - t_ref;
    return {c[0][1] + 2 * c[0][2] * tau, c[1][1] + 2 * c[1][2] * tau};
  }
};

/// The instant near t0_s at which |a(t) - b(t)| = dist_m: six Newton steps
/// from t0_s (the exact root of the nominal fits; draws lie close to it).
double contactTime(const PlaneTrack& a, const PlaneTrack& b, double dist_m, double t0_s);

/// Weight of the pre-impact instant in the combined collision instant:
/// inverse variances, var_a / (var_a + var_b); 0.5 when either is unknown.
double beforeInstantWeight(double sigma_before_s, double sigma_after_s);

}  // namespace collide
