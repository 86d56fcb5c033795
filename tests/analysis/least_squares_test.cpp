#include "analysis/least_squares.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace collide;
using ::testing::HasSubstr;

namespace {

Eigen::MatrixXd lineDesign(const Eigen::VectorXd& x) {
  Eigen::MatrixXd a(x.size(), 2);
  a.col(0).setOnes();
  a.col(1) = x;
  return a;
}

}  // namespace

TEST(LeastSquares, RecoversNoiseFreeCubicExactly) {
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(9, -2.0, 3.0);
  Eigen::MatrixXd a(9, 4);
  Eigen::VectorXd y(9);
  for (int i = 0; i < 9; ++i) {
    a.row(i) << 1, x[i], x[i] * x[i], x[i] * x[i] * x[i];
    y[i] = 0.5 - 1.25 * x[i] + 2.0 * x[i] * x[i] - 0.75 * x[i] * x[i] * x[i];
  }
  auto fit = weightedLeastSquares(a, y, Weights::equal());
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_NEAR(fit->coefficients[0], 0.5, 1e-12);
  EXPECT_NEAR(fit->coefficients[1], -1.25, 1e-12);
  EXPECT_NEAR(fit->coefficients[2], 2.0, 1e-12);
  EXPECT_NEAR(fit->coefficients[3], -0.75, 1e-12);
  EXPECT_EQ(fit->dof, 5);
  EXPECT_LT(fit->residualRms(), 1e-12);
}

// Mean of {1, 2, 3}: c = 2, residuals (-1, 0, 1), chi^2 = 2, dof = 2; with
// relative weights the variance of the mean is s^2/N = 1/3.
TEST(LeastSquares, ConstantModelByHand) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Ones(3, 1);
  Eigen::VectorXd y(3);
  y << 1, 2, 3;
  auto fit = weightedLeastSquares(a, y, Weights::equal());
  ASSERT_TRUE(fit.ok());
  EXPECT_NEAR(fit->coefficients[0], 2.0, 1e-14);
  EXPECT_NEAR(fit->residuals[0], -1.0, 1e-14);
  EXPECT_NEAR(fit->residuals[2], 1.0, 1e-14);
  EXPECT_NEAR(fit->chi2, 2.0, 1e-14);
  EXPECT_EQ(fit->dof, 2);
  EXPECT_NEAR(fit->reducedChi2(), 1.0, 1e-14);
  EXPECT_NEAR(fit->covariance(0, 0), 1.0 / 3.0, 1e-14);
  EXPECT_NEAR(fit->residualRms(), std::sqrt(2.0 / 3.0), 1e-14);

  // Known sigma 0.5 for every point: variance of the mean sigma^2/N, residuals ignored.
  auto abs_fit = weightedLeastSquares(a, y, Weights::fromSigmas(Eigen::VectorXd::Constant(3, 0.5)));
  ASSERT_TRUE(abs_fit.ok());
  EXPECT_NEAR(abs_fit->covariance(0, 0), 0.25 / 3.0, 1e-14);
  EXPECT_NEAR(abs_fit->chi2, 2.0 / 0.25, 1e-12);
}

// Weighted mean of {0, 10} with weights {3, 1} is 2.5 (by hand).
TEST(LeastSquares, WeightsPullTheFit) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Ones(2, 1);
  Eigen::VectorXd y(2);
  y << 0, 10;
  Eigen::VectorXd w(2);
  w << 3, 1;
  auto fit = weightedLeastSquares(a, y, Weights::relative(w));
  ASSERT_TRUE(fit.ok());
  EXPECT_NEAR(fit->coefficients[0], 2.5, 1e-14);
}

