// The centre offset per track from the kinks' gaps, against gaps drawn from
// the model the estimator assumes: each shot's gap is Gaussian of variance
// (its drawn sigma)^2 + k^2 (the offset's variance it was not drawn with),
// the shots' sigmas and sensitivities spread as a lab's are (sigmas of 2-20
// us, 3-30 us per px of offset).
#include "analysis/track_offset.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace collide {
namespace {

// n shots whose tracks carry an offset of `true_px` per axis, analysed with
// `drawn_px` (its variance in each shot's sigma), plus a few shots whose
// kinks err for another reason (`wild`, at 30 of their sigmas).
std::vector<KinkGap> drawGaps(int n, double true_px, double drawn_px, std::mt19937_64& rng,
                              int wild = 0) {
  std::normal_distribution<double> unit(0, 1);
  std::uniform_real_distribution<double> fit_sigma(2e-6, 20e-6), per_px(3e-6 / 0.01, 30e-6 / 0.01);
  std::vector<KinkGap> out;
  for (int i = 0; i < n; ++i) {
    const double fit = fit_sigma(rng), k = per_px(rng);
    KinkGap g;
    g.var_per_px2 = 2 * k * k;
    g.sigma_s = std::sqrt(fit * fit + g.var_per_px2 * drawn_px * drawn_px);
    g.gap_s = std::sqrt(fit * fit + g.var_per_px2 * true_px * true_px) * unit(rng);
    if (i < wild) g.gap_s = 30 * g.sigma_s;
    out.push_back(g);
  }
  return out;
}

TEST(TrackOffsetFromKinkGaps, RecoversAnOffsetTheAnalysisDidNotDraw) {
  std::mt19937_64 rng(4);
  const auto gaps = drawGaps(400, 0.02, 0.0, rng);
  const auto r = trackOffsetFromKinkGaps(gaps);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->shots, 400);
  EXPECT_GT(r->pull_rms, 1.5);  // the drawn sigmas fall short
  EXPECT_GT(r->sigma_px2, 0);
  EXPECT_NEAR(r->excess_px2, 0.02 * 0.02, 3 * r->sigma_px2);
  EXPECT_LT(r->sigma_px2, 0.3 * 0.02 * 0.02);  // 400 shots measure it
  EXPECT_NEAR(r->suggestedPx(0.0), 0.02, 0.004);
  EXPECT_GT(r->excessPx(), 0);
}

TEST(TrackOffsetFromKinkGaps, FindsNoExcessWhereTheAnalysisDrewTheOffset) {
  std::mt19937_64 rng(5);
  const auto r = trackOffsetFromKinkGaps(drawGaps(400, 0.02, 0.02, rng));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_NEAR(r->pull_rms, 1.0, 0.15);
  EXPECT_NEAR(r->excess_px2, 0.0, 3 * r->sigma_px2);
  EXPECT_NEAR(r->suggestedPx(0.02), 0.02, 0.004);
}

TEST(TrackOffsetFromKinkGaps, AnOffsetDrawnTooLargeComesOutNegative) {
  std::mt19937_64 rng(6);
  const auto r = trackOffsetFromKinkGaps(drawGaps(400, 0.02, 0.05, rng));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_LT(r->pull_rms, 0.8);
  EXPECT_LT(r->excess_px2, -3 * r->sigma_px2);
  EXPECT_LT(r->excessPx(), 0);
  EXPECT_NEAR(r->excess_px2, 0.02 * 0.02 - 0.05 * 0.05, 3 * r->sigma_px2);
  EXPECT_NEAR(r->suggestedPx(0.05), 0.02, 0.006);
}

// A few kinks that err for another reason (a merged outline, a bad frame)
// move the median little; they would dominate a mean of squared pulls.
TEST(TrackOffsetFromKinkGaps, AFewWildKinksDoNotCarryTheEstimate) {
  std::mt19937_64 rng(7);
  const auto r = trackOffsetFromKinkGaps(drawGaps(400, 0.02, 0.0, rng, /*wild=*/12));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_GT(r->pull_rms, 5.0);
  EXPECT_NEAR(r->suggestedPx(0.0), 0.02, 0.005);
}

TEST(TrackOffsetFromKinkGaps, NeedsFiveUsableShotsAndSaysSo) {
  std::mt19937_64 rng(8);
  auto gaps = drawGaps(6, 0.02, 0.0, rng);
  gaps[0].gap_s = std::nan("");  // a sphere whose velocity did not change
  gaps[1].sigma_s = 0;
  EXPECT_FALSE(gaps[0].usable());
  EXPECT_FALSE(gaps[1].usable());
  EXPECT_TRUE(gaps[2].usable());
  const auto r = trackOffsetFromKinkGaps(gaps);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("at least 5 shots"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("got 4"), std::string::npos) << r.error().message;
  gaps.push_back(drawGaps(1, 0.02, 0.0, rng)[0]);
  EXPECT_TRUE(trackOffsetFromKinkGaps(gaps));
  EXPECT_FALSE(trackOffsetFromKinkGaps(gaps, -1));
}

}  // namespace
}  // namespace collide
