#include "analysis/calibration.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace collide;
using ::testing::HasSubstr;

// v(p) = 0.143 + 6.6 x - 5 x^2 + 3.38 x^3, x = p/100, evaluated by hand.
TEST(LaunchCalibration, ThesisCubicAtKnownPressures) {
  const LaunchCalibration cal = LaunchCalibration::thesis();
  EXPECT_NEAR(cal.speed_m_s(100.0), 0.143 + 6.6 - 5.0 + 3.38, 1e-12);  // 5.123
  EXPECT_NEAR(cal.speed_m_s(50.0), 0.143 + 3.3 - 1.25 + 0.4225, 1e-12);
  EXPECT_NEAR(cal.speed_m_s(0.0), 0.143, 1e-15);
  EXPECT_NEAR(cal.speed_m_s(150.0), 0.143 + 9.9 - 11.25 + 11.4075, 1e-12);
  EXPECT_NEAR(cal.minSpeed_m_s(), 0.143 + 0.66 - 0.05 + 0.00338, 1e-12);
  EXPECT_EQ(cal.minPressure_kPa(), 10.0);
  EXPECT_EQ(cal.maxPressure_kPa(), 150.0);
}

TEST(LaunchCalibration, InverseRoundTripsOverTheRange) {
  const LaunchCalibration cal = LaunchCalibration::thesis();
  for (double p = 10.0; p <= 150.0; p += 0.7) {
    auto back = cal.pressure_kPa(cal.speed_m_s(p));
    ASSERT_TRUE(back.ok()) << p << ": " << back.error().message;
    EXPECT_NEAR(*back, p, 1e-9) << p;
  }
  auto at_100 = cal.pressure_kPa(5.123);
  ASSERT_TRUE(at_100.ok());
  EXPECT_NEAR(*at_100, 100.0, 1e-9);
  // The range ends themselves are in range.
  EXPECT_TRUE(cal.pressure_kPa(cal.minSpeed_m_s()).ok());
  EXPECT_TRUE(cal.pressure_kPa(cal.maxSpeed_m_s()).ok());
}

TEST(LaunchCalibration, OutOfRangeSpeedIsRefusedWithTheLimits) {
  const LaunchCalibration cal = LaunchCalibration::thesis();
  auto too_fast = cal.pressure_kPa(12.0);
  ASSERT_FALSE(too_fast.ok());
  const std::string& msg = too_fast.error().message;
  EXPECT_THAT(msg, HasSubstr("12.00 m/s"));
  EXPECT_THAT(msg, HasSubstr("0.76 .. 10.20 m/s"));
  EXPECT_THAT(msg, HasSubstr("10..150 kPa"));
  EXPECT_THAT(msg, HasSubstr("recalibrate"));
  EXPECT_FALSE(cal.pressure_kPa(0.5).ok());
  EXPECT_FALSE(cal.pressure_kPa(-1.0).ok());
  EXPECT_FALSE(cal.pressure_kPa(std::nan("")).ok());
}

TEST(LaunchCalibration, NonMonotonicCubicIsRejected) {
  // dv/dx = 1 - 4x turns negative past x = 0.25 (25 kPa).
  auto falling = LaunchCalibration::create({0.0, 1.0, -2.0, 0.0}, 10.0, 150.0);
  ASSERT_FALSE(falling.ok());
  EXPECT_THAT(falling.error().message, HasSubstr("does not increase"));
  EXPECT_TRUE(LaunchCalibration::create({0.0, 1.0, -2.0, 0.0}, 10.0, 20.0).ok());

  // Increasing at both ends but not in between: dv/dx = 1 - 6x + 6.6x^2 has
  // its minimum -0.364 at x = 0.4545 (45 kPa).
  auto dip = LaunchCalibration::create({0.0, 1.0, -3.0, 2.2}, 10.0, 150.0);
  ASSERT_FALSE(dip.ok());
  EXPECT_THAT(dip.error().message, HasSubstr("45.5 kPa"));

  EXPECT_FALSE(LaunchCalibration::create(LaunchCalibration::kThesisCoefficients, 150, 10).ok());
  EXPECT_FALSE(LaunchCalibration::create({NAN, 1, 0, 0}).ok());
}

