#include "analysis/shot_uncertainty.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <utility>

namespace collide {
namespace {

Vec3 drawVec(const Vec3& mean, const Eigen::Matrix3d& cov, std::mt19937_64& rng, bool nominal) {
  if (nominal || !cov.allFinite()) return mean;
  std::normal_distribution<double> nd;
  const Eigen::LLT<Eigen::Matrix3d> llt(cov);
  if (llt.info() != Eigen::Success) return mean;
  return mean + llt.matrixL() * Vec3(nd(rng), nd(rng), nd(rng));
}

}  // namespace

PlaneTrack nominalTrack(const TrajectoryFit& f) {
  PlaneTrack d;
  d.t_ref = f.tRef_s();
  for (int k = 0; k < 2; ++k) d.c[k] = f.coefficients(k);
  return d;
}

PlaneTrack drawTrack(const TrajectoryFit& f, double inflation, const Eigen::Vector2d& drift_m_s,
                     double offset_m, std::mt19937_64& rng, bool nominal, unsigned sources) {
  std::normal_distribution<double> nd;
  PlaneTrack d = nominalTrack(f);
  if (nominal) return d;
  const int np = f.accelerationFixed() ? 2 : 3;
  for (int k = 0; k < 2; ++k) {
    const Eigen::MatrixXd cov = f.covariance(k).topLeftCorner(np, np) * inflation;
    if (!cov.allFinite()) continue;
    const Eigen::LLT<Eigen::MatrixXd> llt(cov);
    if (llt.info() != Eigen::Success) continue;
    if (sources & kFitNoise) {
      Eigen::VectorXd z(np);
      for (int i = 0; i < np; ++i) z[i] = nd(rng);
      d.c[k].head(np) += llt.matrixL() * z;
    }
    d.c[k][1] += drift_m_s[k];
    if (sources & kPositionOffset) d.c[k][0] += offset_m * nd(rng);
  }
  return d;
}

std::array<double, 2> drawDriftPair(double sigma_before, double sigma_after, std::mt19937_64& rng) {
  std::normal_distribution<double> nd;
  const double far_before = nd(rng), contact = nd(rng), far_after = nd(rng);
  return {sigma_before * (contact - far_before) / std::numbers::sqrt2,
          sigma_after * (far_after - contact) / std::numbers::sqrt2};
}

namespace {

// A fit's position variance at t_s on each image axis, m^2 (its covariance
// times its inflation); infinite without the fit.
Eigen::Vector2d positionVariance(const ShotModel& model, int s, int side, double t_s) {
  const TrajectoryFit* f = model.fit[s][side];
  if (!f) return Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  const Vec3 sigma = f->positionAt_m(t_s).sigma;
  return model.inflation[s][side] * sigma.head<2>().array().square().matrix();
}

}  // namespace

std::array<double, 2> contactPositionWeights(const ShotModel& model, double t_c_s) {
  std::array<double, 2> w{1.0, 1.0};
  for (int s = 0; s < 2; ++s) {
    const double vb = positionVariance(model, s, 0, t_c_s).sum();
    const double va = positionVariance(model, s, 1, t_c_s).sum();
    if (std::isfinite(vb) && std::isfinite(va) && vb > 0 && va > 0) w[s] = va / (va + vb);
  }
  return w;
}

namespace {

// The instant's four estimates (t_before, t_after, the kink of sphere 1, of
// sphere 2), to first order: how each moves per metre of each fit's position
// error at the instant (track 2 s + side, x and y: columns 0-7) and of the
// contact distance's error (column 8), and those errors' variances.
struct InstantErrors {
  static constexpr int kEstimates = 4, kErrors = 9;
  Eigen::Matrix<double, kEstimates, kErrors> sens =
      Eigen::Matrix<double, kEstimates, kErrors>::Zero();
  Eigen::Matrix<double, kErrors, 1> var = Eigen::Matrix<double, kErrors, 1>::Zero();
  std::array<bool, kEstimates> usable{};
};

std::optional<InstantErrors> instantErrors(const ShotModel& model, double t_c_s) {
  InstantErrors e;
  std::array<std::array<PlaneTrack, 2>, 2> track;
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      if (!model.fit[s][side]) return std::nullopt;
      track[s][side] = nominalTrack(*model.fit[s][side]);
      e.var.segment<2>(2 * (2 * s + side)) = positionVariance(model, s, side, t_c_s);
    }
  e.var[8] = model.contact_sigma * model.contact_sigma;
  // Contact distance d reached: |r|^2 = d^2 with r = P1 - P2, so
  // dt = (d dd - r . (dP1 - dP2)) / (r . v).
  for (int side = 0; side < 2; ++side) {
    const double t = side == 0 ? model.t_before : model.t_after;
    const Eigen::Vector2d r = track[0][side].pos(t) - track[1][side].pos(t);
    const double rv = r.dot(track[0][side].vel(t) - track[1][side].vel(t));
    if (!(std::abs(rv) > 0)) continue;
    e.sens.block<1, 2>(side, 2 * side) = -r.transpose() / rv;       // sphere 1's fit
    e.sens.block<1, 2>(side, 2 * (2 + side)) = r.transpose() / rv;  // sphere 2's fit
    e.sens(side, 8) = r.norm() / rv;
    e.usable[side] = true;
  }
  // Kink: (P - Q) . dv = 0 with dv = P' - Q': dt = -(dP - dQ) . dv / |dv|^2.
  for (int s = 0; s < 2; ++s) {
    const Eigen::Vector2d dv = track[s][0].vel(t_c_s) - track[s][1].vel(t_c_s);
    const double dv2 = dv.squaredNorm();
    if (!(dv2 > 0)) continue;
    e.sens.block<1, 2>(2 + s, 2 * (2 * s)) = -dv.transpose() / dv2;
    e.sens.block<1, 2>(2 + s, 2 * (2 * s + 1)) = dv.transpose() / dv2;
    e.usable[2 + s] = true;
  }
  return e;
}

// Least squares' weights (C^-1 1 / 1' C^-1 1) of the estimates `used`, with
// none negative: where estimates share most of their errors the plain
// weights come out large and of both signs, which leans on the linear model
// and amplifies what it leaves out (a fit's systematic error; unconstrained,
// they flagged 5 of 30 ideal shots). The most negative estimate is left out
// and the rest weighed again, until none is. Empty when none is left or the
// solve fails.
std::optional<std::array<double, InstantErrors::kEstimates>> nonNegativeWeights(
    const InstantErrors& e, std::vector<int> used) {
  while (!used.empty()) {
    const int m = static_cast<int>(used.size());
    Eigen::MatrixXd cov(m, m);
    for (int a = 0; a < m; ++a)
      for (int b = 0; b < m; ++b) {
        double c = 0;
        for (int k = 0; k < InstantErrors::kErrors; ++k)
          if (e.sens(used[a], k) != 0 && e.sens(used[b], k) != 0)
            c += e.sens(used[a], k) * e.sens(used[b], k) * e.var[k];
        cov(a, b) = c;
      }
    // The estimates' errors can be (nearly) dependent: along the line of
    // centres the two kinks add up to t_before + t_after. A ridge of 1e-9 of
    // the largest variance keeps the solve defined.
    cov.diagonal().array() += 1e-9 * std::max(cov.diagonal().maxCoeff(), 1e-300);
    const Eigen::VectorXd x = cov.ldlt().solve(Eigen::VectorXd::Ones(m));
    const double sum = x.sum();
    if (!x.allFinite() || !(sum > 0)) return std::nullopt;
    Eigen::Index worst = 0;
    if (x.minCoeff(&worst) >= 0) {
      std::array<double, InstantErrors::kEstimates> w{};
      for (int a = 0; a < m; ++a) w[used[a]] = x[a] / sum;
      return w;
    }
    used.erase(used.begin() + worst);
  }
  return std::nullopt;
}

}  // namespace

