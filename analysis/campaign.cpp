#include "analysis/campaign.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>

#include "analysis/campaign_detail.hpp"

namespace collide {

using campaign_detail::birgeScale;
using campaign_detail::num;
using campaign_detail::robustScale;

double CampaignShot::cotIncidenceSigma() const {
  // x = -v_n/v_s: dx/dv_n = -1/v_s, dx/dv_s = v_n/v_s^2.
  const double a = v_n_sigma_m_s / v_s_m_s;
  const double b = v_n_m_s * v_s_sigma_m_s / (v_s_m_s * v_s_m_s);
  return std::hypot(a, b);
}

double CampaignShot::incidenceAngle_rad() const {
  return std::atan2(v_s_m_s, -v_n_m_s);
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kRadToDeg = 180.0 / std::numbers::pi;

double standardNormalCdf(double z) {
  return 0.5 * std::erfc(-z / std::numbers::sqrt2);
}

// Best weighted least-squares fit of y = min(c, s x) to points sorted by x.
// With y = beta + 1 this is Walton's beta = min(beta0, -1 + s x), c = 1 + beta0.
//
// Why exhaustive and exact rather than Gauss-Newton: chi2(s, c) is a convex
// quadratic inside each region of parameter space where the partition of the
// points into sliding (x < c/s) and rolling (x >= c/s) is fixed, and it is
// continuous across region borders, but it has a kink there, and a local method
// started on the wrong side of the switch stays there. Each region is a convex
// cone bounded by the lines c = s x_j, so its optimum is either the
// unconstrained two-line solution of that partition (if it falls inside the
// region) or lies on a border c = s x_j, where the model is a single parameter
// fit y = s min(x, x_j). Trying all n + 1 partitions and all n borders, with
// prefix sums, finds the global optimum in O(n).
struct KinkedLine {
  double slope = 0;               // s
  double plateau = 0;             // c
  double chi2 = kInf;             // with the weights passed in
  std::size_t first_rolling = 0;  // points [0, first_rolling) are sliding
  bool valid = false;
};

KinkedLine fitKinkedLine(const std::vector<double>& x, const std::vector<double>& y,
                         const std::vector<double>& w) {
  const std::size_t n = x.size();
  // Prefix sums over the sliding part [0, k) and suffix sums over the rolling
  // part [k, n).
  std::vector<double> sxx(n + 1, 0.0), sxy(n + 1, 0.0), syy(n + 1, 0.0);
  std::vector<double> rw(n + 1, 0.0), ry(n + 1, 0.0), ryy(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    sxx[i + 1] = sxx[i] + w[i] * x[i] * x[i];
    sxy[i + 1] = sxy[i] + w[i] * x[i] * y[i];
    syy[i + 1] = syy[i] + w[i] * y[i] * y[i];
  }
  for (std::size_t i = n; i-- > 0;) {
    rw[i] = rw[i + 1] + w[i];
    ry[i] = ry[i + 1] + w[i] * y[i];
    ryy[i] = ryy[i + 1] + w[i] * y[i] * y[i];
  }

  // Borders are tried first and later candidates must be better by more than
  // rounding, so on a tie (noise-free data) the simpler description, with no
  // point fitted by a line of its own, wins.
  const double tie = 1e-12 * syy[n];
  KinkedLine best;
  auto consider = [&best, tie](double s, double c, double chi2, std::size_t first_rolling) {
    if (!(s > 0) || !(chi2 < best.chi2 - tie)) return;
    best = KinkedLine{s, c, chi2, first_rolling, true};
  };

  // Border solutions: the kink sits on point j (all points tied with it are at
  // the kink too, so only the first of a tie is tried). y = s z, z = min(x, x_j).
  for (std::size_t j = 0; j < n; ++j) {
    if (j > 0 && x[j] == x[j - 1]) continue;
    const double szy = sxy[j] + x[j] * ry[j];
    const double szz = sxx[j] + x[j] * x[j] * rw[j];
    if (!(szz > 0)) continue;
    const double s = szy / szz;
    const double chi2 = syy[n] - szy * szy / szz;
    // Points at the kink lie on both lines. Count them as rolling, unless they
    // are all the rolling group has: a plateau seen only at its corner is no
    // plateau, and the data then say "all sliding".
    std::size_t past_kink = j;
    while (past_kink < n && x[past_kink] == x[j]) ++past_kink;
    consider(s, s * x[j], chi2, past_kink == n ? n : j);
  }

  // Interior solutions: partition k has k >= 1 sliding and n - k >= 1 rolling
  // points; it counts only if its own switch c/s falls between them.
  for (std::size_t k = 1; k < n; ++k) {
    const double s = sxy[k] / sxx[k];
    const double c = ry[k] / rw[k];
    if (!(s > 0) || s * x[k - 1] > c || c > s * x[k]) continue;
    const double chi2 = (syy[k] - sxy[k] * sxy[k] / sxx[k]) + (ryy[k] - ry[k] * ry[k] / rw[k]);
    consider(s, c, chi2, k);
  }
  return best;
}

struct FrictionInput {
  std::vector<CampaignShot> shots;
  std::vector<std::size_t> index;  // each shot's index in the caller's list, for messages
};

std::optional<Error> validateFrictionShot(std::size_t i, const CampaignShot& s) {
  using namespace campaign_detail;
  if (auto e = requireApproaching(i, s.v_n_m_s)) return e;
  if (!std::isfinite(s.v_s_m_s) || s.v_s_m_s < 0)
    return fail("shot " + std::to_string(i) + ": v_s = " + num(s.v_s_m_s) +
                " m/s must be a finite speed >= 0: it is the magnitude of the tangential "
                "contact velocity");
  if (s.v_s_m_s == 0)
    return fail("shot " + std::to_string(i) +
                ": v_s = 0 (head-on), so beta and x = -v_n/v_s are undefined: leave head-on "
                "shots out of the friction fit (they still count for e)");
  if (auto e = requireFinite(i, "beta", s.beta,
                             "re-analyse the shot or leave it out of the friction fit"))
    return e;
  if (auto e = requireSigma(i, "beta_sigma", s.beta_sigma, false)) return e;
  if (auto e = requireSigma(i, "v_n_sigma", s.v_n_sigma_m_s, true)) return e;
  if (auto e = requireSigma(i, "v_s_sigma", s.v_s_sigma_m_s, true)) return e;
  return std::nullopt;
}

std::string angleDeg(double cot_incidence) {
  return num(std::atan2(1.0, cot_incidence) * kRadToDeg);
}

// What the friction fit cannot start without: a finite K > 0, a fitted e,
// enough shots for both regimes, and each shot's inputs.
Status checkFrictionInputs(const FrictionInput& in, FittedValue e, const FrictionOptions& options,
                           int min_per_regime) {
  const double K = options.inertia_factor_K;
  if (!std::isfinite(K) || K <= 0)
    return fail("inertia factor K = " + num(K) +
                " must be finite and > 0 (2/5 for homogeneous spheres)");
  if (!std::isfinite(e.value) || e.value <= -1 || !std::isfinite(e.sigma) || e.sigma < 0)
    return fail("restitution e = " + num(e.value) + " +- " + num(e.sigma) +
                " must be finite, > -1, with a sigma >= 0: fit e first (fitRestitutionMean)");
  const std::size_t n = in.shots.size();
  const std::size_t needed = std::max<std::size_t>(4, 2 * std::size_t(min_per_regime));
  if (n < needed)
    return fail("friction fit needs at least " + std::to_string(needed) + " shots (" +
                std::to_string(min_per_regime) + " sliding and " + std::to_string(min_per_regime) +
                " rolling), got " + std::to_string(n) +
                ": add shots at incidence angles on both sides of the switch (~40 degrees "
                "for Nylon)");
  for (std::size_t i = 0; i < n; ++i)
    if (auto err = validateFrictionShot(in.index[i], in.shots[i])) return *err;
  return Ok{};
}

// Walton's kinked line beta + 1 = min(c, s x) fitted to the shots sorted by
// x = -v_n/v_s, with effective variances: an error dx moves a sliding
// point's model value by s dx and a rolling point's by nothing. Near the
// switch a point's regime is itself uncertain, so the x term is weighted by
// the probability that its true x lies below x0, which keeps the weights
// continuous in (s, c). u: the robust loss's weights (all 1 for least
// squares), multiplying them.
struct KinkedLineFit {
  std::vector<std::size_t> order;  // the r-th point is shot order[r]
  std::vector<double> x, y, sigma_beta, sigma_x, w, u;
  KinkedLine fit;

  explicit KinkedLineFit(const FrictionInput& in) {
    const std::size_t n = in.shots.size();
    order.resize(n);
    std::iota(order.begin(), order.end(), 0);
    std::vector<double> x_all(n);
    for (std::size_t i = 0; i < n; ++i) x_all[i] = in.shots[i].cotIncidence();
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return x_all[a] < x_all[b]; });
    x.resize(n), y.resize(n), sigma_beta.resize(n), sigma_x.resize(n), w.resize(n);
    u.assign(n, 1.0);
    for (std::size_t r = 0; r < n; ++r) {
      const CampaignShot& s = in.shots[order[r]];
      x[r] = x_all[order[r]];
      y[r] = s.beta + 1.0;
      sigma_beta[r] = s.beta_sigma;
      sigma_x[r] = s.cotIncidenceSigma();
      w[r] = 1.0 / (sigma_beta[r] * sigma_beta[r]);
    }
    fit = fitKinkedLine(x, y, w);
  }
  std::size_t size() const { return x.size(); }
  double model(const KinkedLine& f, std::size_t r) const {
    return std::min(f.plateau, f.slope * x[r]);
  }

