#include "analysis/adaptive_design.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

namespace collide {
namespace {

constexpr double kDeg = 180.0 / std::numbers::pi;

std::string fmt(const char* spec, double a, double b = 0, double c = 0, double d = 0, double e = 0,
                double f = 0) {
  char buf[320];
  std::snprintf(buf, sizeof buf, spec, a, b, c, d, e, f);
  return buf;
}

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// How a shot's uncertainties grow with the angle and the speed, from the
// shots measured so far: sigma_beta ~ a (V / V_ref)^q / sin psi and sigma_x ~
// b (V / V_ref)^q / sin^2 psi (v_s = V sin psi), V = |v_c| at contact, V_ref
// the shots' median; q from a least-squares line through log(sigma_beta sin
// psi) against log V once the speeds spread enough to tell (else 0).
struct NoiseModel {
  double a = 0.02, b = 0.01, v_ref = 1.0, q = 0.0;
  bool speed_known = false;  ///< q measured
  int shots = 0;
  double v_lo = 0, v_hi = 0;  ///< the shots' slowest and fastest, m/s
  double speedFactor(double v) const { return v > 0 ? std::pow(v / v_ref, q) : 1.0; }
  double sigmaBeta(double psi, double v) const { return a * speedFactor(v) / std::sin(psi); }
  double sigmaX(double psi, double v) const {
    return b * speedFactor(v) / (std::sin(psi) * std::sin(psi));
  }
};

double speedExponent(const std::vector<double>& log_v, const std::vector<double>& log_a) {
  const double n = static_cast<double>(log_v.size());
  double mv = 0, ma = 0;
  for (std::size_t i = 0; i < log_v.size(); ++i) mv += log_v[i] / n, ma += log_a[i] / n;
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < log_v.size(); ++i)
    sxy += (log_v[i] - mv) * (log_a[i] - ma), sxx += (log_v[i] - mv) * (log_v[i] - mv);
  return std::clamp(sxy / sxx, -2.0, 2.0);
}

NoiseModel noiseModel(std::span<const CampaignShot> shots) {
  std::vector<double> a, b, v, log_v, log_a;
  for (const CampaignShot& s : shots) {
    const double psi = s.incidenceAngle_rad();
    const double speed = std::hypot(s.v_n_m_s, s.v_s_m_s);
    if (!(std::sin(psi) > 0.05) || !(s.beta_sigma > 0) || !(speed > 0)) continue;
    a.push_back(s.beta_sigma * std::sin(psi));
    b.push_back(s.cotIncidenceSigma() * std::sin(psi) * std::sin(psi));
    v.push_back(speed);
    log_v.push_back(std::log(speed));
    log_a.push_back(std::log(a.back()));
  }
  NoiseModel m;
  m.shots = static_cast<int>(a.size());
  if (a.empty()) return m;
  m.v_ref = median(v);
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  m.v_lo = *lo, m.v_hi = *hi;
  if (a.size() >= 4 && *hi >= 1.2 * *lo) {
    m.q = speedExponent(log_v, log_a);
    m.speed_known = true;
  }
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double f = m.speedFactor(v[i]);
    a[i] /= f, b[i] /= f;
  }
  m.a = median(a);
  m.b = median(b);
  return m;
}

double standardNormalCdf(double z) {
  return 0.5 * std::erfc(-z / std::numbers::sqrt2);
}

// sigma_mu and sigma_beta0 from an information matrix of (s, beta0).
struct Sigmas {
  double mu = INFINITY, beta0 = INFINITY;
};

Sigmas sigmasFrom(const Eigen::Matrix2d& info, double c, double mu, double e, double sigma_e) {
  Sigmas out;
  if (!(std::abs(info.determinant()) > 1e-300)) return out;
  const Eigen::Matrix2d cov = info.inverse();
  if (!(cov(0, 0) > 0) || !(cov(1, 1) > 0)) return out;
  out.mu = std::hypot(std::sqrt(cov(0, 0)) / c, mu * sigma_e / (1 + e));
  out.beta0 = std::sqrt(cov(1, 1));
  return out;
}

double score(const Sigmas& s, const AdaptiveOptions& o) {
  return std::max(s.mu / o.target_sigma_mu, s.beta0 / o.target_sigma_beta0);
}

std::vector<double> candidateAngles(const AdaptiveOptions& o) {
  std::vector<double> out;
  for (double g = o.angle_min_deg; g <= o.angle_max_deg + 1e-9; g += 0.5) out.push_back(g);
  return out;
}