namespace {

// A sphere's pre- and post-impact tracks bend at the instant: their
// velocities there differ (kinkTime has a root to find).
bool bends(const PlaneTrack& pre, const PlaneTrack& post, double t_s) {
  return (pre.vel(t_s) - post.vel(t_s)).squaredNorm() > 0;
}

// ShotUncertainty::kink_gap_var_per_offset_var: a per-axis offset of sigma o
// on each of a sphere's two tracks moves its kink by (dP_pre - dP_post) . dv
// / |dv|^2, of variance 2 o^2 / |dv|^2; the spheres' tracks are their own.
double kinkGapVarPerOffsetVar(const ShotModel& model, double t_c_s) {
  double sum = 0;
  for (int s = 0; s < 2; ++s) {
    if (!model.fit[s][0] || !model.fit[s][1]) return std::numeric_limits<double>::quiet_NaN();
    const PlaneTrack pre = nominalTrack(*model.fit[s][0]), post = nominalTrack(*model.fit[s][1]);
    const double dv2 = (pre.vel(t_c_s) - post.vel(t_c_s)).squaredNorm();
    if (!(dv2 > 0)) return std::numeric_limits<double>::quiet_NaN();
    sum += 2 / dv2;
  }
  return sum;
}

}  // namespace

InstantWeights instantWeights(const ShotModel& model, double t_c_s) {
  const InstantWeights unchanged{model.w_before, {0.0, 0.0}};
  const std::optional<InstantErrors> e = instantErrors(model, t_c_s);
  if (!e) return unchanged;
  // An estimate resting on a variance that is not finite is left out.
  std::vector<int> used;
  for (int i = model.contact_reached ? 0 : 2; i < InstantErrors::kEstimates; ++i) {
    bool finite = e->usable[i];
    for (int k = 0; k < InstantErrors::kErrors && finite; ++k)
      finite = e->sens(i, k) == 0 || std::isfinite(e->var[k]);
    if (finite) used.push_back(i);
  }
  const auto w = nonNegativeWeights(*e, std::move(used));
  if (!w) return unchanged;
  const double contact = (*w)[0] + (*w)[1];
  return {contact > 1e-12 ? (*w)[0] / contact : 0.5, {(*w)[2], (*w)[3]}};
}

