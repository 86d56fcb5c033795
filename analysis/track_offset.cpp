#include "analysis/track_offset.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

namespace collide {
namespace {

// The median of a chi-square of one degree of freedom.
constexpr double kChi2OneMedian = 0.454936423119572;

struct Gap {
  double g2, var, k2;  // gap^2 (s^2), its drawn variance (s^2), per px^2 (s^2/px^2)
};

// The median of the squared pulls at a further offset variance s.
double medianPull2(const std::vector<Gap>& gaps, double s, std::vector<double>& work) {
  work.resize(gaps.size());
  for (std::size_t i = 0; i < gaps.size(); ++i)
    work[i] = gaps[i].g2 / std::max(gaps[i].var + gaps[i].k2 * s, 1e-300);
  const auto mid = work.begin() + static_cast<std::ptrdiff_t>(work.size() / 2);
  std::nth_element(work.begin(), mid, work.end());
  if (work.size() % 2 == 1) return *mid;
  return 0.5 * (*mid + *std::max_element(work.begin(), mid));
}

// The s at which the median squared pull is kChi2OneMedian: it falls as s
// grows, so bisection; s stays above -min(var / k2), where a shot's variance
// would vanish (the estimate stops there when even that is not enough).
double solveExcess(const std::vector<Gap>& gaps, std::vector<double>& work) {
  double lo = std::numeric_limits<double>::infinity(), scale = 0;
  for (const Gap& g : gaps) {
    lo = std::min(lo, g.var / g.k2);
    scale = std::max(scale, g.var / g.k2);
  }
  lo = -lo * (1 - 1e-9);
  if (medianPull2(gaps, lo, work) <= kChi2OneMedian) return lo;
  double hi = std::max(scale, 1e-12);
  for (int i = 0; i < 200 && medianPull2(gaps, hi, work) > kChi2OneMedian; ++i) hi *= 4;
  for (int i = 0; i < 100 && hi - lo > 1e-9 * std::max(std::abs(hi), 1e-300); ++i) {
    const double mid = 0.5 * (lo + hi);
    (medianPull2(gaps, mid, work) > kChi2OneMedian ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

bool KinkGap::usable() const {
  return std::isfinite(gap_s) && std::isfinite(sigma_s) && std::isfinite(var_per_px2) &&
         sigma_s > 0 && var_per_px2 > 0;
}

double TrackOffsetExcess::excessPx() const {
  return std::copysign(std::sqrt(std::abs(excess_px2)), excess_px2);
}

double TrackOffsetExcess::suggestedPx(double stated_px) const {
  return std::sqrt(std::max(0.0, stated_px * stated_px + excess_px2));
}

Result<TrackOffsetExcess> trackOffsetFromKinkGaps(const std::vector<KinkGap>& in, int resamples,
                                                  std::uint64_t seed) {
  if (resamples < 0) return fail("the bootstrap's resamples must be 0 or more");
  std::vector<Gap> gaps;
  double pull2 = 0;
  for (const KinkGap& k : in) {
    if (!k.usable()) continue;
    gaps.push_back({k.gap_s * k.gap_s, k.sigma_s * k.sigma_s, k.var_per_px2});
    pull2 += gaps.back().g2 / gaps.back().var;
  }
  const int n = static_cast<int>(gaps.size());
  if (n < 5)
    return fail(
        "the tracks' centre offset needs at least 5 shots whose both spheres' tracks "
        "bend at the impact (got " +
        std::to_string(n) + "): analyse more shots");
  std::vector<double> work;
  TrackOffsetExcess out;
  out.shots = n;
  out.pull_rms = std::sqrt(pull2 / n);
  out.excess_px2 = solveExcess(gaps, work);
  if (resamples > 1) {
    std::mt19937_64 rng(seed);
    std::uniform_int_distribution<int> pick(0, n - 1);
    std::vector<Gap> sample(gaps.size());
    double sum = 0, sum2 = 0;
    for (int r = 0; r < resamples; ++r) {
      for (Gap& g : sample) g = gaps[pick(rng)];
      const double s = solveExcess(sample, work);
      sum += s, sum2 += s * s;
    }
    const double mean = sum / resamples;
    out.sigma_px2 = std::sqrt(std::max(0.0, (sum2 - resamples * mean * mean) / (resamples - 1)));
  }
  return out;
}

}  // namespace collide
