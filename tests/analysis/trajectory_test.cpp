#include "analysis/trajectory.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

using namespace collide;
using ::testing::HasSubstr;

namespace {

// A ballistic truth: r(t) = r0 + v0 t + a t^2 / 2.
struct Ballistic {
  Vec3 r0, v0, a;
  Vec3 at(double t) const { return r0 + v0 * t + 0.5 * a * t * t; }
  Vec3 velocity(double t) const { return v0 + a * t; }
};

Eigen::VectorXd frameTimes(int n, double t0_s, double dt_s) {
  return Eigen::VectorXd::LinSpaced(n, t0_s, t0_s + (n - 1) * dt_s);
}

Eigen::MatrixXd sample(const Ballistic& b, const Eigen::VectorXd& t, int dims,
                       std::mt19937* rng = nullptr, double sigma_m = 0.0) {
  Eigen::MatrixXd p(t.size(), dims);
  std::normal_distribution<double> noise(0.0, sigma_m);
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    const Vec3 r = b.at(t[i]);
    for (int k = 0; k < dims; ++k) p(i, k) = r[k] + (rng ? noise(*rng) : 0.0);
  }
  return p;
}

const Ballistic kShot{{-0.05, 0.02, 0.001}, {2.3, 0.8, -0.05}, kGravity_m_s2};

}  // namespace

TEST(Trajectory, RecoversNoiseFreeQuadraticExactly3D) {
  const Eigen::VectorXd t = frameTimes(10, -9e-3, 1e-3);
  auto fit = fitTrajectory(t, sample(kShot, t, 3), Weights::equal(), -4e-3);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_EQ(fit->dimensions(), 3);
  for (double tq : {-9e-3, -1e-3, 0.0, 2.5e-3}) {
    EXPECT_LT((fit->positionAt_m(tq).value - kShot.at(tq)).norm(), 1e-12) << tq;
    EXPECT_LT((fit->velocityAt_m_s(tq).value - kShot.velocity(tq)).norm(), 1e-9) << tq;
  }
  EXPECT_LT((fit->acceleration_m_s2().value - kGravity_m_s2).norm(), 1e-6);
  EXPECT_LT(fit->residualRms_m().norm(), 1e-12);
}

TEST(Trajectory, TwoDimensionalFitReportsZeroZ) {
  const Eigen::VectorXd t = frameTimes(6, 0.0, 1e-3);
  auto fit = fitTrajectory(t, sample(kShot, t, 2), Weights::equal(), 0.0);
  ASSERT_TRUE(fit.ok());
  EXPECT_EQ(fit->dimensions(), 2);
  const Estimate3 v = fit->velocityAt_m_s(3e-3);
  EXPECT_NEAR(v.value.x(), kShot.velocity(3e-3).x(), 1e-9);
  EXPECT_NEAR(v.value.y(), kShot.velocity(3e-3).y(), 1e-9);
  EXPECT_EQ(v.value.z(), 0.0);
  EXPECT_EQ(v.sigma.z(), 0.0);
}

TEST(Trajectory, FixedAccelerationNeedsOnlyTwoSamples) {
  const Eigen::VectorXd t = frameTimes(2, 1e-3, 1e-3);
  TrajectoryOptions opt;
  opt.fixed_acceleration_m_s2 = kGravity_m_s2;
  auto fit = fitTrajectory(t, sample(kShot, t, 2), Weights::equal(), 0.0, opt);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_TRUE(fit->accelerationFixed());
  EXPECT_NEAR(fit->velocityAt_m_s(0.0).value.y(), kShot.v0.y(), 1e-10);
  EXPECT_NEAR(fit->velocityAt_m_s(0.0).value.x(), kShot.v0.x(), 1e-10);
  EXPECT_NEAR(fit->acceleration_m_s2().value.y(), kGravity_m_s2.y(), 1e-15);
  EXPECT_EQ(fit->acceleration_m_s2().sigma.y(), 0.0);
  // Two samples leave no residual to estimate the noise from.
  EXPECT_TRUE(std::isnan(fit->velocityAt_m_s(0.0).sigma.x()));
}