ShotDraw evaluateShot(const ShotModel& in, std::mt19937_64& rng, bool nominal, unsigned sources) {
  const auto drawn = [&](UncertaintySource s) { return !nominal && (sources & s); };
  ShotDraw o;
  std::array<std::array<PlaneTrack, 2>, 2> d;
  std::array<double, 2> rate_before{0, 0};  // each sphere's pre-impact depth-rate deviate
  // The dots' drift of each sphere's two fits, drawn together (anti-correlated).
  std::array<std::array<Eigen::Vector2d, 2>, 2> drift;
  for (int s = 0; s < 2; ++s)
    for (int k = 0; k < 2; ++k) {
      const auto pair = drawn(kCentreDrift) ? drawDriftPair(in.drift[s][0], in.drift[s][1], rng)
                                            : std::array<double, 2>{0, 0};
      drift[s][0][k] = pair[0], drift[s][1][k] = pair[1];
    }
  for (int s = 0; s < 2; ++s)
    for (int side = 0; side < 2; ++side) {
      d[s][side] = drawTrack(*in.fit[s][side], in.inflation[s][side], drift[s][side], in.offset[s],
                             rng, nominal, sources);
      const DepthCoupling& c = in.depth[s][side];
      if (!drawn(kDepth) || (c.per_rate.isZero() && c.per_offset.isZero())) continue;  // no depth
      std::normal_distribution<double> nd;
      const double rate = nd(rng), offset = nd(rng);
      for (int k = 0; k < 2; ++k)
        d[s][side].c[k][1] += c.per_rate[k] * rate + c.per_offset[k] * offset;
      if (side == 0) rate_before[s] = rate;
    }
  const double contact =
      drawn(kContactDistance)
          ? in.contact + in.contact_sigma * std::normal_distribution<double>()(rng)
          : in.contact;
  // Without the contact distance reached, the instant is where the tracks
  // bend: the kinks alone (their weights add up to 1), both instants there.
  const bool reached = in.contact_reached;
  const double tb =
      nominal || !reached ? in.t_before : contactTime(d[0][0], d[1][0], contact, in.t_before);
  const double ta =
      nominal || !reached ? in.t_after : contactTime(d[0][1], d[1][1], contact, in.t_after);
  const double w_kinks = in.w_kink[0] + in.w_kink[1];
  o.t_c = reached ? (1 - w_kinks) * (in.w_before * tb + (1 - in.w_before) * ta) : 0.0;
  std::array<double, 2> kink{};
  for (int s = 0; s < 2; ++s) {
    kink[s] = kinkTime(d[s][0], d[s][1], in.t_before);
    if (in.w_kink[s] > 0) o.t_c += in.w_kink[s] / (reached ? 1.0 : w_kinks) * kink[s];
  }
  if (bends(d[0][0], d[0][1], in.t_before) && bends(d[1][0], d[1][1], in.t_before))
    o.kink_gap = kink[0] - kink[1];
  if (!reached && !(w_kinks > 0)) o.t_c = in.t_before;
  o.dt_ba = reached ? tb - ta : 0.0;
  ContactState st;
  for (int s = 0; s < 2; ++s) {
    const double wp = in.w_position_before[s];
    st.position_m[s] = wp * d[s][0].pos(o.t_c) + (1 - wp) * d[s][1].pos(o.t_c);
    o.v_before[s] = Vec3(d[s][0].vel(o.t_c).x(), d[s][0].vel(o.t_c).y(), 0);
    const double z = drawn(kOutOfPlaneSpeed) ? std::normal_distribution<double>()(rng) : 0.0;
    if (const auto& vz = in.vz_before[s]) {
      const double shared = std::clamp(in.vz_before_shared[s], 0.0, (*vz)[1]);
      o.v_before[s].z() =
          (*vz)[0] + shared * rate_before[s] + std::sqrt((*vz)[1] * (*vz)[1] - shared * shared) * z;
    } else
      o.v_before[s].z() = in.vz_fraction * o.v_before[s].norm() * z;
    o.v_after[s] = Vec3(d[s][1].vel(o.t_c).x(), d[s][1].vel(o.t_c).y(), 0);
    o.w_before[s] = drawVec(in.spin[s][0], in.spin_cov[s][0], rng, !drawn(kSpins));
    o.w_after[s] = drawVec(in.spin[s][1], in.spin_cov[s][1], rng, !drawn(kSpins));
  }
  st.v_before = o.v_before;
  st.v_after = o.v_after;
  st.w_before = o.w_before;
  st.w_after = o.w_after;
  ShotInverseSettings inv;
  inv.diameter_m = in.diameter;
  inv.mass_kg = in.mass;
  for (int s = 0; s < 2; ++s) inv.spin_change_cov[s] = in.spin_cov[s][0] + in.spin_cov[s][1];
  inv.nz_sigma = in.nz_sigma;
  const double sz = std::max(in.nz_sigma, 1e-6);
  inv.nz_prior =
      in.nz_mean + (drawn(kLineOfCentresZ) ? sz * std::normal_distribution<double>()(rng) : 0.0);
  o.inverse = invertShot(st, inv);
  o.v_after = o.inverse.v_after;
  o.ok = o.inverse.ok;
  return o;
}

