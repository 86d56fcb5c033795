// e over a campaign: the weighted mean, and the laws of e against the normal
// impact speed |v_n| (thesis section 5.3, Figs. 5.12 and 5.13).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <optional>

#include "analysis/campaign.hpp"
#include "analysis/campaign_detail.hpp"

namespace collide {

using campaign_detail::birgeScale;
using campaign_detail::num;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kViscoExponent = 0.2;     // Kuwabara and Kono: 1 - e ~ v^(1/5)
constexpr double kPlasticExponent = 0.25;  // Johnson: e ~ v^(-1/4)
// The free power law's exponent is searched in [-kMaxExponent, kMaxExponent]:
// b = 2 already means e changing 100-fold over one decade of speed, far beyond
// anything a restitution coefficient in [0, 1] can do over a lab's speed range.
constexpr double kMaxExponent = 2.0;
constexpr double kExponentGridStep = 0.02;

struct SpeedData {
  std::vector<double> speed;      // |v_n|, m/s
  std::vector<double> log_speed;  // ln |v_n|
  std::vector<double> e, e_sigma, speed_sigma;
  std::size_t size() const { return speed.size(); }
};

std::optional<Error> validateRestitutionShot(std::size_t i, const CampaignShot& s) {
  using namespace campaign_detail;
  if (auto e = requireFinite(i, "e", s.e, "re-analyse the shot or leave it out of the e fit"))
    return e;
  if (auto e = requireSigma(i, "e_sigma", s.e_sigma, false)) return e;
  return std::nullopt;
}

Result<SpeedData> speedData(std::span<const CampaignShot> shots) {
  SpeedData d;
  for (std::size_t i = 0; i < shots.size(); ++i) {
    const CampaignShot& s = shots[i];
    if (auto err = validateRestitutionShot(i, s)) return *err;
    if (auto err = campaign_detail::requireApproaching(i, s.v_n_m_s)) return *err;
    if (auto err = campaign_detail::requireSigma(i, "v_n_sigma", s.v_n_sigma_m_s, true))
      return *err;
    d.speed.push_back(-s.v_n_m_s);
    d.log_speed.push_back(std::log(-s.v_n_m_s));
    d.e.push_back(s.e);
    d.e_sigma.push_back(s.e_sigma);
    d.speed_sigma.push_back(s.v_n_sigma_m_s);
  }
  return d;
}

// ---- The four laws: value, de/dv, gradient in the parameters, and the
// weighted least-squares fit for fixed weights. ----

double lawValue(RestitutionLaw law, const Eigen::VectorXd& p, double v) {
  switch (law) {
    case RestitutionLaw::Constant: return p(0);
    case RestitutionLaw::PowerLaw: return p(0) * std::pow(v, -p(1));
    case RestitutionLaw::ViscoElastic: return 1.0 - p(0) * std::pow(v, kViscoExponent);
    case RestitutionLaw::Plastic: return std::min(1.0, p(0) * std::pow(v, -kPlasticExponent));
  }
  return std::numeric_limits<double>::quiet_NaN();
}

bool plasticCapped(const Eigen::VectorXd& p, double v) {
  return p(0) * std::pow(v, -kPlasticExponent) >= 1.0;
}

double lawSlope(RestitutionLaw law, const Eigen::VectorXd& p, double v) {
  switch (law) {
    case RestitutionLaw::Constant: return 0.0;
    case RestitutionLaw::PowerLaw: return -p(1) * p(0) * std::pow(v, -p(1) - 1.0);
    case RestitutionLaw::ViscoElastic:
      return -kViscoExponent * p(0) * std::pow(v, kViscoExponent - 1.0);
    case RestitutionLaw::Plastic:
      return plasticCapped(p, v) ? 0.0
                                 : -kPlasticExponent * p(0) * std::pow(v, -kPlasticExponent - 1);
  }
  return 0.0;
}

// sigma_e^2 + (de/dv)^2 sigma_v^2 for shot i. Near the plastic law's yield
// speed c^4 whether a shot is above it is itself uncertain, so its slope term
// is weighted by that probability; this keeps the weights continuous in c.
double effectiveVariance(RestitutionLaw law, const Eigen::VectorXd& p, const SpeedData& d,
                         std::size_t i) {
  const double v = d.speed[i], sv = d.speed_sigma[i];
  double slope2 = 0;
  if (law == RestitutionLaw::Plastic) {
    const double uncapped_slope = kPlasticExponent * p(0) * std::pow(v, -kPlasticExponent - 1);
    const double yield = p(0) > 0 ? std::pow(p(0), 1.0 / kPlasticExponent) : 0.0;  // m/s
    const double p_above = sv > 0 ? 0.5 * std::erfc((yield - v) / (sv * std::numbers::sqrt2))
                                  : (plasticCapped(p, v) ? 0.0 : 1.0);
    slope2 = p_above * uncapped_slope * uncapped_slope;
  } else {
    slope2 = lawSlope(law, p, v) * lawSlope(law, p, v);
  }
  return d.e_sigma[i] * d.e_sigma[i] + slope2 * sv * sv;
}

Eigen::VectorXd lawGradient(RestitutionLaw law, const Eigen::VectorXd& p, double v) {
  Eigen::VectorXd g(p.size());
  switch (law) {
    case RestitutionLaw::Constant: g(0) = 1.0; break;
    case RestitutionLaw::PowerLaw: {
      const double u = std::pow(v, -p(1));
      g(0) = u;
      g(1) = -p(0) * u * std::log(v);
      break;
    }
    case RestitutionLaw::ViscoElastic: g(0) = -std::pow(v, kViscoExponent); break;
    case RestitutionLaw::Plastic:
      g(0) = plasticCapped(p, v) ? 0.0 : std::pow(v, -kPlasticExponent);
      break;
  }
  return g;
}

// y = c u through the origin, weights w: c = sum w u y / sum w u^2.
double proportionalFit(const std::vector<double>& u, const std::vector<double>& y,
                       const std::vector<double>& w) {
  double suy = 0, suu = 0;
  for (std::size_t i = 0; i < u.size(); ++i) {
    suy += w[i] * u[i] * y[i];
    suu += w[i] * u[i] * u[i];
  }
  return suy / suu;
}

// e = min(1, c u), u = v^(-1/4), exactly. chi2(c) is continuous and, between
// consecutive values c = 1/u_j where another point reaches the cap, a convex
// quadratic; so the optimum is an unconstrained solution that lies in its own
// interval, or one of those borders. Points sorted by speed ascending have u
// descending, so the capped points are always a prefix.
double fitPlastic(const SpeedData& d, const std::vector<double>& w) {
  const std::size_t n = d.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return d.speed[a] < d.speed[b]; });
  std::vector<double> u(n), e(n), ww(n);
  for (std::size_t r = 0; r < n; ++r) {
    u[r] = std::pow(d.speed[order[r]], -kPlasticExponent);
    e[r] = d.e[order[r]];
    ww[r] = w[order[r]];
  }
  std::vector<double> capped(n + 1, 0.0);  // sum over [0, k) of w (e - 1)^2
  for (std::size_t r = 0; r < n; ++r) capped[r + 1] = capped[r] + ww[r] * (e[r] - 1) * (e[r] - 1);
  std::vector<double> suu(n + 1, 0.0), sue(n + 1, 0.0), see(n + 1, 0.0);  // over [k, n)
  for (std::size_t r = n; r-- > 0;) {
    suu[r] = suu[r + 1] + ww[r] * u[r] * u[r];
    sue[r] = sue[r + 1] + ww[r] * u[r] * e[r];
    see[r] = see[r + 1] + ww[r] * e[r] * e[r];
  }
  auto chi2 = [&](std::size_t k, double c) {
    return capped[k] + see[k] - 2 * c * sue[k] + c * c * suu[k];
  };
  // All capped: e = 1 everywhere fits; c is only bounded below. Start from the
  // smallest such c; any partition with data below the cap beats it if it can.
  double best_c = 1.0 / u[n - 1];
  double best = capped[n];
  for (std::size_t k = 0; k < n; ++k) {
    const double c = sue[k] / suu[k];
    const bool inside = (k == 0 || c * u[k - 1] >= 1.0) && c * u[k] < 1.0;
    if (inside && chi2(k, c) < best) {
      best = chi2(k, c);
      best_c = c;
    }
    // Border: point k just reaches the cap (counted as capped).
    const double cb = 1.0 / u[k];
    if (chi2(k + 1, cb) < best) {
      best = chi2(k + 1, cb);
      best_c = cb;
    }
  }
  return best_c;
}