  void effectiveWeights(const KinkedLine& f, std::vector<double>& weights) const {
    const double x0 = f.plateau / f.slope;
    for (std::size_t r = 0; r < size(); ++r) {
      const double p_sliding =
          sigma_x[r] > 0 ? standardNormalCdf((x0 - x[r]) / sigma_x[r]) : (x[r] < x0 ? 1.0 : 0.0);
      const double sx = f.slope * sigma_x[r];
      weights[r] = u[r] / (sigma_beta[r] * sigma_beta[r] + p_sliding * sx * sx);
    }
  }
  // chi2 of a solution with the weights it implies itself.
  double selfConsistentChi2(const KinkedLine& f) const {
    std::vector<double> weights(size());
    effectiveWeights(f, weights);
    double chi2 = 0;
    for (std::size_t r = 0; r < size(); ++r) {
      const double res = y[r] - model(f, r);
      chi2 += weights[r] * res * res;
    }
    return chi2;
  }

  // Fixed-point iteration (Orear's effective variance method). The best
  // partition can flip when the weights move, so the map is discontinuous and
  // may cycle between two near-equal solutions instead of settling; then the
  // cycle's member with the smaller self-consistent chi2 is taken.
  void settle() {
    constexpr int kSettleIterations = 40, kCycleIterations = 10;
    KinkedLine best_in_cycle;
    double best_cycle_chi2 = kInf;
    bool settled = false;
    for (int iter = 0; iter < kSettleIterations + kCycleIterations && fit.valid; ++iter) {
      effectiveWeights(fit, w);
      const KinkedLine next = fitKinkedLine(x, y, w);
      settled = next.valid && std::abs(next.slope - fit.slope) <= 1e-10 * std::abs(fit.slope) &&
                std::abs(next.plateau - fit.plateau) <= 1e-10 * (1 + std::abs(fit.plateau));
      fit = next;
      if (settled) break;
      if (iter >= kSettleIterations && fit.valid) {
        const double chi2 = selfConsistentChi2(fit);
        if (chi2 < best_cycle_chi2) {
          best_cycle_chi2 = chi2;
          best_in_cycle = fit;
        }
      }
    }
    if (!settled && best_in_cycle.valid) fit = best_in_cycle;
  }

