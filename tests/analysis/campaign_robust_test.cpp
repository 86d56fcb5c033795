// Robust campaign fits (issue 12): campaigns simulated from Walton's rule as
// docs/SPEC.md states it (written out here, independently of the fitting
// code), with a few wrong shots injected; the robust loss must recover the
// true material where least squares is pulled away.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "analysis/campaign.hpp"

using namespace collide;

namespace {

constexpr double kK = 0.4;
struct Truth {
  double mu, beta0, e;
};
constexpr Truth kNylon{0.176, 0.44, 0.97};

double waltonBeta(double v_n, double v_s, const Truth& m) {
  const double sliding = -1.0 - m.mu * (1.0 + 1.0 / kK) * (1.0 + m.e) * v_n / v_s;
  return std::min(sliding, m.beta0);
}

// 60 shots, incidence 10..80 degrees, Gaussian errors as stated.
std::vector<CampaignShot> campaign(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> angle(10 * std::numbers::pi / 180,
                                               80 * std::numbers::pi / 180);
  std::uniform_real_distribution<double> speed(1.0, 2.5), bsig(0.03, 0.06);
  std::normal_distribution<double> g;
  std::vector<CampaignShot> out;
  for (int i = 0; i < 60; ++i) {
    const double psi = angle(rng), v = speed(rng);
    const double v_n = -v * std::cos(psi), v_s = v * std::sin(psi);
    CampaignShot s;
    s.v_n_m_s = v_n + 0.02 * g(rng);
    s.v_s_m_s = v_s + 0.02 * g(rng);
    s.v_n_sigma_m_s = s.v_s_sigma_m_s = 0.02;
    s.beta_sigma = bsig(rng);
    s.beta = waltonBeta(v_n, v_s, kNylon) + s.beta_sigma * g(rng);
    s.e_sigma = 0.015;
    s.e = kNylon.e + 0.015 * g(rng);
    out.push_back(s);
  }
  return out;
}

// Wrong shots of the kinds seen in independent footage: beta far outside
// [-1, 1], e above 1, each with a small stated sigma. Returns their indices.
std::vector<std::size_t> injectOutliers(std::vector<CampaignShot>& shots) {
  const std::vector<std::size_t> bad = {3, 11, 19, 27, 35, 43};
  const double beta[] = {-2.68, 0.95, -2.2, 0.98, -2.5, 0.9};
  for (std::size_t k = 0; k < bad.size(); ++k) {
    CampaignShot& s = shots[bad[k]];
    s.beta = beta[k];
    s.beta_sigma = 0.03;
    s.e = 1.25;
    s.e_sigma = 0.01;
  }
  return bad;
}

FrictionOptions withLoss(RobustLoss loss) {
  FrictionOptions o;
  o.robust.loss = loss;
  return o;
}

TEST(CampaignRobust, RobustLossesRecoverTheMaterialDespiteOutliers) {
  int ls_off = 0;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    auto shots = campaign(seed);
    const auto bad = injectOutliers(shots);
    auto ls = fitCampaign(shots, withLoss(RobustLoss::LeastSquares));
    ASSERT_TRUE(ls.ok()) << ls.error().message;
    for (const RobustLoss loss : {RobustLoss::Huber, RobustLoss::Cauchy}) {
      auto r = fitCampaign(shots, withLoss(loss));
      ASSERT_TRUE(r.ok() && r->friction.ok());
      const FrictionFit& f = *r->friction;
      std::printf("seed %d %-8s mu %.4f +- %.4f  beta0 %.4f +- %.4f  e %.4f +- %.4f\n", int(seed),
                  robustLossName(loss).c_str(), f.mu.value, f.mu.sigma, f.beta0.value,
                  f.beta0.sigma, r->restitution.e.value, r->restitution.e.sigma);
      EXPECT_NEAR(f.mu.value, kNylon.mu, 3 * f.mu.sigma);
      EXPECT_NEAR(f.beta0.value, kNylon.beta0, 3 * f.beta0.sigma);
      EXPECT_NEAR(r->restitution.e.value, kNylon.e, 3 * r->restitution.e.sigma);
      // The injected shots are the ones set aside.
      for (const std::size_t i : bad) {
        EXPECT_LT(f.robust_weight[i], 0.25) << "shot " << i;
        EXPECT_LT(r->restitution.robust_weight[i], 0.25) << "shot " << i;
      }
      int full = 0;
      for (std::size_t i = 0; i < shots.size(); ++i) full += f.robust_weight[i] > 0.5;
      EXPECT_GE(full, int(shots.size() - bad.size()) - 6);
    }
    ASSERT_TRUE(ls->friction.ok()) << ls->friction.error().message;
    const FrictionFit& f = *ls->friction;
    std::printf("seed %d LS       mu %.4f +- %.4f  beta0 %.4f +- %.4f  e %.4f +- %.4f\n", int(seed),
                f.mu.value, f.mu.sigma, f.beta0.value, f.beta0.sigma, ls->restitution.e.value,
                ls->restitution.e.sigma);
    for (const double w : f.robust_weight) EXPECT_EQ(w, 1.0);
    // Least squares is pulled off the truth by more than its own sigma says.
    const bool off = std::abs(ls->restitution.e.value - kNylon.e) > 3 * ls->restitution.e.sigma ||
                     std::abs(f.beta0.value - kNylon.beta0) > 3 * f.beta0.sigma ||
                     std::abs(f.mu.value - kNylon.mu) > 3 * f.mu.sigma;
    ls_off += off;
  }
  EXPECT_EQ(ls_off, 5);
}

TEST(CampaignRobust, CleanCampaignsGiveWhatLeastSquaresGives) {
  for (std::uint64_t seed = 11; seed <= 15; ++seed) {
    const auto shots = campaign(seed);
    auto ls = fitCampaign(shots, withLoss(RobustLoss::LeastSquares));
    auto hu = fitCampaign(shots);  // Huber: the campaign default
    ASSERT_TRUE(ls.ok() && hu.ok() && ls->friction.ok() && hu->friction.ok());
    EXPECT_NEAR(hu->friction->mu.value, ls->friction->mu.value, 0.5 * ls->friction->mu.sigma);
    EXPECT_NEAR(hu->friction->beta0.value, ls->friction->beta0.value,
                0.5 * ls->friction->beta0.sigma);
    EXPECT_NEAR(hu->restitution.e.value, ls->restitution.e.value, 0.5 * ls->restitution.e.sigma);
    EXPECT_NEAR(hu->friction->mu.value, kNylon.mu, 4 * hu->friction->mu.sigma);
  }
}

TEST(CampaignRobust, WeightFunctions) {
  RobustOptions h{RobustLoss::Huber, 0}, c{RobustLoss::Cauchy, 0}, l{};
  EXPECT_EQ(robustWeight(5.0, l), 1.0);
  EXPECT_EQ(robustWeight(1.0, h), 1.0);
  EXPECT_NEAR(robustWeight(-2.69, h), 0.5, 1e-12);  // c / |z|, c = 1.345
  EXPECT_NEAR(robustWeight(2.385, c), 0.5, 1e-12);  // 1 / (1 + 1)
  EXPECT_NEAR(robustWeight(0.0, c), 1.0, 1e-12);
  RobustOptions h2{RobustLoss::Huber, 2.0};
  EXPECT_NEAR(robustWeight(4.0, h2), 0.5, 1e-12);
}

}  // namespace
