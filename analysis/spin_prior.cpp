#include "analysis/spin_prior.hpp"

#include <cmath>

namespace collide {

SpinWithPrior combineWithLaunchPrior(const Vec3& spin_rad_s, const Eigen::Matrix3d& cov,
                                     double prior_sigma_rad_s) {
  SpinWithPrior out{spin_rad_s, cov, 0};
  if (!(prior_sigma_rad_s > 0) || !std::isfinite(prior_sigma_rad_s) || !cov.allFinite() ||
      !spin_rad_s.allFinite())
    return out;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(0.5 * (cov + cov.transpose()));
  if (eig.info() != Eigen::Success) return out;
  const double p = prior_sigma_rad_s * prior_sigma_rad_s;
  const Eigen::Matrix3d& V = eig.eigenvectors();
  Vec3 value = V.transpose() * spin_rad_s;  // the spin in the eigenbasis
  Vec3 var = eig.eigenvalues();
  for (int i = 0; i < 3; ++i) {
    if (!(var[i] > p)) continue;
    // Two independent Gaussian estimates of one component: the fit's
    // (value, m) and the prior's (0, p).
    value[i] *= p / (var[i] + p);
    var[i] = var[i] * p / (var[i] + p);
    ++out.prior_directions;
  }
  if (out.prior_directions == 0) return out;
  out.spin_rad_s = V * value;
  out.cov = V * var.asDiagonal() * V.transpose();
  return out;
}

}  // namespace collide