  // One round of the robust loss (IRLS): the shots reweighted by their
  // normalised residuals (the loss's weights taken out), and the line
  // refitted. True once the robust weights stop changing.
  bool reweight(const RobustOptions& robust) {
    const std::size_t n = size();
    std::vector<double> z(n);
    effectiveWeights(fit, w);
    for (std::size_t r = 0; r < n; ++r) {
      const double w_plain = u[r] > 0 ? w[r] / u[r] : 0.0;
      z[r] = (y[r] - model(fit, r)) * std::sqrt(w_plain);
    }
    const double scale = robustScale(z);
    double change = 0;
    for (std::size_t r = 0; r < n; ++r) {
      const double un = std::max(robustWeight(z[r] / scale, robust), 1e-6);
      change = std::max(change, std::abs(un - u[r]));
      u[r] = un;
    }
    if (change < 1e-6) return true;
    effectiveWeights(fit, w);
    const KinkedLine refit = fitKinkedLine(x, y, w);
    if (refit.valid) fit = refit;
    return false;
  }
};

// Both regimes need min_per_regime shots; the error says where to add them.
Status requireBothRegimes(const KinkedLineFit& k, int min_per_regime) {
  const std::size_t n = k.size();
  const std::size_t n_sliding = k.fit.first_rolling;
  const std::size_t n_rolling = n - k.fit.first_rolling;
  const double x0 = k.fit.plateau / k.fit.slope;
  if (n_rolling < std::size_t(min_per_regime)) {
    const std::string add = "add shots nearer head-on (incidence angle below " +
                            angleDeg(n_rolling == 0 ? k.x.back() : x0) +
                            " degrees, i.e. larger -v_n/v_s) to measure beta0";
    if (n_rolling == 0)
      return fail("all " + std::to_string(n) + " shots are in the sliding regime: " + add);
    return fail("only " + std::to_string(n_rolling) + " of " + std::to_string(n) +
                " shots are in the rolling regime (x = -v_n/v_s above the fitted switch x0 = " +
                num(x0) + "), at least " + std::to_string(min_per_regime) + " are needed: " + add);
  }
  if (n_sliding < std::size_t(min_per_regime)) {
    const std::string add = "add shots at more grazing incidence (incidence angle above " +
                            angleDeg(n_sliding == 0 ? k.x.front() : x0) +
                            " degrees, i.e. smaller -v_n/v_s) to measure mu";
    if (n_sliding == 0)
      return fail("all " + std::to_string(n) + " shots are in the rolling regime: " + add);
    return fail("only " + std::to_string(n_sliding) + " of " + std::to_string(n) +
                " shots are in the sliding regime (x = -v_n/v_s below the fitted switch x0 = " +
                num(x0) + "), at least " + std::to_string(min_per_regime) + " are needed: " + add);
  }
  return Ok{};
}