// Textbook straight-line fit with equal known sigma:
//   var(b) = sigma^2 / Sxx, var(a) = sigma^2 sum x^2 / (N Sxx), cov(a,b) = -sigma^2 xbar / Sxx.
TEST(LeastSquares, LineCovarianceMatchesTextbookFormula) {
  Eigen::VectorXd x(5);
  x << 1, 2, 4, 7, 11;
  Eigen::VectorXd y(5);
  y << 2.1, 2.9, 5.2, 7.8, 12.1;
  const double sigma = 0.3;
  auto fit = weightedLeastSquares(lineDesign(x), y,
                                  Weights::fromSigmas(Eigen::VectorXd::Constant(5, sigma)));
  ASSERT_TRUE(fit.ok());
  const double n = 5, xbar = x.mean();
  const double sxx = (x.array() - xbar).square().sum();
  const double s2 = sigma * sigma;
  EXPECT_NEAR(fit->covariance(1, 1), s2 / sxx, 1e-14);
  EXPECT_NEAR(fit->covariance(0, 0), s2 * x.squaredNorm() / (n * sxx), 1e-14);
  EXPECT_NEAR(fit->covariance(0, 1), -s2 * xbar / sxx, 1e-14);
  const double b = ((x.array() - xbar) * (y.array() - y.mean())).sum() / sxx;
  EXPECT_NEAR(fit->coefficients[1], b, 1e-13);
  EXPECT_NEAR(fit->coefficients[0], y.mean() - b * xbar, 1e-13);
}

// Relative weights: multiplying every weight by a constant changes nothing.
// Absolute weights: it scales the covariance by the inverse constant.
TEST(LeastSquares, RelativeWeightsAreScaleFreeAbsoluteAreNot) {
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(6, 0, 5);
  Eigen::VectorXd y(6);
  y << 0.1, 1.2, 1.9, 3.2, 3.9, 5.1;
  Eigen::VectorXd w(6);
  w << 1, 2, 1, 3, 1, 2;
  auto r1 = weightedLeastSquares(lineDesign(x), y, Weights::relative(w));
  auto r2 = weightedLeastSquares(lineDesign(x), y, Weights::relative(100.0 * w));
  ASSERT_TRUE(r1.ok() && r2.ok());
  EXPECT_NEAR(r1->covariance(1, 1), r2->covariance(1, 1), 1e-12 * r1->covariance(1, 1));
  auto a1 = weightedLeastSquares(lineDesign(x), y, {w, WeightKind::kInverseVariance});
  auto a2 = weightedLeastSquares(lineDesign(x), y, {100.0 * w, WeightKind::kInverseVariance});
  ASSERT_TRUE(a1.ok() && a2.ok());
  EXPECT_NEAR(a2->covariance(1, 1), a1->covariance(1, 1) / 100.0, 1e-12 * a1->covariance(1, 1));
}

TEST(LeastSquares, ExactlyDeterminedRelativeFitHasUnknownCovariance) {
  Eigen::VectorXd x(2);
  x << 0, 1;
  Eigen::VectorXd y(2);
  y << 1, 3;
  auto fit = weightedLeastSquares(lineDesign(x), y, Weights::equal());
  ASSERT_TRUE(fit.ok());
  EXPECT_EQ(fit->dof, 0);
  EXPECT_TRUE(std::isnan(fit->covariance(1, 1)));
  EXPECT_NEAR(fit->coefficients[1], 2.0, 1e-14);
}

// Widely different column scales (t in milliseconds, t^2 ~ 1e-6) must not lose the answer.
TEST(LeastSquares, IllScaledColumnsStillExact) {
  Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(8, 0.0, 7e-3);
  Eigen::MatrixXd a(8, 3);
  Eigen::VectorXd y(8);
  for (int i = 0; i < 8; ++i) {
    a.row(i) << 1, t[i], t[i] * t[i];
    y[i] = 0.2 + 3.0 * t[i] - 4.903325 * t[i] * t[i];
  }
  auto fit = weightedLeastSquares(a, y, Weights::equal());
  ASSERT_TRUE(fit.ok());
  EXPECT_NEAR(fit->coefficients[1], 3.0, 1e-9);
  EXPECT_NEAR(fit->coefficients[2], -4.903325, 1e-6);
}

