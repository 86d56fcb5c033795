#pragma once
// Free-flight trajectory of one sphere centre: a weighted least-squares
// quadratic in time per axis (constant acceleration, SPEC step 2), and the
// collision instant where two fitted centres are one contact distance apart
// (SPEC step 3). SI units: seconds, metres.
#include <Eigen/Dense>
#include <array>
#include <optional>

#include "analysis/air_drag.hpp"
#include "analysis/least_squares.hpp"
#include "analysis/result.hpp"
#include "analysis/types.hpp"

namespace collide {

/// A vector quantity with the standard uncertainty of each component (same unit).
struct Estimate3 {
  Vec3 value = Vec3::Zero();
  Vec3 sigma = Vec3::Zero();
};

struct TrajectoryOptions {
  /// When set, the acceleration is not fitted but fixed to this vector (m/s^2;
  /// for a 2-D fit only x and y are used), e.g. kGravity_m_s2: the physics
  /// knows g, and fixing it leaves 2 parameters per axis instead of 3.
  std::optional<Vec3> fixed_acceleration_m_s2;
  /// With a fixed acceleration: the air's drag on the sphere
  /// (analysis/air_drag.hpp) added to it. The track is fitted once without
  /// it; the drag at the fitted velocity at t_ref, and its first two rates of
  /// change along the fit, are then taken as known (their terms in tau^2,
  /// tau^3, tau^4 subtracted) and the track fitted again, twice.
  /// acceleration_m_s2() reports gravity plus the drag at t_ref (its change,
  /// ~0.3 m/s^3 at 1.5 m/s, is left out of positions and velocities evaluated
  /// away from t_ref: 3e-7 m/s a millisecond off). Ignored without a fixed
  /// acceleration.
  std::optional<AirDrag> drag;
};

/// r_k(t) = c0 + c1 (t - t_ref) + c2 (t - t_ref)^2 per axis k. The axes are
/// fitted independently (uncorrelated centre noise in x, y, z). A 2-D fit
/// (image plane) reports z = 0 with zero uncertainty.
class TrajectoryFit {
 public:
  int dimensions() const { return dims_; }
  double tRef_s() const { return t_ref_s_; }
  double tFirst_s() const { return t_first_s_; }  ///< earliest fitted sample
  double tLast_s() const { return t_last_s_; }    ///< latest fitted sample
  bool accelerationFixed() const { return acceleration_fixed_; }

  /// Centre position (m) at time t_s (s; any t, extrapolation included), with
  /// its standard uncertainty from the fit covariance.
  Estimate3 positionAt_m(double t_s) const;
  /// Velocity (m/s), the derivative of the fit, at time t_s.
  Estimate3 velocityAt_m_s(double t_s) const;
  /// Acceleration (m/s^2), constant; zero uncertainty when fixed.
  Estimate3 acceleration_m_s2() const;
  /// Covariance of the position (m^2) at t_s: diagonal, axes are independent.
  Eigen::Matrix3d positionCovariance_m2(double t_s) const;

  /// Coefficients (c0 m, c1 m/s, c2 m/s^2) of axis k and their covariance
  /// (c2 row/column zero when the acceleration is fixed).
  const Eigen::Vector3d& coefficients(int axis) const { return coef_[axis]; }
  const Eigen::Matrix3d& covariance(int axis) const { return cov_[axis]; }
  /// RMS of the position residuals per axis (m; z = 0 for a 2-D fit).
  Vec3 residualRms_m() const { return residual_rms_m_; }
  /// The underlying least-squares fit of axis k (chi^2, dof, residuals).
  const LinearFit& axisFit(int axis) const { return axis_fit_[axis]; }

 private:
  friend Result<TrajectoryFit> fitTrajectory(const Eigen::VectorXd&, const Eigen::MatrixXd&,
                                             const Weights&, double, const TrajectoryOptions&);
  Estimate3 evaluate(const Eigen::Vector3d& basis) const;

  int dims_ = 0;
  double t_ref_s_ = 0, t_first_s_ = 0, t_last_s_ = 0;
  bool acceleration_fixed_ = false;
  std::array<Eigen::Vector3d, 3> coef_{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                                       Eigen::Vector3d::Zero()};
  std::array<Eigen::Matrix3d, 3> cov_{Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero(),
                                      Eigen::Matrix3d::Zero()};
  std::array<LinearFit, 3> axis_fit_{};
  Vec3 residual_rms_m_ = Vec3::Zero();
};

/// Fits one centre track.
///  times_s: N sample times (s). positions_m: N x 2 (x, y) or N x 3 (x, y, z), metres.
///  weights: per sample, shared by all axes. Weights::fromSigmas(sigma_m) for a
///    known centre uncertainty (covariance as is); Weights::equal() or
///    Weights::relative(w) to let the residuals set the scale (with exactly
///    3 samples, or 2 with fixed acceleration, the uncertainties are then NaN).
///  t_ref_s: origin of the polynomial; pick it near where the fit will be used.
/// Errors: sizes that disagree, not 2 or 3 columns, a non-finite time, position
/// or t_ref, fewer than 3 samples (2 with fixed acceleration), all times equal,
/// fewer distinct times than parameters, bad weights.
Result<TrajectoryFit> fitTrajectory(const Eigen::VectorXd& times_s,
                                    const Eigen::MatrixXd& positions_m, const Weights& weights,
                                    double t_ref_s, const TrajectoryOptions& options = {});

/// Which root of |r_A(t) - r_B(t)| = d is wanted.
enum class CollisionSide {
  /// From pre-impact fits: the earliest instant at which the distance falls to
  /// d (distance decreasing), searched from the start of the data forward.
  kBefore,
  /// From post-impact fits: the latest instant at which the distance rises
  /// through d (distance increasing), searched from the end of the data backward.
  kAfter,
};

struct CollisionInstant {
  double t_s = 0.0;  ///< contact instant (s, same clock as the fits)
  /// Standard uncertainty propagated from both fits' covariances; NaN when a
  /// fit's noise scale is unknown (relative weights, no residual degrees of freedom).
  double sigma_s = 0.0;
};

/// Instant at which the fitted centres of A and B are contact_distance_m
/// (metres, (sigma_1 + sigma_2)/2) apart. The fits are taken as independent.
/// The search window is the union of both fits' sample spans extended by
/// search_margin_s (s, >= 0; default: the longer of the two spans) after the
/// data for kBefore, before it for kAfter. The quartic |dr|^2 = d^2 is solved
/// exactly (monotonic brackets from its derivatives, then bisection).
/// Errors: non-positive or non-finite distance or margin; the fitted distance
/// never reaches d in the required direction inside the window.
Result<CollisionInstant> collisionInstant(const TrajectoryFit& a, const TrajectoryFit& b,
                                          double contact_distance_m, CollisionSide side,
                                          std::optional<double> search_margin_s = std::nullopt);

}  // namespace collide