// The fitted line's values and uncertainties: slope s and beta0 = c - 1
// (Birge-scaled), mu = s / ((1 + 1/K)(1 + e)) with e's uncertainty, the
// switch x0 = c/s and its angle, and each shot's regime and robust weight.
FrictionFit frictionResult(KinkedLineFit& k, FittedValue e, double K) {
  const KinkedLine& fit = k.fit;
  const std::size_t n = k.size();
  FrictionFit out;
  out.inertia_factor_K = K;
  out.dof = int(n) - 2;
  // From the residuals rather than the prefix sums, whose differences lose
  // digits when the fit is good; weights as the solution itself implies.
  k.effectiveWeights(fit, k.w);
  for (std::size_t r = 0; r < n; ++r) {
    const double res = k.y[r] - k.model(fit, r);
    out.chi2 += k.w[r] * res * res;
  }
  out.scale_factor = birgeScale(out.chi2, out.dof);
  // For a fixed partition the two lines are separate linear fits, so (s, c) are
  // uncorrelated to first order: var s = 1/sum_sliding w x^2, var c = 1/sum_rolling w.
  double info_s = 0, info_c = 0;
  for (std::size_t r = 0; r < n; ++r) {
    if (r < fit.first_rolling)
      info_s += k.w[r] * k.x[r] * k.x[r];
    else
      info_c += k.w[r];
  }
  const double scale2 = out.scale_factor * out.scale_factor;
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  cov(0, 0) = scale2 / info_s;
  cov(1, 1) = scale2 / info_c;
  out.slope_beta0_covariance = cov;  // beta0 = c - 1 has c's variance
  out.slope = {fit.slope, std::sqrt(cov(0, 0))};
  out.beta0 = {fit.plateau - 1.0, std::sqrt(cov(1, 1))};
  out.e = e;

  const double lever = (1.0 + 1.0 / K) * (1.0 + e.value);
  const double mu = fit.slope / lever;
  const double dmu_ds = 1.0 / lever;
  const double dmu_de = -mu / (1.0 + e.value);
  out.mu = {mu, std::sqrt(dmu_ds * dmu_ds * cov(0, 0) + dmu_de * dmu_de * e.sigma * e.sigma)};

  // x0 = c/s; psi0 = atan(1/x0).
  const double x0 = fit.plateau / fit.slope;
  const Eigen::Vector2d dx0{-fit.plateau / (fit.slope * fit.slope), 1.0 / fit.slope};
  const double sigma_x0 = std::sqrt(dx0.dot(cov * dx0));
  out.switch_cot = {x0, sigma_x0};
  out.switch_angle_deg = {std::atan2(1.0, x0) * kRadToDeg, sigma_x0 / (1.0 + x0 * x0) * kRadToDeg};

  out.regime.assign(n, CollisionRegime::Rolling);
  for (std::size_t r = 0; r < fit.first_rolling; ++r)
    out.regime[k.order[r]] = CollisionRegime::Sliding;
  out.robust_weight.assign(n, 1.0);
  for (std::size_t r = 0; r < n; ++r) out.robust_weight[k.order[r]] = k.u[r];
  out.sliding_count = int(fit.first_rolling);
  out.rolling_count = int(n - fit.first_rolling);
  return out;
}

