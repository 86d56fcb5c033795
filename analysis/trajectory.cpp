#include "analysis/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <string>
#include <vector>

namespace collide {

namespace {

const char* kAxisName[3] = {"x", "y", "z"};

std::string fmt(double v, const char* spec = "%.6g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, spec, v);
  return buf;
}

}  // namespace

Estimate3 TrajectoryFit::evaluate(const Eigen::Vector3d& basis) const {
  Estimate3 e;
  for (int k = 0; k < dims_; ++k) {
    e.value[k] = basis.dot(coef_[k]);
    // Skip terms with a zero basis entry: a fixed acceleration is exact even
    // when the rest of the covariance is unknown (NaN), and 0 * NaN would hide that.
    double var = 0.0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (basis[i] != 0.0 && basis[j] != 0.0) var += basis[i] * cov_[k](i, j) * basis[j];
    e.sigma[k] = std::sqrt(var);
  }
  return e;
}

Estimate3 TrajectoryFit::positionAt_m(double t_s) const {
  const double tau = t_s - t_ref_s_;
  return evaluate({1.0, tau, tau * tau});
}

Estimate3 TrajectoryFit::velocityAt_m_s(double t_s) const {
  const double tau = t_s - t_ref_s_;
  return evaluate({0.0, 1.0, 2.0 * tau});
}

Estimate3 TrajectoryFit::acceleration_m_s2() const {
  return evaluate({0.0, 0.0, 2.0});
}

Eigen::Matrix3d TrajectoryFit::positionCovariance_m2(double t_s) const {
  const Vec3 sigma = positionAt_m(t_s).sigma;
  return sigma.array().square().matrix().asDiagonal();
}

Result<TrajectoryFit> fitTrajectory(const Eigen::VectorXd& times_s,
                                    const Eigen::MatrixXd& positions_m, const Weights& weights,
                                    double t_ref_s, const TrajectoryOptions& options) {
  const Eigen::Index n = times_s.size();
  const int dims = int(positions_m.cols());
  if (dims != 2 && dims != 3)
    return fail("trajectory: positions have " + std::to_string(dims) +
                " columns; give x, y (2 columns) or x, y, z (3 columns) per sample");
  if (positions_m.rows() != n)
    return fail("trajectory: " + std::to_string(n) + " times but " +
                std::to_string(positions_m.rows()) + " positions; give one time per position");
  const bool fixed = options.fixed_acceleration_m_s2.has_value();
  const int params = fixed ? 2 : 3;
  if (n < params)
    return fail(
        "trajectory: " + std::to_string(n) + " samples; a " +
        (fixed ? std::string("fit with fixed acceleration") : std::string("quadratic fit")) +
        " needs at least " + std::to_string(params) + " (track more frames)");
  if (!std::isfinite(t_ref_s))
    return fail("trajectory: reference time t_ref is not finite; pass a time near the samples");
  if (fixed && !options.fixed_acceleration_m_s2->head(dims).allFinite())
    return fail("trajectory: the fixed acceleration is not finite; give a finite vector (m/s^2)");
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!std::isfinite(times_s[i]))
      return fail("trajectory: time of sample " + std::to_string(i) +
                  " is not finite; drop that sample");
    if (!positions_m.row(i).allFinite())
      return fail("trajectory: position of sample " + std::to_string(i) +
                  " is not finite; drop that sample");
  }
  const std::set<double> distinct(times_s.begin(), times_s.end());
  if (distinct.size() == 1)
    return fail("trajectory: all " + std::to_string(n) + " samples have the same time " +
                fmt(times_s[0]) + " s; a fit needs samples from different frames");
  if (int(distinct.size()) < params)
    return fail("trajectory: only " + std::to_string(distinct.size()) +
                " distinct sample times; the fit needs at least " + std::to_string(params));

  const Eigen::ArrayXd tau = times_s.array() - t_ref_s;
  Eigen::MatrixXd design(n, params);
  design.col(0).setOnes();
  design.col(1) = tau.matrix();
  if (!fixed) design.col(2) = tau.square().matrix();

  // The fit with a known acceleration (and the drag's change along the
  // track, its rate `jerk` and the rate's rate `snap`) taken out of the
  // positions, or the acceleration fitted.
  const auto fitWith = [&](const Vec3& acceleration, const Vec3& jerk,
                           const Vec3& snap) -> Result<TrajectoryFit> {
    TrajectoryFit fit;
    fit.dims_ = dims;
    fit.t_ref_s_ = t_ref_s;
    fit.t_first_s_ = times_s.minCoeff();
    fit.t_last_s_ = times_s.maxCoeff();
    fit.acceleration_fixed_ = fixed;
    for (int k = 0; k < dims; ++k) {
      Eigen::VectorXd y = positions_m.col(k);
      double half_acc = 0.0;
      if (fixed) {
        // Known acceleration: subtract its quadratic term (and the drag's
        // change, its cubic and quartic ones) and fit the straight line that is left.
        half_acc = 0.5 * acceleration[k];
        y.array() -= half_acc * tau.square() + jerk[k] / 6.0 * tau.cube() +
                     snap[k] / 24.0 * tau.square().square();
      }
      auto axis = weightedLeastSquares(design, y, weights,
                                       std::string("trajectory ") + kAxisName[k] + " positions");
      if (!axis) return axis.error();
      fit.coef_[k].head(params) = axis->coefficients;
      fit.cov_[k].topLeftCorner(params, params) = axis->covariance;
      if (fixed) fit.coef_[k][2] = half_acc;
      fit.residual_rms_m_[k] = axis->residualRms();
      fit.axis_fit_[k] = std::move(axis).value();
    }
    return fit;
  };
  const Vec3 known = fixed ? *options.fixed_acceleration_m_s2 : Vec3::Zero();
  auto fit = fitWith(known, Vec3::Zero(), Vec3::Zero());
  if (!fit || !fixed || !options.drag || !options.drag->acts()) return fit;
  // The drag at the fitted velocity, and its first and second rates of
  // change from points half the track's reach either side of t_ref (the
  // velocity turns under gravity along the track); twice, the second time
  // from the velocity the drag's own fit gives (the first is off by half the
  // speed the drag took: 0.1 % of the drag).
  const double h = 0.5 * std::max(times_s.maxCoeff() - t_ref_s, t_ref_s - times_s.minCoeff());
  for (int pass = 0; pass < 2; ++pass) {
    const TrajectoryFit& prev = *fit;
    const auto dragAt = [&](double t) {
      return options.drag->acceleration(prev.velocityAt_m_s(t).value);
    };
    const Vec3 a0 = dragAt(t_ref_s), up = dragAt(t_ref_s + h), down = dragAt(t_ref_s - h);
    const Vec3 jerk = h > 0 ? Vec3((up - down) / (2 * h)) : Vec3::Zero();
    const Vec3 snap = h > 0 ? Vec3((up - 2 * a0 + down) / (h * h)) : Vec3::Zero();
    auto next = fitWith(known + a0, jerk, snap);
    if (!next) return next.error();
    fit = std::move(next);
  }
  return fit;
}

