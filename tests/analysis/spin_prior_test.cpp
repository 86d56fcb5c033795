// The launchers' spin as a prior where the dots do not pin a pre-impact
// spin, against the Gaussian algebra done by hand and against spins drawn
// from the prior and measured with a known covariance (simulated truth).
#include "analysis/spin_prior.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace collide {
namespace {

// A covariance with variances `var` along the orthonormal axes of `basis`.
Eigen::Matrix3d covAlong(const Eigen::Matrix3d& basis, const Vec3& var) {
  return basis * var.asDiagonal() * basis.transpose();
}

Eigen::Matrix3d tiltedBasis() {
  return Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
}

TEST(CombineWithLaunchPrior, ASpinTheDotsPinEverywhereIsLeftAlone) {
  const Vec3 spin(35, -12, 60);  // well outside the prior: must not be pulled to 0
  const Eigen::Matrix3d cov = covAlong(tiltedBasis(), Vec3(4, 9, 30));
  const SpinWithPrior r = combineWithLaunchPrior(spin, cov, 6.7);  // 6.7^2 = 44.9 > 30
  EXPECT_EQ(r.prior_directions, 0);
  EXPECT_EQ(r.spin_rad_s, spin);
  EXPECT_EQ(r.cov, cov);
}

TEST(CombineWithLaunchPrior, OnlyTheDirectionTheDotsDoNotPinTakesThePrior) {
  // One dot per frame: the turn about that dot's radius is not seen.
  const Eigen::Matrix3d basis = tiltedBasis();
  const double p = 6.7, m = 400.0 * 400.0;
  const Eigen::Matrix3d cov = covAlong(basis, Vec3(2.0, 3.0, m));
  const Vec3 in_basis(5.0, -8.0, 2000.0);  // 2000 rad/s off along the unseen direction
  const Vec3 spin = basis * in_basis;
  const SpinWithPrior r = combineWithLaunchPrior(spin, cov, p);
  EXPECT_EQ(r.prior_directions, 1);
  const Vec3 out = basis.transpose() * r.spin_rad_s;
  // Two independent Gaussians along the third axis: (2000 / m) / (1/m + 1/p^2).
  const double w = p * p / (m + p * p);
  EXPECT_NEAR(out[2], 2000.0 * w, 1e-9);
  EXPECT_NEAR(out[0], 5.0, 1e-9);
  EXPECT_NEAR(out[1], -8.0, 1e-9);
  const Eigen::Matrix3d cov_b = basis.transpose() * r.cov * basis;
  EXPECT_NEAR(cov_b(2, 2), 1.0 / (1.0 / m + 1.0 / (p * p)), 1e-9);
  EXPECT_NEAR(cov_b(0, 0), 2.0, 1e-9);
  EXPECT_NEAR(cov_b(1, 1), 3.0, 1e-9);
  EXPECT_NEAR(cov_b(0, 2), 0.0, 1e-9);
}

// Spins drawn from the prior, measured with a covariance that pins one
// direction far less well than the prior: the combined spin's errors against
// the drawn truth match its stated covariance, and are smaller than the fit's.
TEST(CombineWithLaunchPrior, ItsSigmasCoverTheErrorsAgainstDrawnTruth) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> unit(0, 1);
  const double p = 6.7;
  const Eigen::Matrix3d basis = tiltedBasis();
  const Vec3 var(1.5 * 1.5, 3.0 * 3.0, 150.0 * 150.0);
  const Eigen::Matrix3d cov = covAlong(basis, var);
  const int n = 20000;
  double pull2[3] = {0, 0, 0}, err2_fit = 0, err2_out = 0;
  for (int i = 0; i < n; ++i) {
    const Vec3 truth = p * Vec3(unit(rng), unit(rng), unit(rng));
    const Vec3 noise = basis * Vec3(std::sqrt(var[0]) * unit(rng), std::sqrt(var[1]) * unit(rng),
                                    std::sqrt(var[2]) * unit(rng));
    const SpinWithPrior r = combineWithLaunchPrior(truth + noise, cov, p);
    ASSERT_EQ(r.prior_directions, 1);
    const Vec3 err = basis.transpose() * (r.spin_rad_s - truth);
    const Eigen::Matrix3d cb = basis.transpose() * r.cov * basis;
    for (int k = 0; k < 3; ++k) pull2[k] += err[k] * err[k] / cb(k, k);
    err2_fit += noise.squaredNorm();
    err2_out += err.squaredNorm();
  }
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(std::sqrt(pull2[k] / n), 1.0, 0.03) << "axis " << k;
  EXPECT_LT(err2_out, 0.01 * err2_fit);
}

TEST(CombineWithLaunchPrior, NoPriorOrABadCovarianceLeavesTheFitAlone) {
  const Vec3 spin(1, 2, 3);
  const Eigen::Matrix3d cov = Eigen::Matrix3d::Identity() * 1e6;
  for (const double p : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    const SpinWithPrior r = combineWithLaunchPrior(spin, cov, p);
    EXPECT_EQ(r.prior_directions, 0) << p;
    EXPECT_EQ(r.spin_rad_s, spin) << p;
  }
  Eigen::Matrix3d bad = cov;
  bad(1, 1) = std::nan("");
  EXPECT_EQ(combineWithLaunchPrior(spin, bad, 6.7).prior_directions, 0);
}

}  // namespace
}  // namespace collide
