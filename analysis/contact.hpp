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

/// Where the centres' images are when the spheres touch: the fits follow the
/// centres in the image plane, where two touching spheres whose line of
/// centres leaves the plane by n_z (its z part) are d sqrt(1 - n_z^2) apart,
/// not d. With n_z known as N(nz_mean, nz_sigma^2), the distance at which the
/// image-plane fits touch is taken at the expected n_z^2 (nz_mean^2 +
/// nz_sigma^2). Left at d, the pre-impact instant comes early by d n_z^2 /
/// (2 |v_n|) and the post-impact one late by as much over |v_n'| (a 3-degree
/// tilt of 2.54 cm spheres: 35 um, 35 us at 1 m/s).
double inPlaneContactDistance(double contact_m, double nz_mean, double nz_sigma);

/// Weight of the pre-impact instant in the combined collision instant:
/// inverse variances, var_a / (var_a + var_b); 0.5 when either is unknown.
double beforeInstantWeight(double sigma_before_s, double sigma_after_s);

/// The same with the contact distance's uncertainty: an error dd of the
/// distance at which the centres touch moves the pre-impact instant by
/// -dd / |v_n| and the post-impact one by +dd / |v_n'| (fully correlated), so
/// the weights that minimise the combined instant's variance (generalised
/// least squares over both) lean towards cancelling it: w -> |v_n| / (|v_n| +
/// |v_n'|) when dd dominates. Where the line of centres is set by the
/// instant (grazing impacts, whose relative motion is mostly along the
/// tangent), this is what keeps gamma, and e through it, off dd. Falls back
/// to the two-sigma form when a speed is not > 0.
double beforeInstantWeight(double sigma_before_s, double sigma_after_s, double contact_sigma_m,
                           double vn_before_m_s, double vn_after_m_s);

/// The instant at which one sphere's pre- and post-impact tracks meet: its
/// centre does not jump at the impact, so the two fits, extended, cross
/// where it happened, whatever the contact distance (a biased radius moves
/// the instants at which the centres are one contact distance apart, not
/// this one). Newton steps from t0_s on the tracks' separation along their
/// velocity difference; t0_s where their velocities do not differ.
double kinkTime(const PlaneTrack& pre, const PlaneTrack& post, double t0_s);

/// What the two instants may differ by without anything being wrong.
struct InstantAgreementModel {
  /// Standard deviation of (t_before - t_after) from the fits' random errors
  /// and the centres' systematic drifts (residual inflation included), s.
  double fit_sigma_s = 0;
  /// Standard uncertainty of the contact distance, m: the detector's
  /// systematic radius error (through the pixel size or the contact distance
  /// in pixels), the diameters' tolerance. It moves the pre-impact instant by
  /// -dd / |v_n| and the post-impact one by +dd / |v_n'|: fully correlated.
  double contact_distance_sigma_m = 0;
  double vn_before_m_s = 0;  ///< |v_n| before (m/s, > 0)
  double vn_after_m_s = 0;   ///< |v_n'| after (m/s, > 0)
  /// Longest plausible contact duration, s: the pre-impact fits reach the
  /// contact distance when the spheres first touch, the post-impact fits when
  /// they separate, so t_after - t_before lies in [0, contact_duration_s]
  /// for an honest shot (0 for the instantaneous impacts of the simulator).
  double contact_duration_s = 0;
  double k_sigma = 4;  ///< how many combined sigmas make a disagreement
};

struct InstantAgreement {
  double difference_s = 0;  ///< t_after - t_before
  double sigma_s = 0;       ///< combined standard uncertainty of the difference
  /// Distance of the difference from the allowed band [0, contact_duration],
  /// s (0 inside the band), and in combined sigmas.
  double outside_s = 0;
  double excess_sigmas = 0;
  bool disagree = false;  ///< excess_sigmas > k_sigma
};

/// Compares the two collision instants under `model`. A non-finite
/// fit_sigma_s is taken as 0 (the other terms then decide).
InstantAgreement compareInstants(double t_before_s, double t_after_s,
                                 const InstantAgreementModel& model);

}  // namespace collide