namespace {

// Polynomials as coefficient vectors, lowest power first.
using Poly = std::vector<double>;

double evalPoly(const Poly& c, double x) {
  double v = 0.0;
  for (auto it = c.rbegin(); it != c.rend(); ++it) v = v * x + *it;
  return v;
}

Poly derivative(const Poly& c) {
  Poly d;
  for (size_t i = 1; i < c.size(); ++i) d.push_back(double(i) * c[i]);
  return d;
}

struct Crossing {
  double x;
  int direction;  // +1: the polynomial goes from negative to positive
};

// Every sign change of c in [lo, hi]. Between consecutive sign changes of the
// derivative the polynomial is monotonic, so each piece holds at most one
// root and bisection on it cannot miss or skip one; recursing on the degree
// gives those pieces without any tolerance on the leading coefficients.
std::vector<Crossing> signChanges(const Poly& c, double lo, double hi) {
  std::vector<double> cuts{lo};
  if (c.size() > 2)
    for (const Crossing& r : signChanges(derivative(c), lo, hi)) cuts.push_back(r.x);
  cuts.push_back(hi);
  std::vector<Crossing> roots;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    double a = cuts[i], b = cuts[i + 1];
    const double fa = evalPoly(c, a), fb = evalPoly(c, b);
    // Half-open (a, b] so a root on a cut is counted once; a root exactly at lo
    // is counted by the first piece.
    const bool starts_at_zero = i == 0 && fa == 0.0 && fb != 0.0;
    if (!starts_at_zero && !((fa < 0 && fb >= 0) || (fa > 0 && fb <= 0))) continue;
    const int direction = fb > fa ? +1 : -1;
    if (fb == 0.0) {
      roots.push_back({b, direction});
      continue;
    }
    if (starts_at_zero) {
      roots.push_back({a, direction});
      continue;
    }
    for (int it = 0; it < 200; ++it) {
      const double m = 0.5 * (a + b);
      if (m <= a || m >= b) break;
      const double fm = evalPoly(c, m);
      if (fm == 0.0) {
        a = b = m;
        break;
      }
      ((fm < 0) == (fa < 0) ? a : b) = m;
    }
    roots.push_back({0.5 * (a + b), direction});
  }
  return roots;
}

}  // namespace