Result<FrictionFit> fitFrictionIndexed(const FrictionInput& in, FittedValue e,
                                       const FrictionOptions& options) {
  const int min_per_regime = std::max(1, options.min_shots_per_regime);
  if (Status ok = checkFrictionInputs(in, e, options, min_per_regime); !ok) return ok.error();
  KinkedLineFit k(in);
  // With a robust loss, an outer loop reweights the shots by their normalised
  // residuals (IRLS) and settles the effective variances again, until the
  // robust weights stop changing.
  const bool robust = options.robust.loss != RobustLoss::LeastSquares;
  constexpr int kRobustIterations = 50;
  for (int outer = 0; outer < (robust ? kRobustIterations : 1); ++outer) {
    k.settle();
    if (!robust || !k.fit.valid || k.reweight(options.robust)) break;
  }
  if (!k.fit.valid)
    return fail(
        "beta does not rise with x = -v_n/v_s anywhere in the campaign, so Walton's "
        "sliding line cannot be fitted: check the sign conventions (v_s' = -beta v_s, "
        "v_n < 0 on approach)");
  if (Status ok = requireBothRegimes(k, min_per_regime); !ok) return ok.error();
  return frictionResult(k, e, options.inertia_factor_K);
}

}  // namespace

Result<FrictionFit> fitFriction(std::span<const CampaignShot> shots, FittedValue e,
                                const FrictionOptions& options) {
  FrictionInput in;
  in.shots.assign(shots.begin(), shots.end());
  in.index.resize(shots.size());
  std::iota(in.index.begin(), in.index.end(), 0);
  return fitFrictionIndexed(in, e, options);
}

double robustWeight(double z, const RobustOptions& o) {
  const double a = std::abs(z);
  switch (o.loss) {
    case RobustLoss::LeastSquares: return 1.0;
    case RobustLoss::Huber: {
      const double c = o.tuning > 0 ? o.tuning : 1.345;
      return a <= c ? 1.0 : c / a;
    }
    case RobustLoss::Cauchy: {
      const double c = o.tuning > 0 ? o.tuning : 2.385;
      return 1.0 / (1.0 + (a / c) * (a / c));
    }
  }
  return 1.0;
}

std::string robustLossName(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::LeastSquares: return "least squares";
    case RobustLoss::Huber: return "Huber";
    case RobustLoss::Cauchy: return "Cauchy";
  }
  return "?";
}

FrictionOptions campaignOptions() {
  FrictionOptions o;
  o.robust.loss = RobustLoss::Huber;
  return o;
}

Result<CampaignFit> fitCampaign(std::span<const CampaignShot> shots,
                                const FrictionOptions& options) {
  Result<RestitutionMean> mean = fitRestitutionMean(shots, options.robust);
  if (!mean) return mean.error();

  // Head-on shots, and shots whose spins were not measured (a silhouette),
  // inform e but have no beta; fit friction on the others and keep their
  // input indices for messages.
  FrictionInput in;
  std::size_t without_spins = 0;
  for (std::size_t i = 0; i < shots.size(); ++i) {
    const bool no_beta = std::isnan(shots[i].beta) && shots[i].v_s_m_s != 0;
    without_spins += no_beta;
    if (shots[i].v_s_m_s == 0 || no_beta) continue;
    in.shots.push_back(shots[i]);
    in.index.push_back(i);
  }
  Result<FrictionFit> friction = fitFrictionIndexed(in, mean->e, options);
  if (!friction) {
    if (without_spins > 0)
      friction = fail(std::to_string(without_spins) + " of " + std::to_string(shots.size()) +
                      " shots have no beta (their spins were not measured: no dots seen, e.g. "
                      "bare backlit silhouettes), so they count for e only; " +
                      friction.error().message);
    return CampaignFit{*mean, std::move(friction), fitRestitutionLaws(shots)};
  }
  std::vector<CollisionRegime> regime(shots.size(), CollisionRegime::Rolling);
  for (std::size_t k = 0; k < in.index.size(); ++k) regime[in.index[k]] = friction->regime[k];
  friction->regime = std::move(regime);
  std::vector<double> weight(shots.size(), 1.0);
  for (std::size_t k = 0; k < in.index.size(); ++k)
    weight[in.index[k]] = friction->robust_weight[k];
  friction->robust_weight = std::move(weight);

  return CampaignFit{*mean, std::move(friction), fitRestitutionLaws(shots)};
}