// e = a v^(-b): for a fixed b the best a is a proportional fit, so the
// profile chi2(b) is one-dimensional; a grid finds its basin and bisection on
// its derivative refines it (the derivative, unlike chi2 itself, still
// resolves b near the minimum to rounding). Local methods from a log-linear
// start can fail when some e are near 0 or the speed range is short; the
// profile cannot. `near_b`, the exponent of the previous effective-variance
// iteration, lets the grid be skipped: the weights change little.
Eigen::VectorXd fitPowerLaw(const SpeedData& d, const std::vector<double>& w,
                            std::optional<double> near_b) {
  const std::size_t n = d.size();
  // Weighted sums for u_i = v_i^(-b); chi2(b) = See - Sue^2/Suu.
  struct Sums {
    double suu = 0, sue = 0, see = 0, dsuu = 0, dsue = 0;  // d/db of suu, sue
    double chi2() const { return see - sue * sue / suu; }
    double slope() const { return -2 * sue * dsue / suu + sue * sue * dsuu / (suu * suu); }
  };
  auto sums = [&](double b) {
    Sums s;
    for (std::size_t i = 0; i < n; ++i) {
      const double u = std::exp(-b * d.log_speed[i]);
      s.suu += w[i] * u * u;
      s.sue += w[i] * u * d.e[i];
      s.see += w[i] * d.e[i] * d.e[i];
      s.dsuu -= 2 * w[i] * d.log_speed[i] * u * u;
      s.dsue -= w[i] * d.log_speed[i] * u * d.e[i];
    }
    return s;
  };
  // The minimum in [lo, hi] if chi2 falls at lo and rises at hi; else nullopt.
  auto bisect = [&](double lo, double hi) -> std::optional<double> {
    if (!(sums(lo).slope() < 0) || !(sums(hi).slope() > 0)) return std::nullopt;
    while (hi - lo > 1e-15 * (1 + std::abs(lo))) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      (sums(mid).slope() < 0 ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };

  std::optional<double> b;
  if (near_b)
    b = bisect(std::max(-kMaxExponent, *near_b - kExponentGridStep),
               std::min(kMaxExponent, *near_b + kExponentGridStep));
  if (!b) {
    // Stepping b by a constant multiplies each u_i by a constant: the grid
    // needs one exp per point, not one per point and step.
    double best_b = 0, best = kInf;
    const int steps = int(std::lround(2 * kMaxExponent / kExponentGridStep));
    std::vector<double> u(n), step(n);
    for (std::size_t i = 0; i < n; ++i) {
      u[i] = std::exp(kMaxExponent * d.log_speed[i]);
      step[i] = std::exp(-kExponentGridStep * d.log_speed[i]);
    }
    for (int k = 0; k <= steps; ++k) {
      double suu = 0, sue = 0, see = 0;
      for (std::size_t i = 0; i < n; ++i) {
        suu += w[i] * u[i] * u[i];
        sue += w[i] * u[i] * d.e[i];
        see += w[i] * d.e[i] * d.e[i];
        u[i] *= step[i];
      }
      const double chi2 = see - sue * sue / suu;
      if (chi2 < best) {
        best = chi2;
        best_b = -kMaxExponent + k * kExponentGridStep;
      }
    }
    // At a grid end the exponent is pinned to the search limit (see
    // kMaxExponent); inside, the minimum is within one step of the best node.
    b = bisect(std::max(-kMaxExponent, best_b - kExponentGridStep),
               std::min(kMaxExponent, best_b + kExponentGridStep))
            .value_or(best_b);
  }
  const Sums s = sums(*b);
  Eigen::VectorXd p(2);
  p << s.sue / s.suu, *b;
  return p;
}

// `previous`: the parameters of the last effective-variance iteration, or null.
Eigen::VectorXd fitLawFixedWeights(RestitutionLaw law, const SpeedData& d,
                                   const std::vector<double>& w, const Eigen::VectorXd* previous) {
  const std::size_t n = d.size();
  Eigen::VectorXd p(law == RestitutionLaw::PowerLaw ? 2 : 1);
  switch (law) {
    case RestitutionLaw::Constant: {
      std::vector<double> one(n, 1.0);
      p(0) = proportionalFit(one, d.e, w);
      break;
    }
    case RestitutionLaw::ViscoElastic: {
      std::vector<double> u(n), loss(n);
      for (std::size_t i = 0; i < n; ++i) {
        u[i] = std::pow(d.speed[i], kViscoExponent);
        loss[i] = 1.0 - d.e[i];
      }
      p(0) = proportionalFit(u, loss, w);
      break;
    }
    case RestitutionLaw::Plastic: p(0) = fitPlastic(d, w); break;
    case RestitutionLaw::PowerLaw:
      p = fitPowerLaw(d, w, previous ? std::optional<double>((*previous)(1)) : std::nullopt);
      break;
  }
  return p;
}

const char* lawFormula(RestitutionLaw law) {
  switch (law) {
    case RestitutionLaw::Constant: return "e = c";
    case RestitutionLaw::PowerLaw: return "e = a |v_n|^(-b)";
    case RestitutionLaw::ViscoElastic: return "1 - e = c |v_n|^(1/5)";
    case RestitutionLaw::Plastic: return "e = min(1, c |v_n|^(-1/4))";
  }
  return "";
}

RestitutionLawFit fitLaw(RestitutionLaw law, const SpeedData& d) {
  const std::size_t n = d.size();
  std::vector<double> w(n);
  for (std::size_t i = 0; i < n; ++i) w[i] = 1.0 / (d.e_sigma[i] * d.e_sigma[i]);
  // Effective variances, iterated because the slope depends on the fit; as in
  // the friction fit the plastic law's cap can make the iteration cycle, and
  // then the cycle's member with the smaller self-consistent chi2 is taken.
  auto selfConsistentChi2 = [&](const Eigen::VectorXd& q) {
    double chi2 = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double r = d.e[i] - lawValue(law, q, d.speed[i]);
      chi2 += r * r / effectiveVariance(law, q, d, i);
    }
    return chi2;
  };
  constexpr int kSettleIterations = 40, kCycleIterations = 10;
  Eigen::VectorXd p = fitLawFixedWeights(law, d, w, nullptr);
  Eigen::VectorXd best_in_cycle;
  double best_cycle_chi2 = kInf;
  bool settled = false;
  for (int iter = 0; iter < kSettleIterations + kCycleIterations; ++iter) {
    for (std::size_t i = 0; i < n; ++i) w[i] = 1.0 / effectiveVariance(law, p, d, i);
    const Eigen::VectorXd next = fitLawFixedWeights(law, d, w, &p);
    settled = ((next - p).array().abs() <= 1e-10 * (1 + p.array().abs())).all();
    p = next;
    if (settled) break;
    if (iter >= kSettleIterations) {
      const double chi2 = selfConsistentChi2(p);
      if (chi2 < best_cycle_chi2) {
        best_cycle_chi2 = chi2;
        best_in_cycle = p;
      }
    }
  }
  if (!settled && best_in_cycle.size() > 0) p = best_in_cycle;

  RestitutionLawFit out;
  out.law = law;
  out.formula = lawFormula(law);
  const int k = int(p.size());
  Eigen::MatrixXd info = Eigen::MatrixXd::Zero(k, k);
  double chi2 = 0, log_norm = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double v = effectiveVariance(law, p, d, i);
    const double r = d.e[i] - lawValue(law, p, d.speed[i]);
    chi2 += r * r / v;
    log_norm += std::log(2 * std::numbers::pi * v);
    const Eigen::VectorXd g = lawGradient(law, p, d.speed[i]);
    info += g * g.transpose() / v;
  }
  out.chi2 = chi2;
  out.dof = int(n) - k;
  out.scale_factor = birgeScale(chi2, out.dof);
  // The variances depend on the law (through de/dv), so the likelihoods keep
  // their normalisation terms to stay comparable between laws.
  out.minus2_log_likelihood = chi2 + log_norm;
  out.aic = out.minus2_log_likelihood + 2.0 * k;
  out.bic = out.minus2_log_likelihood + k * std::log(double(n));

  // A singular information matrix (e.g. plastic with every shot at the cap,
  // where c is only bounded below) leaves the parameters undetermined: say so
  // with an infinite sigma rather than a number.
  Eigen::FullPivLU<Eigen::MatrixXd> lu(info);
  if (lu.isInvertible())
    out.covariance = lu.inverse() * (out.scale_factor * out.scale_factor);
  else
    out.covariance = Eigen::MatrixXd::Constant(k, k, kInf);
  switch (law) {
    case RestitutionLaw::PowerLaw: out.parameter_names = {"a", "b"}; break;
    default: out.parameter_names = {"c"}; break;
  }
  for (int j = 0; j < k; ++j) out.parameters.push_back({p(j), std::sqrt(out.covariance(j, j))});
  return out;
}

}  // namespace