// Before a fit: the initial spread, then the largest gap in psi.
NextShot spreadShot(std::span<const CampaignShot> shots, const AdaptiveOptions& o,
                    const std::string& reason) {
  NextShot next;
  next.expected_sigma_mu = next.expected_sigma_beta0 = NAN;
  const int n = static_cast<int>(shots.size());
  if (n < o.initial_shots) {
    // Evenly over the range, alternating ends towards the middle.
    const int k = n % 2 == 0 ? n / 2 : o.initial_shots - 1 - n / 2;
    next.incidence_deg =
        o.angle_min_deg + (o.angle_max_deg - o.angle_min_deg) * (k + 0.5) / o.initial_shots;
    next.why = fmt("initial spread, shot %.0f of %.0f, before a fit is possible", n + 1.0,
                   static_cast<double>(o.initial_shots));
    return next;
  }
  double best = -1;
  for (const double g : candidateAngles(o)) {
    double nearest = INFINITY;
    for (const CampaignShot& s : shots)
      nearest = std::min(nearest, std::abs(s.incidenceAngle_rad() * kDeg - g));
    if (nearest > best) best = nearest, next.incidence_deg = g;
  }
  next.why = "no friction fit yet (" + reason + "): filling the largest gap in angle (" +
             fmt("%.1f deg from the nearest shot)", best);
  return next;
}

// The speed half of the choice, and its words. Once the noise's speed law
// is known the angle loop has scored both ends of the range; until then the
// shot goes to the end furthest (in ratio) from the speeds fired so far, so
// that the law is learnt within a shot or two.
void chooseSpeed(NextShot& next, const NoiseModel& noise, const AdaptiveOptions& o) {
  if (!(o.speed_min_m_s > 0 && o.speed_max_m_s > o.speed_min_m_s) || noise.shots == 0) return;
  if (!noise.speed_known) {
    const bool up = o.speed_max_m_s / noise.v_hi >= noise.v_lo / o.speed_min_m_s;
    next.speed_m_s = up ? o.speed_max_m_s : o.speed_min_m_s;
  }
  const bool fastest = next.speed_m_s == o.speed_max_m_s;
  next.why += fmt("; at %.2f m/s, the ", next.speed_m_s) + (fastest ? "fastest" : "slowest") +
              " in the rig's range";
  if (noise.speed_known)
    next.why += fmt(": over %.0f shots sigma_beta scales as speed^%.2f", noise.shots, noise.q);
  else
    next.why +=
        fmt(", to learn how sigma_beta scales with speed (%.0f usable shots at "
            "%.2f-%.2f m/s so far; 4 spread over 20 %% needed)",
            noise.shots, noise.v_lo, noise.v_hi);
}

}  // namespace

AdaptiveStatus assessCampaign(std::span<const CampaignShot> shots, const AdaptiveOptions& o) {
  AdaptiveStatus st;
  auto e = fitRestitutionMean(shots);
  if (!e) {
    st.fit_error = e.error().message;
    return st;
  }
  st.restitution = *e;
  std::vector<CampaignShot> oblique;
  for (const CampaignShot& s : shots)
    if (s.v_s_m_s > 0 && !std::isnan(s.beta)) oblique.push_back(s);  // spins measured
  auto f = fitFriction(oblique, e->e, o.friction);
  if (!f) {
    st.fit_error = f.error().message;
    return st;
  }
  st.friction = *f;
  st.targets_met = f->mu.sigma <= o.target_sigma_mu && f->beta0.sigma <= o.target_sigma_beta0;
  return st;
}

