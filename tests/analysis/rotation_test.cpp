#include "analysis/rotation.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace collide;
using ::testing::HasSubstr;

namespace {

constexpr double kRadius_m = 0.0127;  // 2.54 cm sphere

// n dots spread over the sphere's visible hemisphere (z > 0, towards the camera).
Eigen::Matrix3Xd dotsOnSphere(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    Vec3 v(g(rng), g(rng), std::abs(g(rng)) + 0.3);
    p.col(i) = kRadius_m * v.normalized();
  }
  return p;
}

Eigen::Matrix3d rotationFromVector(const Vec3& rv) {
  const double angle = rv.norm();
  if (angle == 0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rv / angle).toRotationMatrix();
}

}  // namespace

TEST(Rotation, RecoversKnownRotationExactly) {
  const Vec3 truth(0.12, -0.35, 0.8);
  const Eigen::Matrix3Xd from = dotsOnSphere(6, 1);
  const Eigen::Matrix3Xd to = rotationFromVector(truth) * from;
  auto fit = fitRotation(from, to);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_LT((fit->rotation_vector_rad - truth).norm(), 1e-12);
  EXPECT_LT((fit->rotation - rotationFromVector(truth)).norm(), 1e-12);
  EXPECT_LT(fit->residual_rms_m, 1e-15);
  EXPECT_EQ(fit->points, 6);
}

TEST(Rotation, TwoDotsOffOneLineFixTheRotation) {
  const Vec3 truth(0.0, 0.0, 0.05);  // mostly in-plane spin, as in the thesis
  const Eigen::Matrix3Xd from = dotsOnSphere(2, 7);
  auto fit = fitRotation(from, rotationFromVector(truth) * from);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_LT((fit->rotation_vector_rad - truth).norm(), 1e-12);
}

TEST(Rotation, LargeAngleNearPi) {
  const Vec3 truth = 3.1 * Vec3(1, 2, -0.5).normalized();
  const Eigen::Matrix3Xd from = dotsOnSphere(5, 3);
  auto fit = fitRotation(from, rotationFromVector(truth) * from);
  ASSERT_TRUE(fit.ok());
  EXPECT_LT((fit->rotation_vector_rad - truth).norm(), 1e-9);
}

TEST(Rotation, NeverReturnsAReflection) {
  // Mirror images (z -> -z) are best matched by a reflection; the fit must
  // still return a proper rotation.
  const Eigen::Matrix3Xd from = dotsOnSphere(6, 11);
  const Eigen::Matrix3Xd to = Eigen::Vector3d(1, 1, -1).asDiagonal() * from;
  auto fit = fitRotation(from, to);
  ASSERT_TRUE(fit.ok());
  EXPECT_NEAR(fit->rotation.determinant(), 1.0, 1e-12);
  EXPECT_LT((fit->rotation.transpose() * fit->rotation - Eigen::Matrix3d::Identity()).norm(),
            1e-12);
  EXPECT_GT(fit->residual_rms_m, 1e-4);  // a rotation cannot mirror the dots
}

TEST(Rotation, TinyWeightOutlierDoesNotMatter) {
  const Vec3 truth(0.1, 0.2, -0.3);
  Eigen::Matrix3Xd from = dotsOnSphere(6, 21);
  Eigen::Matrix3Xd to = rotationFromVector(truth) * from;
  to.col(4) = rotationFromVector(Vec3(1.5, 0.0, 0.0)) * to.col(4);  // a gross mismatch
  Eigen::VectorXd w = Eigen::VectorXd::Ones(6);
  w[4] = 1e-12;
  auto weighted = fitRotation(from, to, w);
  auto unweighted = fitRotation(from, to);
  ASSERT_TRUE(weighted.ok() && unweighted.ok());
  EXPECT_LT((weighted->rotation_vector_rad - truth).norm(), 1e-9);
  EXPECT_GT((unweighted->rotation_vector_rad - truth).norm(), 1e-2);  // the weight is what saved it
}