Result<CollisionInstant> collisionInstant(const TrajectoryFit& a, const TrajectoryFit& b,
                                          double contact_distance_m, CollisionSide side,
                                          std::optional<double> search_margin_s) {
  if (!std::isfinite(contact_distance_m) || contact_distance_m <= 0)
    return fail("collision instant: contact distance " + fmt(contact_distance_m) +
                " m must be finite and > 0 (the mean of the two diameters)");
  const double span_s = std::max(a.tLast_s() - a.tFirst_s(), b.tLast_s() - b.tFirst_s());
  const double margin_s = search_margin_s.value_or(span_s);
  if (!std::isfinite(margin_s) || margin_s < 0)
    return fail("collision instant: search margin " + fmt(margin_s) + " s must be finite and >= 0");
  double lo = std::min(a.tFirst_s(), b.tFirst_s());
  double hi = std::max(a.tLast_s(), b.tLast_s());
  if (side == CollisionSide::kBefore)
    hi += margin_s;
  else
    lo -= margin_s;

  // Expand both fits about the window centre in u = (t - tc)/h in [-1, 1]:
  // each coordinate difference is p + q u + r u^2 with p, q, r the differences
  // of position, velocity*h and acceleration*h^2/2 at tc. Working in u keeps
  // the quartic's coefficients of comparable size.
  const double tc = 0.5 * (lo + hi);
  const double h = std::max(0.5 * (hi - lo), 1e-12);
  const Vec3 p = a.positionAt_m(tc).value - b.positionAt_m(tc).value;
  const Vec3 q = (a.velocityAt_m_s(tc).value - b.velocityAt_m_s(tc).value) * h;
  const Vec3 r = (a.acceleration_m_s2().value - b.acceleration_m_s2().value) * (0.5 * h * h);
  Poly g(5, 0.0);  // |dr(u)|^2 - d^2
  for (int k = 0; k < 3; ++k) {
    g[0] += p[k] * p[k];
    g[1] += 2 * p[k] * q[k];
    g[2] += q[k] * q[k] + 2 * p[k] * r[k];
    g[3] += 2 * q[k] * r[k];
    g[4] += r[k] * r[k];
  }
  g[0] -= contact_distance_m * contact_distance_m;

  const std::vector<Crossing> crossings = signChanges(g, -1.0, 1.0);
  std::optional<double> u_root;
  if (side == CollisionSide::kBefore) {
    for (const Crossing& c : crossings)
      if (c.direction < 0) {
        u_root = c.x;
        break;
      }
  } else {
    for (auto it = crossings.rbegin(); it != crossings.rend(); ++it)
      if (it->direction > 0) {
        u_root = it->x;
        break;
      }
  }
  if (!u_root)
    return fail("collision instant: the fitted centres never come " +
                std::string(side == CollisionSide::kBefore ? "within " : "apart through ") +
                fmt(contact_distance_m) + " m between t = " + fmt(lo) + " s and " + fmt(hi) +
                " s; check the tracks, the contact distance or widen the search margin");

  CollisionInstant out;
  out.t_s = tc + h * *u_root;
  // Implicit function theorem on F(t, fits) = |dr|^2 - d^2 = 0:
  //   var t = sum_k dr_k^2 (var rA_k + var rB_k) / (dr . dv)^2.
  const Estimate3 pa = a.positionAt_m(out.t_s), pb = b.positionAt_m(out.t_s);
  const Vec3 dr = pa.value - pb.value;
  const Vec3 dv = a.velocityAt_m_s(out.t_s).value - b.velocityAt_m_s(out.t_s).value;
  const double num =
      (dr.array().square() * (pa.sigma.array().square() + pb.sigma.array().square())).sum();
  const double slope = dr.dot(dv);
  out.sigma_s =
      slope != 0.0 ? std::sqrt(num) / std::abs(slope) : std::numeric_limits<double>::infinity();
  return out;
}

}  // namespace collide