TEST(LaunchCalibration, RefitOfExactSamplesRecoversTheCubic) {
  const LaunchCalibration truth = LaunchCalibration::thesis();
  Eigen::VectorXd p = Eigen::VectorXd::LinSpaced(8, 10.0, 150.0);
  Eigen::VectorXd v(8);
  for (int i = 0; i < 8; ++i) v[i] = truth.speed_m_s(p[i]);
  auto refit = refitLaunchCalibration(p, v);
  ASSERT_TRUE(refit.ok()) << refit.error().message;
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(refit->calibration.coefficients()[k], LaunchCalibration::kThesisCoefficients[k],
                1e-9);
  EXPECT_LT(refit->rms_m_s, 1e-12);
  EXPECT_EQ(refit->dof, 4);
}

// Speeds measured with a known 5 cm/s scatter at 12 pressures: each refitted
// coefficient, and the fitted speed at 100 kPa, lies within its reported
// 1-sigma ~68.3 % of the time over 400 seeds.
TEST(LaunchCalibration, NoisyRefitRecoversCubicWithinItsUncertainty) {
  const LaunchCalibration truth = LaunchCalibration::thesis();
  const Eigen::VectorXd p = Eigen::VectorXd::LinSpaced(12, 10.0, 150.0);
  const double sigma_m_s = 0.05;
  const Weights w = Weights::fromSigmas(Eigen::VectorXd::Constant(12, sigma_m_s));
  const int trials = 400;
  int covered[5] = {0, 0, 0, 0, 0};
  for (int seed = 0; seed < trials; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, sigma_m_s);
    Eigen::VectorXd v(12);
    for (int i = 0; i < 12; ++i) v[i] = truth.speed_m_s(p[i]) + noise(rng);
    auto refit = refitLaunchCalibration(p, v, w);
    ASSERT_TRUE(refit.ok()) << refit.error().message;
    for (int k = 0; k < 4; ++k) {
      const double err =
          refit->calibration.coefficients()[k] - LaunchCalibration::kThesisCoefficients[k];
      if (std::abs(err) <= std::sqrt(refit->covariance(k, k))) ++covered[k];
    }
    if (std::abs(refit->calibration.speed_m_s(100) - truth.speed_m_s(100)) <=
        refit->speedSigma_m_s(100))
      ++covered[4];
  }
  for (int k = 0; k < 5; ++k) {
    EXPECT_GE(covered[k], 0.60 * trials) << k;
    EXPECT_LE(covered[k], 0.76 * trials) << k;
  }
}

TEST(LaunchCalibration, RefitErrors) {
  const LaunchCalibration truth = LaunchCalibration::thesis();
  Eigen::VectorXd p4 = Eigen::VectorXd::LinSpaced(4, 10.0, 150.0);
  Eigen::VectorXd v4(4);
  for (int i = 0; i < 4; ++i) v4[i] = truth.speed_m_s(p4[i]);
  auto too_few = refitLaunchCalibration(p4, v4);
  ASSERT_FALSE(too_few.ok());
  EXPECT_THAT(too_few.error().message, HasSubstr("at least 5"));

  // Speeds that fall with pressure cannot be inverted.
  Eigen::VectorXd p = Eigen::VectorXd::LinSpaced(6, 10.0, 150.0);
  Eigen::VectorXd falling = 10.0 - 0.05 * p.array();
  auto bad = refitLaunchCalibration(p, falling);
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.error().message, HasSubstr("refit"));
  EXPECT_THAT(bad.error().message, HasSubstr("does not increase"));

  Eigen::VectorXd v6(6);
  for (int i = 0; i < 6; ++i) v6[i] = truth.speed_m_s(p[i]);
  v6[2] = std::nan("");
  EXPECT_FALSE(refitLaunchCalibration(p, v6).ok());
  // Five readings at only two pressures do not determine a cubic.
  Eigen::VectorXd two(5);
  two << 50, 50, 50, 100, 100;
  Eigen::VectorXd v_two(5);
  v_two << 2.6, 2.6, 2.6, 5.1, 5.1;
  EXPECT_FALSE(refitLaunchCalibration(two, v_two).ok());
}