void Spread::add(double x) {
  if (!std::isfinite(x)) return;
  ++n;
  const double d = x - mean;
  mean += d / n;
  m2 += d * (x - mean);
}

double Spread::sigma() const {
  if (n < 2) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(std::max(0.0, m2 / (n - 1)));
}

ShotUncertainty propagateShot(const ShotModel& model, int draws, std::uint64_t seed,
                              unsigned sources) {
  ShotUncertainty u;
  std::mt19937_64 rng(seed);
  u.nominal = evaluateShot(model, rng, true);
  if (!u.nominal.ok) return u;
  u.kink_gap_var_per_offset_var = kinkGapVarPerOffsetVar(model, u.nominal.t_c);
  for (int i = 0; i < draws; ++i) {
    const ShotDraw o = evaluateShot(model, rng, false, sources);
    if (!o.ok) continue;
    const WaltonMeasurement& m = o.inverse.m;
    u.e.add(m.e), u.beta.add(m.beta), u.beta_from_impulse.add(m.beta_from_impulse), u.f.add(m.f);
    u.gamma_deg.add(m.before.gamma_rad * 180 / std::numbers::pi);
    u.vn.add(m.before.v_n_m_s), u.vs.add(m.before.v_s_m_s), u.vs_after.add(o.inverse.vs_after);
    u.t_c.add(o.t_c), u.dt_ba.add(o.dt_ba);
    u.kinetic_energy_change.add(o.inverse.kinetic_energy_change_J);
    u.n_z.add(o.inverse.n_z);
    u.beta_spin_minus_impulse.add(m.beta - m.beta_from_impulse);
    u.kink_gap.add(o.kink_gap);
    for (int s = 0; s < 2; ++s)
      for (int k = 0; k < 3; ++k)
        u.v_before[s][k].add(o.v_before[s][k]), u.v_after[s][k].add(o.v_after[s][k]);
  }
  return u;
}