std::string restitutionLawName(RestitutionLaw law) {
  switch (law) {
    case RestitutionLaw::Constant: return "constant";
    case RestitutionLaw::PowerLaw: return "power law";
    case RestitutionLaw::ViscoElastic: return "visco-elastic";
    case RestitutionLaw::Plastic: return "plastic";
  }
  return "unknown";
}

std::string evidenceName(Evidence evidence) {
  switch (evidence) {
    case Evidence::BareMention: return "not worth more than a bare mention";
    case Evidence::Positive: return "positive";
    case Evidence::Strong: return "strong";
    case Evidence::VeryStrong: return "very strong";
  }
  return "unknown";
}

double RestitutionLawFit::restitutionAt(double normal_speed_m_s) const {
  Eigen::VectorXd p(parameters.size());
  for (std::size_t j = 0; j < parameters.size(); ++j) p(j) = parameters[j].value;
  return lawValue(law, p, normal_speed_m_s);
}

Result<RestitutionMean> fitRestitutionMean(std::span<const CampaignShot> shots,
                                           const RobustOptions& robust) {
  if (shots.size() < 2)
    return fail("mean restitution needs at least 2 shots, got " + std::to_string(shots.size()) +
                ": add shots");
  for (std::size_t i = 0; i < shots.size(); ++i)
    if (auto err = validateRestitutionShot(i, shots[i])) return *err;
  // Robust weights u (all 1 for least squares): reweighted by the normalised
  // residuals about the current mean until they settle.
  std::vector<double> u(shots.size(), 1.0);
  if (robust.loss != RobustLoss::LeastSquares) {
    for (int iter = 0; iter < 100; ++iter) {
      double sw = 0, swe = 0;
      for (std::size_t i = 0; i < shots.size(); ++i) {
        const double w = u[i] / (shots[i].e_sigma * shots[i].e_sigma);
        sw += w;
        swe += w * shots[i].e;
      }
      const double mean = swe / sw;
      std::vector<double> z(shots.size());
      for (std::size_t i = 0; i < shots.size(); ++i) z[i] = (shots[i].e - mean) / shots[i].e_sigma;
      const double scale = campaign_detail::robustScale(z);
      double change = 0;
      for (std::size_t i = 0; i < shots.size(); ++i) {
        const double un = std::max(robustWeight(z[i] / scale, robust), 1e-6);
        change = std::max(change, std::abs(un - u[i]));
        u[i] = un;
      }
      if (change < 1e-9) break;
    }
  }
  double sw = 0, swe = 0;
  for (std::size_t i = 0; i < shots.size(); ++i) {
    const double w = u[i] / (shots[i].e_sigma * shots[i].e_sigma);
    sw += w;
    swe += w * shots[i].e;
  }
  RestitutionMean out;
  out.count = int(shots.size());
  const double mean = swe / sw;
  double chi2 = 0, plain_sum = 0;
  for (std::size_t i = 0; i < shots.size(); ++i) {
    const CampaignShot& s = shots[i];
    chi2 += u[i] * (s.e - mean) * (s.e - mean) / (s.e_sigma * s.e_sigma);
    plain_sum += s.e;
  }
  const double plain_mean = plain_sum / double(shots.size());
  double ss = 0;
  for (const CampaignShot& s : shots) ss += (s.e - plain_mean) * (s.e - plain_mean);
  out.chi2 = chi2;
  out.dof = out.count - 1;
  out.scale_factor = birgeScale(chi2, out.dof);
  out.e = {mean, out.scale_factor / std::sqrt(sw)};
  out.scatter = std::sqrt(ss / double(shots.size() - 1));
  out.robust_weight = u;
  return out;
}