// With isotropic noise on the dots the estimate scatters around the truth:
// the mean over 400 seeds is within 4 standard errors of it, per component.
TEST(Rotation, UnbiasedWithNoise) {
  const Vec3 truth(0.02, -0.05, 0.3);
  const double sigma_m = 2e-4;
  const int trials = 400;
  Vec3 sum = Vec3::Zero(), sum2 = Vec3::Zero();
  for (int seed = 0; seed < trials; ++seed) {
    const Eigen::Matrix3Xd from = dotsOnSphere(8, 100 + seed);
    Eigen::Matrix3Xd to = rotationFromVector(truth) * from;
    std::mt19937 rng(9000 + seed);
    std::normal_distribution<double> noise(0.0, sigma_m);
    Eigen::Matrix3Xd noisy_from = from;
    for (int i = 0; i < to.size(); ++i) {
      to.data()[i] += noise(rng);
      noisy_from.data()[i] += noise(rng);
    }
    auto fit = fitRotation(noisy_from, to);
    ASSERT_TRUE(fit.ok());
    sum += fit->rotation_vector_rad;
    sum2 += fit->rotation_vector_rad.cwiseAbs2();
  }
  const Vec3 mean = sum / trials;
  const Vec3 sd = (sum2 / trials - mean.cwiseAbs2()).cwiseSqrt();
  for (int k = 0; k < 3; ++k) {
    EXPECT_GT(sd[k], 0.0);
    EXPECT_LT(std::abs(mean[k] - truth[k]), 4.0 * sd[k] / std::sqrt(double(trials))) << k;
  }
}

TEST(Rotation, DegenerateInputsAreErrors) {
  const Eigen::Matrix3Xd one = dotsOnSphere(1, 5);
  auto single = fitRotation(one, one);
  ASSERT_FALSE(single.ok());
  EXPECT_THAT(single.error().message, HasSubstr("at least 2"));

  Eigen::Matrix3Xd line(3, 3);
  line.col(0) = Vec3(1, 2, 3) * 1e-3;
  line.col(1) = -2.0 * line.col(0);
  line.col(2) = 0.5 * line.col(0);
  auto collinear = fitRotation(line, line);
  ASSERT_FALSE(collinear.ok());
  EXPECT_THAT(collinear.error().message, HasSubstr("one line"));

  const Eigen::Matrix3Xd four = dotsOnSphere(4, 6);
  EXPECT_FALSE(fitRotation(four, dotsOnSphere(3, 6)).ok());
  Eigen::Matrix3Xd bad = four;
  bad(1, 2) = std::nan("");
  EXPECT_FALSE(fitRotation(four, bad).ok());
  EXPECT_FALSE(fitRotation(four, four, Eigen::Vector4d(1, 1, -1, 1)).ok());
  EXPECT_FALSE(fitRotation(four, four, Eigen::Vector4d(1, 0, 0, 0)).ok());  // one usable dot
}

// Dots spun at a constant rate: every frame pair, with equal or unequal
// spacing (a dropped frame), gives the same angular velocity, and so does the mean.
TEST(Spin, ConstantRateSequenceGivesTheTrueSpin) {
  const Vec3 omega_rad_s(3.0, -5.0, 40.0);
  const Eigen::Matrix3Xd body = dotsOnSphere(7, 31);
  const std::vector<double> t_s{0.0, 1e-3, 2e-3, 4e-3, 5e-3, 6e-3};
  std::vector<InterFrameRotation> pairs;
  for (size_t i = 0; i + 1 < t_s.size(); ++i) {
    const Eigen::Matrix3Xd a = rotationFromVector(omega_rad_s * t_s[i]) * body;
    const Eigen::Matrix3Xd b = rotationFromVector(omega_rad_s * t_s[i + 1]) * body;
    auto fit = fitRotation(a, b);
    ASSERT_TRUE(fit.ok());
    pairs.push_back({fit->rotation_vector_rad, t_s[i + 1] - t_s[i]});
    EXPECT_LT((pairs.back().angularVelocity_rad_s() - omega_rad_s).norm(), 1e-9);
  }
  auto spin = spinFromRotations(pairs);
  ASSERT_TRUE(spin.ok()) << spin.error().message;
  EXPECT_LT((spin->spin_rad_s - omega_rad_s).norm(), 1e-9);
  EXPECT_NEAR(spin->rate_rad_s, omega_rad_s.norm(), 1e-9);
  EXPECT_LT(spin->sigma_rad_s.maxCoeff(), 1e-9);
  EXPECT_EQ(spin->pairs, 5);
}

