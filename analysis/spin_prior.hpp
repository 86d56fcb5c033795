#pragma once
// The launchers' spin as a prior where the dots do not pin a pre-impact spin
// (docs/SPEC.md step 4). A spin fitted from one dot per frame cannot show the
// turn about that dot's own radius, and a dot followed for two or three
// frames pins little more: in those directions the fit's variance runs to
// thousands of (rad/s)^2 and its value to hundreds of rad/s off. Before the
// impact the spin is the launcher's, which the rig profile states as
// 0 +- launch_spin_rad_s per axis ([analysis] launch_spin_rad_s); in every
// direction the fit knows less well than that, the two are combined as
// independent Gaussian estimates. Elsewhere the fit stands alone: a spin the
// dots measure is never pulled towards 0 by the prior.
#include <Eigen/Dense>

#include "analysis/trajectory.hpp"

namespace collide {

struct SpinWithPrior {
  Vec3 spin_rad_s = Vec3::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();  ///< (rad/s)^2
  /// Directions (eigenvectors of the fit's covariance) whose variance was
  /// above the prior's and so were combined with it: 0 to 3.
  int prior_directions = 0;
};

/// Combines a fitted pre-impact spin (value, covariance) with the prior
/// 0 +- prior_sigma_rad_s per axis in each eigen-direction of `cov` whose
/// variance exceeds prior_sigma_rad_s^2. With an isotropic prior the
/// posterior is diagonal in the same eigenbasis, so this is the Bayesian
/// update restricted to those directions. prior_sigma_rad_s <= 0 or not
/// finite, or a covariance not finite: the fit unchanged.
SpinWithPrior combineWithLaunchPrior(const Vec3& spin_rad_s, const Eigen::Matrix3d& cov,
                                     double prior_sigma_rad_s);

}  // namespace collide
