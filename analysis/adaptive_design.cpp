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

// How a shot's uncertainties grow with the angle, from the shots measured so
// far: sigma_beta ~ a / sin psi and sigma_x ~ b / sin^2 psi at the campaign's
// speeds (v_s = V sin psi).
struct NoiseModel {
  double a = 0.02, b = 0.01;
  double sigmaBeta(double psi) const { return a / std::sin(psi); }
  double sigmaX(double psi) const { return b / (std::sin(psi) * std::sin(psi)); }
};

NoiseModel noiseModel(std::span<const CampaignShot> shots) {
  std::vector<double> a, b;
  for (const CampaignShot& s : shots) {
    const double psi = s.incidenceAngle_rad();
    if (!(std::sin(psi) > 0.05) || !(s.beta_sigma > 0)) continue;
    a.push_back(s.beta_sigma * std::sin(psi));
    b.push_back(s.cotIncidenceSigma() * std::sin(psi) * std::sin(psi));
  }
  NoiseModel m;
  if (!a.empty()) m.a = median(a);
  if (!b.empty()) m.b = median(b);
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
    if (s.v_s_m_s > 0) oblique.push_back(s);
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

  NextShot next;
  double best = INFINITY, best_p = 0;
  for (const double g : candidateAngles(o)) {
    const double psi = g / kDeg, x = 1 / std::tan(psi);
    const double sb = noise.sigmaBeta(psi), sx = noise.sigmaX(psi);
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
  return next;
}

CampaignShot synthesizeShot(const Material& m, double psi_deg, const ShotNoise& n,
                            std::mt19937_64& rng, double K) {
  std::normal_distribution<double> g(0, 1);
  const double psi = psi_deg / kDeg;
  const double x = 1 / std::tan(psi), s = (1 + 1 / K) * (1 + m.e) * m.mu;
  CampaignShot c;
  c.v_n_m_s = -n.relative_speed_m_s * std::cos(psi) + n.sigma_v_m_s * g(rng);
  c.v_s_m_s = n.relative_speed_m_s * std::sin(psi) + n.sigma_v_m_s * g(rng);
  c.v_n_sigma_m_s = c.v_s_sigma_m_s = n.sigma_v_m_s;
  c.e = m.e + n.sigma_e * g(rng);
  c.e_sigma = n.sigma_e;
  c.beta_sigma = n.sigma_beta_at_90 / std::sin(psi);
  c.beta = std::min(m.beta0, -1 + s * x) + c.beta_sigma * g(rng);
  return c;
}

}  // namespace collide
