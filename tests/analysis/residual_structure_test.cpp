#include "analysis/residual_structure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "tests/analysis/correlated_wander.hpp"

using namespace collide;

namespace {

// A free-flight axis as the shot analysis fits it: y = c0 + c1 t + c2 t^2 at
// n frames 1 ms apart, with per-frame sigmas `sigma` (weights 1 / sigma^2).
LinearFit fitParabola(const Eigen::VectorXd& y, const Eigen::VectorXd& sigma) {
  const Eigen::Index n = y.size();
  Eigen::MatrixXd a(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = 1e-3 * static_cast<double>(i);
    a.row(i) << 1, t, t * t;
  }
  auto fit = weightedLeastSquares(a, y, Weights::fromSigmas(sigma), "track");
  EXPECT_TRUE(fit.ok());
  return *fit;
}

Eigen::VectorXd track(int n) {
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    const double t = 1e-3 * i;
    y[i] = 100 + 9.6e3 * t - 0.5 * 9.81e3 * t * t;  // px, px/s, px/s^2
  }
  return y;
}

}  // namespace

// Independent scatter, however large, is not order: at the default z (1 in
// 1000 per test, two tests) about 0.2 % of such tracks are called structured.
TEST(ResidualStructure, IndependentScatterIsRarelyCalledStructured) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::uniform_real_distribution<double> spread(0.5, 3.0);
  const int tracks = 2000, n = 16;
  int structured = 0;
  double mean_r1 = 0;
  for (int k = 0; k < tracks; ++k) {
    Eigen::VectorXd y = track(n), sigma(n);
    for (int i = 0; i < n; ++i) {
      sigma[i] = 0.01 * spread(rng);  // the detector's stated sigma, px
      y[i] += 0.3 * unit(rng);        // actual scatter, 30 times larger on average
    }
    const LinearFit fit = fitParabola(y, sigma);
    structured += residualsStructured(fit);
    mean_r1 += residualLag1Correlation(fit) / tracks;
  }
  std::printf("%d of %d independent-scatter tracks called structured\n", structured, tracks);
  EXPECT_LT(structured, tracks / 100) << structured << " of " << tracks;
  EXPECT_NEAR(mean_r1, -1.0 / n, 0.1);
}

// A track that is not a parabola (a jerk the model lacks) leaves a smooth run
// of residuals: strongly positive r1.
TEST(ResidualStructure, ASmoothMisfitIsStructured) {
  std::mt19937_64 rng(12);
  std::normal_distribution<double> noise(0.0, 0.005);  // the detector's scatter, px
  const int n = 16;
  Eigen::VectorXd y = track(n), sigma = Eigen::VectorXd::Constant(n, 0.005);
  for (int i = 0; i < n; ++i) {
    const double t = 1e-3 * i;
    y[i] += 5e7 * t * t * t + noise(rng);  // 0.17 px at the end of the track
  }
  const LinearFit fit = fitParabola(y, sigma);
  EXPECT_GT(residualLag1Correlation(fit), 0.5);
  EXPECT_GT(residualTrendF(fit), 100.0);
  EXPECT_TRUE(residualsStructured(fit));
}

// Every other frame displaced by half a pixel (a shaking camera): r1 near -1.
TEST(ResidualStructure, AnAlternatingOffsetIsStructured) {
  std::mt19937_64 rng(13);
  std::normal_distribution<double> noise(0.0, 0.02);
  const int n = 16;
  Eigen::VectorXd y = track(n), sigma = Eigen::VectorXd::Constant(n, 0.02);
  for (int i = 0; i < n; ++i) y[i] += (i % 2 ? 0.5 : -0.5) + noise(rng);
  const LinearFit fit = fitParabola(y, sigma);
  EXPECT_LT(residualLag1Correlation(fit), -0.8);
  EXPECT_TRUE(residualsStructured(fit));
}