// Known Gaussian centre noise (0.1 mm, about a quarter pixel on the thesis rig):
// the velocity extrapolated half a frame past the data lies within the reported
// 1-sigma 68.3 % of the time; 60..76 % over 400 seeds is a > 3-sigma band.
TEST(Trajectory, VelocityUncertaintyCoverageOverSeeds) {
  const Eigen::VectorXd t = frameTimes(10, -9.5e-3, 1e-3);
  const double sigma_m = 1e-4;
  const Weights w = Weights::fromSigmas(Eigen::VectorXd::Constant(t.size(), sigma_m));
  TrajectoryOptions fixed;
  fixed.fixed_acceleration_m_s2 = kGravity_m_s2;
  int cover_x = 0, cover_y = 0, cover_fixed_y = 0;
  const int trials = 400;
  for (int seed = 0; seed < trials; ++seed) {
    std::mt19937 rng(seed);
    const Eigen::MatrixXd p = sample(kShot, t, 2, &rng, sigma_m);
    auto fit = fitTrajectory(t, p, w, -5e-3);
    auto fit_g = fitTrajectory(t, p, w, -5e-3, fixed);
    ASSERT_TRUE(fit.ok() && fit_g.ok());
    const Vec3 truth = kShot.velocity(0.0);
    const Estimate3 v = fit->velocityAt_m_s(0.0);
    const Estimate3 vg = fit_g->velocityAt_m_s(0.0);
    if (std::abs(v.value.x() - truth.x()) <= v.sigma.x()) ++cover_x;
    if (std::abs(v.value.y() - truth.y()) <= v.sigma.y()) ++cover_y;
    if (std::abs(vg.value.y() - truth.y()) <= vg.sigma.y()) ++cover_fixed_y;
  }
  for (int covered : {cover_x, cover_y, cover_fixed_y}) {
    EXPECT_GE(covered, 0.60 * trials);
    EXPECT_LE(covered, 0.76 * trials);
  }
}

// The residuals of a quadratic fit to N samples with noise sigma have
// E[rms^2] = sigma^2 (N - 3) / N.
TEST(Trajectory, ResidualRmsMatchesNoiseLevel) {
  const Eigen::VectorXd t = frameTimes(10, 0.0, 1e-3);
  const double sigma_m = 2e-4;
  double sum_rms2 = 0.0;
  const int trials = 400;
  for (int seed = 0; seed < trials; ++seed) {
    std::mt19937 rng(1000 + seed);
    auto fit = fitTrajectory(t, sample(kShot, t, 2, &rng, sigma_m), Weights::equal(), 4.5e-3);
    ASSERT_TRUE(fit.ok());
    sum_rms2 += std::pow(fit->residualRms_m().x(), 2);
  }
  EXPECT_NEAR(sum_rms2 / trials, sigma_m * sigma_m * 7.0 / 10.0, 0.1 * sigma_m * sigma_m * 0.7);
}

TEST(Trajectory, ErrorsSayWhatIsWrong) {
  const Eigen::VectorXd t2 = frameTimes(2, 0.0, 1e-3);
  auto too_few = fitTrajectory(t2, sample(kShot, t2, 2), Weights::equal(), 0.0);
  ASSERT_FALSE(too_few.ok());
  EXPECT_THAT(too_few.error().message, HasSubstr("at least 3"));

  TrajectoryOptions fixed;
  fixed.fixed_acceleration_m_s2 = kGravity_m_s2;
  const Eigen::VectorXd t1 = frameTimes(1, 0.0, 1e-3);
  auto too_few_fixed = fitTrajectory(t1, sample(kShot, t1, 2), Weights::equal(), 0.0, fixed);
  ASSERT_FALSE(too_few_fixed.ok());
  EXPECT_THAT(too_few_fixed.error().message, HasSubstr("at least 2"));

  const Eigen::VectorXd same = Eigen::VectorXd::Constant(5, 2e-3);
  auto equal_times = fitTrajectory(same, sample(kShot, same, 2), Weights::equal(), 0.0);
  ASSERT_FALSE(equal_times.ok());
  EXPECT_THAT(equal_times.error().message, HasSubstr("same time"));

  Eigen::VectorXd t = frameTimes(5, 0.0, 1e-3);
  Eigen::MatrixXd p = sample(kShot, t, 2);
  p(3, 1) = std::nan("");
  auto nan_pos = fitTrajectory(t, p, Weights::equal(), 0.0);
  ASSERT_FALSE(nan_pos.ok());
  EXPECT_THAT(nan_pos.error().message, HasSubstr("sample 3"));

  t[2] = INFINITY;
  EXPECT_FALSE(
      fitTrajectory(t, sample(kShot, frameTimes(5, 0, 1e-3), 2), Weights::equal(), 0.0).ok());
  EXPECT_FALSE(
      fitTrajectory(frameTimes(5, 0, 1e-3), Eigen::MatrixXd::Zero(5, 1), Weights::equal(), 0.0)
          .ok());
  EXPECT_FALSE(
      fitTrajectory(frameTimes(5, 0, 1e-3), Eigen::MatrixXd::Zero(4, 2), Weights::equal(), 0.0)
          .ok());
}