double betaSpinWeight(double vs, double vi, double vd) {
  if (!std::isfinite(vs) || !std::isfinite(vi) || !std::isfinite(vd) || !(vi > 0) || !(vd > 0))
    return 1.0;
  const double cov = 0.5 * (vs + vi - vd);
  return std::clamp((vi - cov) / vd, 0.0, 1.0);
}

double combinedBetaSigma(double vs, double vi, double vd, double w) {
  if (w >= 1.0) return std::sqrt(vs);
  const double cov = 0.5 * (vs + vi - vd);
  return std::sqrt(std::max(0.0, w * w * vs + (1 - w) * (1 - w) * vi + 2 * w * (1 - w) * cov));
}

namespace {
std::array<double, 3> betaVariances(const ShotUncertainty& u) {
  return {std::pow(u.beta.sigma(), 2), std::pow(u.beta_from_impulse.sigma(), 2),
          std::pow(u.beta_spin_minus_impulse.sigma(), 2)};
}
}  // namespace

double betaSpinWeight(const ShotUncertainty& u) {
  const auto [vs, vi, vd] = betaVariances(u);
  return betaSpinWeight(vs, vi, vd);
}

double combinedBetaSigma(const ShotUncertainty& u, double w) {
  const auto [vs, vi, vd] = betaVariances(u);
  return combinedBetaSigma(vs, vi, vd, w);
}

std::vector<ErrorBudgetRow> errorBudget(const ShotModel& model, int draws, std::uint64_t seed,
                                        double beta_spin_weight) {
  static constexpr std::pair<UncertaintySource, const char*> kRows[] = {
      {kFitNoise, "trajectory_fits"},
      {kCentreDrift, "centre_drift"},
      {kDepth, "depth"},
      {kOutOfPlaneSpeed, "out_of_plane_speed"},
      {kPositionOffset, "position_offset"},
      {kContactDistance, "contact_distance"},
      {kSpins, "spins"},
      {kLineOfCentresZ, "line_of_centres_z"}};
  static_assert(std::size(kRows) == 8 && kEverySource == (1u << 8) - 1, "a row per source");
  std::vector<ErrorBudgetRow> rows;
  for (const auto& [source, name] : kRows) {
    const ShotUncertainty u = propagateShot(model, draws, seed, source);
    if (!u.nominal.ok) return {};
    // NaN where the quantity is (beta without spins).
    rows.push_back(
        {source, name, u.e.sigma(), combinedBetaSigma(u, beta_spin_weight), u.gamma_deg.sigma()});
  }
  return rows;
}

}  // namespace collide