Result<FrictionBootstrap> bootstrapFriction(std::span<const CampaignShot> shots, int resamples,
                                            std::uint64_t seed, const FrictionOptions& options) {
  if (resamples < 10)
    return fail("bootstrap needs at least 10 resamples, got " + std::to_string(resamples) +
                ": use a few hundred");
  Result<RestitutionMean> mean = fitRestitutionMean(shots, options.robust);
  if (!mean) return mean.error();
  if (auto full = fitFriction(shots, mean->e, options); !full) return full.error();

  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, shots.size() - 1);
  std::vector<CampaignShot> sample(shots.size());
  // Columns: s, beta0, mu, e, x0.
  std::vector<Eigen::Matrix<double, 5, 1>> draws;
  int failed = 0;
  for (int b = 0; b < resamples; ++b) {
    for (auto& s : sample) s = shots[pick(rng)];
    Result<RestitutionMean> m = fitRestitutionMean(sample, options.robust);
    if (!m) {
      ++failed;
      continue;
    }
    // The bootstrap measures the spread of the estimates themselves, so the
    // resampled e enters as a value with no separate uncertainty.
    Result<FrictionFit> f = fitFriction(sample, FittedValue{m->e.value, 0.0}, options);
    if (!f) {
      ++failed;
      continue;
    }
    draws.push_back({f->slope.value, f->beta0.value, f->mu.value, m->e.value, f->switch_cot.value});
  }
  if (draws.size() < std::size_t(resamples) / 2)
    return fail("bootstrap: only " + std::to_string(draws.size()) + " of " +
                std::to_string(resamples) +
                " resamples could be fitted (too few shots on one side of the switch): add "
                "shots on both sides of the switch");
  Eigen::Matrix<double, 5, 1> mean_draw = Eigen::Matrix<double, 5, 1>::Zero();
  for (const auto& d : draws) mean_draw += d;
  mean_draw /= double(draws.size());
  Eigen::Matrix<double, 5, 1> var = Eigen::Matrix<double, 5, 1>::Zero();
  for (const auto& d : draws) var += (d - mean_draw).cwiseAbs2();
  var /= double(draws.size() - 1);
  const Eigen::Matrix<double, 5, 1> sd = var.cwiseSqrt();
  return FrictionBootstrap{sd(0), sd(1), sd(2), sd(3), sd(4), int(draws.size()), failed};
}

double campaignBetaCurve(double cot_incidence, const Material& m, double inertia_factor_K) {
  const double s = (1.0 + 1.0 / inertia_factor_K) * (1.0 + m.e) * m.mu;
  if (std::isinf(cot_incidence)) return m.beta0;
  return std::min(m.beta0, -1.0 + s * cot_incidence);
}

double campaignImpulseRatioCurve(double tan_incidence, const Material& m, double inertia_factor_K) {
  const double rolling =
      (1.0 + m.beta0) * tan_incidence / ((1.0 + 1.0 / inertia_factor_K) * (1.0 + m.e));
  return std::min(m.mu, rolling);
}

TangentFormLines campaignTangentFormLines(const Material& m, double inertia_factor_K) {
  const double s = (1.0 + 1.0 / inertia_factor_K) * (1.0 + m.e) * m.mu;
  return TangentFormLines{-s, -m.beta0, s / (1.0 + m.beta0)};
}

double campaignTangentFormCurve(double tan_incidence, const Material& m, double inertia_factor_K) {
  const TangentFormLines l = campaignTangentFormLines(m, inertia_factor_K);
  return std::max(l.rolling_slope * tan_incidence, tan_incidence + l.sliding_intercept);
}

}  // namespace collide