// Head-on along x, both spheres under the same vertical motion, different x
// accelerations so |rA - rB|^2 is a genuine quartic in t:
//   dx(t) = xA - xB = -0.04 + 3.5 t + 2 t^2.
// Contact on approach: dx = -d; the ghost exit (centres passing through each
// other): dx = +d. Both roots from the quadratic formula.
class HeadOn : public ::testing::Test {
 protected:
  const Ballistic a_{{-0.03, 0.1, 0.0}, {2.0, 0.5, 0.0}, {3.0, -9.80665, 0.0}};
  const Ballistic b_{{0.01, 0.1, 0.0}, {-1.5, 0.5, 0.0}, {-1.0, -9.80665, 0.0}};
  const double d_ = 0.0254;
  static double root(double c0) {  // 2 t^2 + 3.5 t + c0 = 0, the root near zero
    const double disc = std::sqrt(3.5 * 3.5 - 8.0 * c0);
    return 2.0 * c0 / (-3.5 - disc);  // stable form of (-3.5 + disc) / 4
  }
  TrajectoryFit fit(const Ballistic& b, const Eigen::VectorXd& t) {
    auto f = fitTrajectory(t, sample(b, t, 2), Weights::equal(), t.mean());
    EXPECT_TRUE(f.ok());
    return *f;
  }
};

TEST_F(HeadOn, BeforeMatchesAnalyticRoot) {
  const Eigen::VectorXd t = frameTimes(8, -8e-3, 1e-3);
  auto hit = collisionInstant(fit(a_, t), fit(b_, t), d_, CollisionSide::kBefore);
  ASSERT_TRUE(hit.ok()) << hit.error().message;
  const double truth = root(-0.04 + d_);
  EXPECT_GT(truth, 4e-3);  // really an extrapolation past the last sample
  EXPECT_NEAR(hit->t_s, truth, 1e-12);
}

TEST_F(HeadOn, AfterMatchesAnalyticRoot) {
  const Eigen::VectorXd t = frameTimes(8, 22e-3, 1e-3);
  auto hit = collisionInstant(fit(a_, t), fit(b_, t), d_, CollisionSide::kAfter);
  ASSERT_TRUE(hit.ok()) << hit.error().message;
  const double truth = root(-0.04 - d_);
  EXPECT_GT(truth, 15e-3);
  EXPECT_LT(truth, 22e-3);
  EXPECT_NEAR(hit->t_s, truth, 1e-12);
}

// Straight relative motion (same gravity on both): |D0 + V t| = d has the two
// roots (-D0.V -+ sqrt((D0.V)^2 - |V|^2 (|D0|^2 - d^2))) / |V|^2; from one pair
// of fits, Before takes the first and After the second.
TEST(CollisionInstant, ObliqueBothSidesFromTheSameFits) {
  const Ballistic a{{-0.06, 0.012, 0.0}, {3.0, 0.4, 0.0}, kGravity_m_s2};
  const Ballistic b{{0.05, -0.004, 0.0}, {-2.0, 0.9, 0.0}, kGravity_m_s2};
  const double d = 0.0254;
  const Vec3 d0 = a.r0 - b.r0, dv = a.v0 - b.v0;
  const double bq = d0.dot(dv),
               disc = std::sqrt(bq * bq - dv.squaredNorm() * (d0.squaredNorm() - d * d));
  const double t_in = (-bq - disc) / dv.squaredNorm();
  const double t_out = (-bq + disc) / dv.squaredNorm();
  ASSERT_LT(t_in, t_out);

  // Samples spanning both roots (the centres pass through each other): Before
  // must pick the approach, After the separation.
  const int n = int(std::ceil((t_out - t_in) / 1e-3)) + 8;
  const Eigen::VectorXd t = frameTimes(n, t_in - 4e-3, 1e-3);
  auto fa = fitTrajectory(t, sample(a, t, 3), Weights::equal(), t_in);
  auto fb = fitTrajectory(t, sample(b, t, 3), Weights::equal(), t_in);
  ASSERT_TRUE(fa.ok() && fb.ok());
  auto before = collisionInstant(*fa, *fb, d, CollisionSide::kBefore);
  auto after = collisionInstant(*fa, *fb, d, CollisionSide::kAfter);
  ASSERT_TRUE(before.ok()) << before.error().message;
  ASSERT_TRUE(after.ok()) << after.error().message;
  EXPECT_NEAR(before->t_s, t_in, 1e-12);
  EXPECT_NEAR(after->t_s, t_out, 1e-12);

  // Post-impact data only: After extrapolates backwards to t_out.
  const Eigen::VectorXd t_post = frameTimes(6, t_out + 1.5e-3, 1e-3);
  auto pa = fitTrajectory(t_post, sample(a, t_post, 3), Weights::equal(), t_out);
  auto pb = fitTrajectory(t_post, sample(b, t_post, 3), Weights::equal(), t_out);
  ASSERT_TRUE(pa.ok() && pb.ok());
  auto post = collisionInstant(*pa, *pb, d, CollisionSide::kAfter);
  ASSERT_TRUE(post.ok()) << post.error().message;
  EXPECT_NEAR(post->t_s, t_out, 1e-12);
  // ... and finds no approach in its window, since it only extends backwards for After.
  EXPECT_FALSE(collisionInstant(*pa, *pb, d, CollisionSide::kBefore).ok());
}

