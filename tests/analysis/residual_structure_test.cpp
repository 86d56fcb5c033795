#include "analysis/residual_structure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

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
