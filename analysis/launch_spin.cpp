#include "analysis/launch_spin.hpp"

#include <cmath>
#include <string>

namespace collide {

Result<LaunchSpinSpread> launchSpinSpread(const std::vector<Estimate3>& spins) {
  const int n = static_cast<int>(spins.size());
  if (n < 3)
    return fail("the launchers' spin needs at least 3 measured pre-impact spins (got " +
                std::to_string(n) + "): analyse more shots whose dots are seen");
  for (int i = 0; i < n; ++i)
    if (!spins[i].value.allFinite() || !spins[i].sigma.allFinite())
      return fail("pre-impact spin " + std::to_string(i) + " is not finite");
  LaunchSpinSpread out;
  out.spins = n;
  // Per axis and pooled: mean of the squares, less the mean noise variance.
  Vec3 sq = Vec3::Zero(), noise = Vec3::Zero();
  for (const Estimate3& s : spins) {
    sq += s.value.cwiseAbs2();
    noise += s.sigma.cwiseAbs2();
  }
  sq /= n, noise /= n;
  out.rms_rad_s = (sq - noise).cwiseMax(0.0).cwiseSqrt();
  const double excess = (sq.sum() - noise.sum()) / 3;  // pooled variance, rad^2/s^2
  out.per_axis_rad_s = std::sqrt(std::max(0.0, excess));
  // Standard error of the pooled variance from the spins' scatter: each
  // spin's (|omega|^2 - |sigma|^2) / 3 (its three axes together, as one
  // launch draws them), then of its square root.
  double ss = 0;
  for (const Estimate3& s : spins) {
    const double q = (s.value.squaredNorm() - s.sigma.squaredNorm()) / 3 - excess;
    ss += q * q;
  }
  const double var_sigma = std::sqrt(ss / (n - 1) / n);
  // Near zero the square root's slope diverges: bound it by sqrt(var_sigma).
  out.sigma_rad_s = out.per_axis_rad_s > 0
                        ? std::min(var_sigma / (2 * out.per_axis_rad_s), std::sqrt(var_sigma))
                        : std::sqrt(var_sigma);
  return out;
}

}  // namespace collide