TEST(CollisionInstant, ErrorWhenTheyNeverMeet) {
  const Ballistic a{{-0.05, 0.0, 0.0}, {1.0, 0.0, 0.0}, kGravity_m_s2};
  const Ballistic b{{-0.05, 0.05, 0.0}, {1.0, 0.0, 0.0}, kGravity_m_s2};  // parallel, 5 cm apart
  const Eigen::VectorXd t = frameTimes(6, 0.0, 1e-3);
  auto fa = fitTrajectory(t, sample(a, t, 2), Weights::equal(), 0.0);
  auto fb = fitTrajectory(t, sample(b, t, 2), Weights::equal(), 0.0);
  ASSERT_TRUE(fa.ok() && fb.ok());
  for (auto side : {CollisionSide::kBefore, CollisionSide::kAfter}) {
    auto hit = collisionInstant(*fa, *fb, 0.0254, side);
    ASSERT_FALSE(hit.ok());
    EXPECT_THAT(hit.error().message, HasSubstr("never"));
  }
  EXPECT_FALSE(collisionInstant(*fa, *fb, -0.01, CollisionSide::kBefore).ok());
}

// The propagated uncertainty of the contact instant covers the truth ~68 % of
// the time when both pre-impact tracks carry known noise.
TEST(CollisionInstant, UncertaintyCoverageOverSeeds) {
  const Ballistic a{{-0.03, 0.1, 0.0}, {2.0, 0.3, 0.0}, kGravity_m_s2};
  const Ballistic b{{0.03, 0.095, 0.0}, {-1.8, 0.6, 0.0}, kGravity_m_s2};
  const double d = 0.0254;
  const Vec3 d0 = a.r0 - b.r0, dv = a.v0 - b.v0;
  const double bq = d0.dot(dv);
  const double t_true =
      (-bq - std::sqrt(bq * bq - dv.squaredNorm() * (d0.squaredNorm() - d * d))) / dv.squaredNorm();
  const Eigen::VectorXd t = frameTimes(8, t_true - 8.6e-3, 1e-3);
  const double sigma_m = 1e-4;
  const Weights w = Weights::fromSigmas(Eigen::VectorXd::Constant(t.size(), sigma_m));
  int covered = 0;
  const int trials = 400;
  for (int seed = 0; seed < trials; ++seed) {
    std::mt19937 rng(5000 + seed);
    auto fa = fitTrajectory(t, sample(a, t, 2, &rng, sigma_m), w, t_true);
    auto fb = fitTrajectory(t, sample(b, t, 2, &rng, sigma_m), w, t_true);
    ASSERT_TRUE(fa.ok() && fb.ok());
    auto hit = collisionInstant(*fa, *fb, d, CollisionSide::kBefore);
    ASSERT_TRUE(hit.ok()) << hit.error().message;
    ASSERT_GT(hit->sigma_s, 0.0);
    if (std::abs(hit->t_s - t_true) <= hit->sigma_s) ++covered;
  }
  EXPECT_GE(covered, 0.60 * trials);
  EXPECT_LE(covered, 0.76 * trials);
}
