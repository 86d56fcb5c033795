#include "analysis/shot_uncertainty.hpp"

#include <algorithm>
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

PlaneTrack drawTrack(const TrajectoryFit& f, double inflation, const Eigen::Vector2d& drift_m_s,
                     double offset_m, std::mt19937_64& rng, bool nominal, unsigned sources) {
  std::normal_distribution<double> nd;
  PlaneTrack d;
  d.t_ref = f.tRef_s();
  const int np = f.accelerationFixed() ? 2 : 3;
  for (int k = 0; k < 2; ++k) {
    d.c[k] = f.coefficients(k);
    if (nominal) continue;
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
  const double tb = nominal ? in.t_before : contactTime(d[0][0], d[1][0], contact, in.t_before);
  const double ta = nominal ? in.t_after : contactTime(d[0][1], d[1][1], contact, in.t_after);
  o.t_c = in.w_before * tb + (1 - in.w_before) * ta;
  o.dt_ba = tb - ta;
  ContactState st;
  for (int s = 0; s < 2; ++s) {
    st.position_m[s] = d[s][0].pos(o.t_c);
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
    for (int s = 0; s < 2; ++s)
      for (int k = 0; k < 3; ++k)
        u.v_before[s][k].add(o.v_before[s][k]), u.v_after[s][k].add(o.v_after[s][k]);
  }
  return u;
}

std::vector<ErrorBudgetRow> errorBudget(const ShotModel& model, int draws, std::uint64_t seed) {
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
    rows.push_back({source, name, u.e.sigma(), u.beta.sigma(), u.gamma_deg.sigma()});
  }
  return rows;
}

}  // namespace collide
