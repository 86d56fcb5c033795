#pragma once
// The launchers' spin spread: how fast, per axis, the launchers spin the
// spheres they fire. An analysis takes a spin it cannot see (no dots on that
// side) as 0 with this standard uncertainty per axis (the rig profile's
// [analysis] launch_spin_rad_s, docs/imaging.md); this measures it from the
// pre-impact spins of shots whose dots were seen.
//
// The prior is centred on zero, so the spread is the root mean square about
// zero (a launcher that spins every sphere the same way widens it, as it
// should: the prior's error is the spin's distance from 0), with each spin's
// own measurement variance taken out.
#include <vector>

#include "analysis/result.hpp"
#include "analysis/trajectory.hpp"

namespace collide {

struct LaunchSpinSpread {
  /// Per axis (x, y, z), rad/s: sqrt(mean(omega^2) - mean(sigma^2)), 0 where
  /// the measurement noise explains all of the scatter.
  Vec3 rms_rad_s = Vec3::Zero();
  /// The three axes pooled, rad/s: the value for launch_spin_rad_s.
  double per_axis_rad_s = 0;
  /// Its standard error, rad/s (from the scatter of the spins' squared sizes).
  double sigma_rad_s = 0;
  int spins = 0;  ///< spins used
};

/// Errors: fewer than 3 spins; a non-finite value or sigma (named by index).
Result<LaunchSpinSpread> launchSpinSpread(const std::vector<Estimate3>& pre_impact_spins);

}  // namespace collide