Result<NextShot> chooseNextShot(std::span<const CampaignShot> shots, const AdaptiveStatus& st,
                                const AdaptiveOptions& o) {
  if (!(o.angle_min_deg >= 0 && o.angle_min_deg < o.angle_max_deg && o.angle_max_deg < 90))
    return fail("the adaptive campaign's angles must satisfy 0 <= min < max < 90 degrees");
  if (!(o.target_sigma_mu > 0) || !(o.target_sigma_beta0 > 0))
    return fail("--target-sigma-mu and --target-sigma-beta0 must be > 0");
  if (!st.friction) return spreadShot(shots, o, st.fit_error);
  const FrictionFit& f = *st.friction;
  const double e = f.e.value, sigma_e = f.e.sigma;
  const double c = (1 + 1 / f.inertia_factor_K) * (1 + e);
  Eigen::Matrix2d info = Eigen::Matrix2d::Zero();
  if (std::abs(f.slope_beta0_covariance.determinant()) > 1e-300)
    info = f.slope_beta0_covariance.inverse();
  const Sigmas now = sigmasFrom(info, c, f.mu.value, e, sigma_e);
  if (!std::isfinite(now.mu) || !std::isfinite(now.beta0))
    return spreadShot(shots, o, "the fit's covariance is singular");
  const NoiseModel noise = noiseModel(shots);
  const double x0 = f.switch_cot.value, sigma_x0 = std::max(f.switch_cot.sigma, 1e-3);
  const double s = f.slope.value;

  // The speeds to try: both ends of the rig's range once the noise's speed
  // law is known; otherwise the campaign's typical speed (and it draws one).
  const bool choose_speed =
      noise.speed_known && o.speed_min_m_s > 0 && o.speed_max_m_s > o.speed_min_m_s;
  // The quieter end first: where the speed does not change the score (the
  // shot adds little), the shot that measures better is kept.
  std::vector<double> speeds{choose_speed ? o.speed_min_m_s : noise.v_ref};
  if (choose_speed) speeds.insert(noise.q < 0 ? speeds.begin() : speeds.end(), o.speed_max_m_s);

  NextShot next;
  double best = INFINITY, best_p = 0;
  for (const double v : speeds)
    for (const double g : candidateAngles(o)) {
      const double psi = g / kDeg, x = 1 / std::tan(psi);
      const double sb = noise.sigmaBeta(psi, v), sx = noise.sigmaX(psi, v);
      // A sliding shot: beta = -1 + s x, d beta / d s = x; the x error adds.
      Eigen::Matrix2d slide = info;
      slide(0, 0) += x * x / (sb * sb + s * s * sx * sx);
      Eigen::Matrix2d roll = info;
      roll(1, 1) += 1 / (sb * sb);
      const double p = standardNormalCdf((x0 - x) / std::hypot(sigma_x0, sx));
      const Sigmas ss = sigmasFrom(slide, c, f.mu.value, e, sigma_e);
      const Sigmas sr = sigmasFrom(roll, c, f.mu.value, e, sigma_e);
      const double expected = p * score(ss, o) + (1 - p) * score(sr, o);
      if (expected < best) {
        best = expected, best_p = p, next.incidence_deg = g;
        next.speed_m_s = choose_speed ? v : NAN;
        next.expected_sigma_mu = p * ss.mu + (1 - p) * sr.mu;
        next.expected_sigma_beta0 = p * ss.beta0 + (1 - p) * sr.beta0;
      }
    }
  const bool mu_worse = now.mu / o.target_sigma_mu >= now.beta0 / o.target_sigma_beta0;
  next.why = std::string(mu_worse ? "mu" : "beta0") + " is furthest from its target " +
             fmt("(sigma_mu %.3g for %.3g, sigma_beta0 %.3g for %.3g); ", now.mu, o.target_sigma_mu,
                 now.beta0, o.target_sigma_beta0) +
             fmt("at %.1f deg (switch at %.1f deg) the shot slides with probability %.0f %% and "
                 "is expected to bring sigma_mu to %.3g, sigma_beta0 to %.3g",
                 next.incidence_deg, f.switch_angle_deg.value, 100 * best_p, next.expected_sigma_mu,
                 next.expected_sigma_beta0);
  chooseSpeed(next, noise, o);
  return next;
}

CampaignShot synthesizeShot(const Material& m, double psi_deg, const ShotNoise& n,
                            std::mt19937_64& rng, double K) {
  std::normal_distribution<double> g(0, 1);
  const double psi = psi_deg / kDeg;
  const double x = 1 / std::tan(psi), s = (1 + 1 / K) * (1 + m.e) * m.mu;
  const double v = n.relative_speed_m_s, grow = std::pow(v / 4.0, n.speed_exponent);
  const double sigma_v = n.sigma_v_m_s * grow;
  CampaignShot c;
  c.v_n_m_s = -v * std::cos(psi) + sigma_v * g(rng);
  c.v_s_m_s = v * std::sin(psi) + sigma_v * g(rng);
  c.v_n_sigma_m_s = c.v_s_sigma_m_s = sigma_v;
  c.e = m.e + n.sigma_e * g(rng);
  c.e_sigma = n.sigma_e;
  c.beta_sigma = n.sigma_beta_at_90 * grow * (4.0 / v) / std::sin(psi);
  c.beta = std::min(m.beta0, -1 + s * x) + c.beta_sigma * g(rng);
  return c;
}

}  // namespace collide
