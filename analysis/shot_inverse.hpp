#pragma once
// Walton's inverse for one measured shot (docs/SPEC.md steps 5-6): from the
// in-plane velocities and the spins of both spheres at the contact instant,
// the out-of-plane part of the line of centres and of the impulse (thesis
// Appendix B, generalised), then e, beta, f and the contact kinematics
// (analysis/walton.hpp's measureCollision). Pure physics, SI units.
#include <Eigen/Dense>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "analysis/types.hpp"
#include "analysis/walton.hpp"

namespace collide {

/// Both spheres at the contact instant, as measured (one draw or the nominal values).
struct ContactState {
  std::array<Eigen::Vector2d, 2> position_m;  ///< centres in the image plane (x, y)
  /// Velocities before (z: the launch's out-of-plane part, drawn or 0) and
  /// after (z filled in by the inverse), m/s.
  std::array<Vec3, 2> v_before, v_after;
  std::array<Vec3, 2> w_before, w_after;  ///< spins, rad/s
};

struct ShotInverseSettings {
  std::array<double, 2> diameter_m{0, 0}, mass_kg{0, 0};
  /// Covariance of each sphere's spin change (before + after), rad^2/s^2:
  /// weights of the out-of-plane estimates.
  std::array<Eigen::Matrix3d, 2> spin_change_cov{Eigen::Matrix3d::Identity(),
                                                 Eigen::Matrix3d::Identity()};
  double nz_sigma = 0.01;  ///< prior sigma of the line of centres' z part
  double nz_prior = 0.0;   ///< prior mean (a draw from N(0, nz_sigma^2) in the Monte Carlo)
};

struct ShotInverse {
  bool ok = false;              ///< false: not a collision (no approach, coincident centres)
  double n_z = 0;               ///< z part of the unit line of centres
  std::array<Vec3, 2> v_after;  ///< the state's v_after with the z parts found
  WaltonMeasurement m;
  double vs_after = 0;  ///< v_s' . t (along the pre-impact tangent), m/s
  /// Total kinetic energy after minus before (translation + rotation, I =
  /// m d^2 / 10), J.
  double kinetic_energy_change_J = 0;
  double kinetic_energy_before_J = 0;
};

/// Out of the image plane: the spin changes give the impulse's z part and,
/// through friction, the line of centres' small z part, which the images
/// cannot show. -n x dP = (m_i d_i / 5) d omega_i, rows x and y for each
/// sphere, is linear in (n_z, dP_z):
///   n_z dP_y - n_y dP_z = c_i d omega_ix,   n_x dP_z - n_z dP_x = c_i d omega_iy,
/// solved by weighted least squares with the prior N(nz_prior, nz_sigma^2) on
/// n_z (a frictionless impulse leaves n_z undetermined); n_z is clamped to
/// +-0.2. Then Walton's inverse on the completed states.
ShotInverse invertShot(const ContactState& state, const ShotInverseSettings& settings);

/// A measured value and its standard uncertainty (any unit).
struct ValueSigma {
  double value = 0, sigma = 0;
};

/// What physics forbids a collision's measured properties, beyond k_sigma of
/// their own uncertainty: e > 1 or e < 0, beta outside [-1, 1], total kinetic
/// energy gained (change > 0, J). A non-finite sigma counts as 0 (the value
/// alone decides); a non-finite value is never called unphysical (beta of a
/// head-on impact is NaN). Returns one sentence per violation (empty: none).
std::vector<std::string> unphysicalFindings(const ValueSigma& e, const ValueSigma& beta,
                                            const ValueSigma& kinetic_energy_change_J,
                                            double k_sigma = 3.0);

/// Angular momentum about the contact point: the spins after an impact are
/// the spins before plus what the impulse (from the velocity changes) turns
/// them by. beta read from the spins after and beta_from_impulse (spins
/// before plus that turn) must then agree within k_sigma of the spread of
/// their difference, `difference_sigma` (the two share most inputs, so it
/// is the difference's own spread, e.g. over Monte Carlo draws). Returns the
/// sentence that says they do not, or nothing (also when a value or the
/// sigma is not finite, or the sigma is not > 0).
std::optional<std::string> spinImpulseDisagreement(double beta, double beta_from_impulse,
                                                   double difference_sigma, double k_sigma = 4.0);

}  // namespace collide
