#pragma once
// Spin from matched surface dots (SPEC step 4): the least-squares rotation
// between the 3-D dot positions of two frames, its rotation vector, and the
// spin at collision as the mean of the inter-frame angular velocities on one
// side. SI units: metres, seconds, radians.
#include <Eigen/Dense>
#include <vector>

#include "analysis/result.hpp"
#include "analysis/types.hpp"

namespace collide {

struct RotationFit {
  /// Proper rotation (det = +1) minimising sum_i w_i |to_i - R from_i|^2.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  /// Axis * angle (rad) of `rotation`, angle in [0, pi].
  Vec3 rotation_vector_rad = Vec3::Zero();
  /// sqrt(sum_i w_i |to_i - R from_i|^2 / sum_i w_i), metres.
  double residual_rms_m = 0.0;
  int points = 0;  ///< points with positive weight
};

/// Weighted least-squares rotation about the origin (Kabsch with the
/// determinant correction, so never a reflection) taking `from_m` onto `to_m`.
/// Columns are matched points (m) relative to the sphere centre of each frame:
/// the centre is the fixed point, so no translation is fitted, and two dots not
/// in line with the centre already fix the rotation.
/// weights: one per point, >= 0, relative; empty -> all 1.
/// Errors: different point counts, fewer than 2 points with positive weight, a
/// non-finite coordinate or weight, a negative weight, or points (in either
/// frame) all on one line through the centre, which leaves the spin about that
/// line undetermined.
Result<RotationFit> fitRotation(const Eigen::Matrix3Xd& from_m, const Eigen::Matrix3Xd& to_m,
                                const Eigen::VectorXd& weights = {});

/// The rotation between two frames and the time between them.
struct InterFrameRotation {
  Vec3 rotation_vector_rad = Vec3::Zero();  ///< axis * angle, as RotationFit gives it
  double dt_s = 0.0;                        ///< time between the two frames, > 0
  double weight = 1.0;                      ///< relative weight of this pair, >= 0

  /// Mean angular velocity over the pair, rad/s: rotation vector / dt.
  Vec3 angularVelocity_rad_s() const { return rotation_vector_rad / dt_s; }
};

struct SpinEstimate {
  Vec3 spin_rad_s = Vec3::Zero();  ///< weighted mean of the pairs' angular velocities
  /// Standard error of each component of the mean, from the pairs' scatter
  /// (NaN with a single pair). Consecutive pairs share a frame, so their
  /// errors are anti-correlated and this scatter-based error is conservative.
  Vec3 sigma_rad_s = Vec3::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< of the mean, (rad/s)^2
  double rate_rad_s = 0.0;                               ///< |spin_rad_s|
  double rate_sigma_rad_s = 0.0;                         ///< its standard error, linearised
  int pairs = 0;                                         ///< pairs with positive weight
};

/// Spin on one side of the collision: weighted mean of rotation_vector / dt
/// over the frame pairs (the pair straddling the collision left out by the caller).
/// Errors: no pair with positive weight; a non-finite rotation vector, dt or
/// weight; dt <= 0; a negative weight.
Result<SpinEstimate> spinFromRotations(const std::vector<InterFrameRotation>& pairs);

}  // namespace collide