TEST(LeastSquares, ZeroWeightPointIsIgnored) {
  Eigen::VectorXd x(4);
  x << 0, 1, 2, 3;
  Eigen::VectorXd y(4);
  y << 1, 3, 5, 1000;
  Eigen::VectorXd w(4);
  w << 1, 1, 1, 0;
  auto fit = weightedLeastSquares(lineDesign(x), y, Weights::relative(w));
  ASSERT_TRUE(fit.ok());
  EXPECT_NEAR(fit->coefficients[1], 2.0, 1e-12);
  EXPECT_EQ(fit->dof, 1);
  EXPECT_LT(fit->residualRms(), 1e-12);  // the dropped point does not count
}

TEST(LeastSquares, ErrorsNameTheDataAndTheFix) {
  Eigen::VectorXd x(3);
  x << 2, 2, 2;
  Eigen::VectorXd y(3);
  y << 1, 2, 3;
  auto degenerate = weightedLeastSquares(lineDesign(x), y, Weights::equal(), "exit speeds");
  ASSERT_FALSE(degenerate.ok());
  EXPECT_THAT(degenerate.error().message, HasSubstr("exit speeds"));
  EXPECT_THAT(degenerate.error().message, HasSubstr("spread"));

  auto too_few = weightedLeastSquares(lineDesign(x.head(1)), y.head(1), Weights::equal());
  ASSERT_FALSE(too_few.ok());
  EXPECT_THAT(too_few.error().message, HasSubstr("at least 2"));

  Eigen::VectorXd bad = y;
  bad[1] = std::nan("");
  EXPECT_FALSE(
      weightedLeastSquares(lineDesign(Eigen::VectorXd::LinSpaced(3, 0, 2)), bad, Weights::equal())
          .ok());
  EXPECT_FALSE(weightedLeastSquares(lineDesign(Eigen::VectorXd::LinSpaced(3, 0, 2)), y,
                                    Weights::fromSigmas(Eigen::Vector3d(0.1, 0.0, 0.1)))
                   .ok());
  EXPECT_FALSE(weightedLeastSquares(lineDesign(Eigen::VectorXd::LinSpaced(3, 0, 2)), y,
                                    Weights::relative(Eigen::Vector3d(1, -1, 1)))
                   .ok());
  EXPECT_FALSE(weightedLeastSquares(lineDesign(Eigen::VectorXd::LinSpaced(3, 0, 2)), y.head(2),
                                    Weights::equal())
                   .ok());
}

// With known Gaussian noise the reported 1-sigma interval on the slope covers
// the truth ~68.3 % of the time; 400 trials put 60..76 % beyond 3 standard errors.
TEST(LeastSquares, SlopeCoverageOverSeeds) {
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(10, 0, 9);
  const double sigma = 0.2;
  int covered_abs = 0, covered_rel = 0;
  const int trials = 400;
  for (int seed = 0; seed < trials; ++seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    Eigen::VectorXd y(10);
    for (int i = 0; i < 10; ++i) y[i] = 1.0 + 0.5 * x[i] + noise(rng);
    auto abs_fit = weightedLeastSquares(lineDesign(x), y,
                                        Weights::fromSigmas(Eigen::VectorXd::Constant(10, sigma)));
    auto rel_fit = weightedLeastSquares(lineDesign(x), y, Weights::equal());
    ASSERT_TRUE(abs_fit.ok() && rel_fit.ok());
    if (std::abs(abs_fit->coefficients[1] - 0.5) <= abs_fit->sigma(1)) ++covered_abs;
    if (std::abs(rel_fit->coefficients[1] - 0.5) <= rel_fit->sigma(1)) ++covered_rel;
  }
  EXPECT_GE(covered_abs, 0.60 * trials);
  EXPECT_LE(covered_abs, 0.76 * trials);
  // Student t with 8 dof: P(|T| <= 1) = 0.653.
  EXPECT_GE(covered_rel, 0.57 * trials);
  EXPECT_LE(covered_rel, 0.73 * trials);
}