// Too few observations, or an exact fit: no verdict.
TEST(ResidualStructure, NoVerdictWithoutResiduals) {
  const int n = 3;
  const LinearFit exact = fitParabola(track(n), Eigen::VectorXd::Constant(n, 0.1));
  EXPECT_TRUE(std::isnan(residualLag1Correlation(exact)));
  EXPECT_TRUE(std::isnan(residualTrendF(exact)));
  EXPECT_FALSE(residualsStructured(exact));
  LinearFit two;
  two.residuals = Eigen::Vector2d(0.1, -0.1);
  two.dof = 5;  // whatever the fit claims, two residuals cannot show order
  two.weights = Eigen::Vector2d(1, 1);
  EXPECT_TRUE(std::isnan(residualLag1Correlation(two)));
}

namespace {

// n times 1 ms apart from 0.
Eigen::VectorXd frameTimes(int n) {
  Eigen::VectorXd t(n);
  for (int i = 0; i < n; ++i) t[i] = 1e-3 * i;
  return t;
}

}  // namespace

// The gains reproduce an exact parabola's coefficients (any reference
// instant), and give a sample of zero weight none.
TEST(QuadraticGains, RecoverAnExactParabola) {
  const Eigen::VectorXd t = frameTimes(15);
  Eigen::VectorXd w = Eigen::VectorXd::Ones(15);
  w[4] = 0;
  Eigen::VectorXd y(15);
  const double c0 = 0.02, c1 = 1.7, c2 = -9.8, t_ref = 3e-3;
  for (int i = 0; i < 15; ++i) {
    const double tau = t[i] - t_ref;
    y[i] = c0 + c1 * tau + 0.5 * c2 * tau * tau;
  }
  y[4] += 1.0;  // left out by its weight
  const auto g = quadraticGains(t, w, t_ref);
  ASSERT_EQ(g.cols(), 15);
  EXPECT_NEAR(g.row(0).dot(y), c0, 1e-12);
  EXPECT_NEAR(g.row(1).dot(y), c1, 1e-9);
  EXPECT_NEAR(g.row(2).dot(y), c2, 1e-6);
  for (int r = 0; r < 3; ++r) EXPECT_EQ(g(r, 4), 0.0);
  EXPECT_EQ(quadraticGains(t.head(2), w.head(2), 0).cols(), 0);
}

// wanderSigma against its limits and against a Monte Carlo of the wander.
TEST(WanderSigma, MatchesDrawnWanderAndItsLimits) {
  const Eigen::VectorXd t = frameTimes(20);
  const Eigen::VectorXd w = Eigen::VectorXd::Ones(20);
  const Eigen::VectorXd gv = quadraticGains(t, w, 0).row(1).transpose();
  const double rms = 5e-6;
  // Uncorrelated (a time far below the frame interval): independent noise.
  EXPECT_NEAR(wanderSigma(t, gv, rms, 1e-7), rms * gv.norm(), 1e-9 * rms * gv.norm());
  // Correlated over far longer than the track: a constant offset, which no
  // slope sees.
  EXPECT_LT(wanderSigma(t, gv, rms, 10.0), 1e-3 * rms * gv.norm());
  EXPECT_EQ(wanderSigma(t, gv, 0, 4e-3), 0.0);
  EXPECT_TRUE(std::isnan(wanderSigma(t.head(3), gv, rms, 4e-3)));
  // Drawn: the slope's spread over 20,000 wanders, within 3 % (the standard
  // error of a standard deviation from that many draws is 0.5 %).
  for (const double time_s : {2e-3, 4e-3, 8e-3}) {
    const collide::testing::CorrelatedWander wander(t, rms, time_s);
    std::mt19937 rng(11);
    double sum2 = 0;
    const int draws = 20000;
    for (int d = 0; d < draws; ++d) {
      const double slope = gv.dot(wander.draw(rng));
      sum2 += slope * slope;
    }
    const double drawn = std::sqrt(sum2 / draws);
    EXPECT_NEAR(wanderSigma(t, gv, rms, time_s), drawn, 0.03 * drawn) << "time " << time_s;
  }
}