Result<RestitutionLaws> fitRestitutionLaws(std::span<const CampaignShot> shots) {
  if (shots.size() < 4)
    return fail("restitution laws need at least 4 shots, got " + std::to_string(shots.size()) +
                ": add shots over a range of launch pressures");
  Result<SpeedData> data = speedData(shots);
  if (!data) return data.error();
  const auto [lo, hi] = std::minmax_element(data->speed.begin(), data->speed.end());
  if (*lo == *hi)
    return fail("all " + std::to_string(shots.size()) + " shots have the same |v_n| = " + num(*lo) +
                " m/s, so no law of e against speed can be fitted: vary the launch pressure");

  RestitutionLaws out;
  for (RestitutionLaw law : {RestitutionLaw::Constant, RestitutionLaw::PowerLaw,
                             RestitutionLaw::ViscoElastic, RestitutionLaw::Plastic})
    out.fits.push_back(fitLaw(law, *data));

  std::vector<double> bic;
  for (const auto& f : out.fits) bic.push_back(f.bic);
  const std::size_t winner = std::min_element(bic.begin(), bic.end()) - bic.begin();
  out.preferred = out.fits[winner].law;
  double runner_up = kInf;
  for (std::size_t j = 0; j < out.fits.size(); ++j) {
    out.fits[j].delta_bic = bic[j] - bic[winner];
    if (j != winner) runner_up = std::min(runner_up, bic[j]);
  }
  out.bic_margin = runner_up - bic[winner];
  out.evidence = out.bic_margin < 2    ? Evidence::BareMention
                 : out.bic_margin < 6  ? Evidence::Positive
                 : out.bic_margin < 10 ? Evidence::Strong
                                       : Evidence::VeryStrong;
  return out;
}

}  // namespace collide