// By hand: angular velocities (1,0,0), (2,0,0), (3,0,0) rad/s -> mean 2,
// standard error s/sqrt(N) = 1/sqrt(3). Weights 1, 1, 2 -> mean 9/4.
TEST(Spin, MeanAndStandardErrorByHand) {
  std::vector<InterFrameRotation> pairs{
      {Vec3(1e-3, 0, 0), 1e-3}, {Vec3(4e-3, 0, 0), 2e-3}, {Vec3(3e-3, 0, 0), 1e-3}};
  auto spin = spinFromRotations(pairs);
  ASSERT_TRUE(spin.ok());
  EXPECT_NEAR(spin->spin_rad_s.x(), 2.0, 1e-12);
  EXPECT_NEAR(spin->sigma_rad_s.x(), 1.0 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(spin->rate_sigma_rad_s, 1.0 / std::sqrt(3.0), 1e-12);
  EXPECT_EQ(spin->sigma_rad_s.y(), 0.0);

  pairs[2].weight = 2.0;
  auto weighted = spinFromRotations(pairs);
  ASSERT_TRUE(weighted.ok());
  EXPECT_NEAR(weighted->spin_rad_s.x(), 9.0 / 4.0, 1e-12);

  auto single = spinFromRotations({pairs[0]});
  ASSERT_TRUE(single.ok());
  EXPECT_NEAR(single->spin_rad_s.x(), 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(single->sigma_rad_s.x()));
}

// Independent pairs with Gaussian scatter: the 1-sigma standard error covers
// the true spin as Student's t with 9 dof does, P(|T| <= 1) = 0.657.
TEST(Spin, StandardErrorCoverageOverSeeds) {
  const Vec3 omega(2.0, -1.0, 30.0);
  const double sd_rad_s = 1.5;
  const int trials = 400;
  int covered = 0;
  for (int seed = 0; seed < trials; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, sd_rad_s);
    std::vector<InterFrameRotation> pairs;
    for (int i = 0; i < 10; ++i)
      pairs.push_back({(omega + Vec3(noise(rng), noise(rng), noise(rng))) * 1e-3, 1e-3});
    auto spin = spinFromRotations(pairs);
    ASSERT_TRUE(spin.ok());
    if (std::abs(spin->spin_rad_s.z() - omega.z()) <= spin->sigma_rad_s.z()) ++covered;
  }
  EXPECT_GE(covered, 0.57 * trials);
  EXPECT_LE(covered, 0.74 * trials);
}

TEST(Spin, ErrorsSayWhatIsWrong) {
  EXPECT_FALSE(spinFromRotations({}).ok());
  auto zero_dt = spinFromRotations({{Vec3(1e-3, 0, 0), 0.0}});
  ASSERT_FALSE(zero_dt.ok());
  EXPECT_THAT(zero_dt.error().message, HasSubstr("pair 0"));
  EXPECT_FALSE(spinFromRotations({{Vec3(NAN, 0, 0), 1e-3}}).ok());
  EXPECT_FALSE(spinFromRotations({{Vec3(1e-3, 0, 0), 1e-3, -1.0}}).ok());
  EXPECT_FALSE(spinFromRotations({{Vec3(1e-3, 0, 0), 1e-3, 0.0}}).ok());
}
