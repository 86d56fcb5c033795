// The uncertainty stage (analysis/shot_uncertainty.hpp) on tracks sampled
// from a known collision (analysis/walton.hpp's forward operator, free flight
// under gravity written out here): exact tracks give the exact properties and
// instant; noisy tracks give errors whose spread the stated sigmas match.
#include "analysis/shot_uncertainty.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

using namespace collide;

namespace {

constexpr double kD = 0.0254, kM = 0.00978, kTc = 0.0305, kDt = 1e-3;
const Vec3 kG(0, -9.80665, 0);

struct Truth {
  std::array<Sphere, 2> before, after;
  ContactOutcome contact;
};

Truth collision(double angle_rad) {
  Truth t;
  const Vec3 n(std::cos(angle_rad), std::sin(angle_rad), 0);
  for (Sphere& s : t.before) s.mass_kg = kM, s.diameter_m = kD;
  t.before[0].position_m = -0.5 * kD * n;
  t.before[1].position_m = 0.5 * kD * n;
  t.before[0].velocity_m_s = Vec3(2.0, 0.05, 0);
  t.before[1].velocity_m_s = Vec3(-2.2, -0.04, 0);
  t.before[0].spin_rad_s = Vec3(0, 0, 12);
  t.before[1].spin_rad_s = Vec3(0, 0, -8);
  auto c = collideSpheres(t.before[0], t.before[1], Material{0.97, 0.176, 0.44});
  if (!c) throw std::runtime_error(c.error().message);
  t.after = c->after;
  t.contact = c->contact;
  return t;
}

// Samples sphere s on one side (20 frames), centre noise sigma_m, fitted with
// known sigmas and gravity fixed. `warp`, when given, moves each true centre
// (time from the collision, centre) before the noise.
TrajectoryFit track(const Truth& t, int s, int side, double sigma_m, std::mt19937_64& rng,
                    const std::function<Vec3(double, const Vec3&)>& warp = {}) {
  std::normal_distribution<double> nd;
  const int n = 20;
  Eigen::VectorXd time(n), sig = Eigen::VectorXd::Constant(n, std::max(sigma_m, 1e-9));
  Eigen::MatrixXd pos(n, 2);
  const Sphere& sp = side == 0 ? t.before[s] : t.after[s];
  for (int k = 0; k < n; ++k) {
    const double tau = side == 0 ? -(k + 0.3) * kDt : (k + 0.6) * kDt;
    time[k] = kTc + tau;
    Vec3 r = sp.position_m + sp.velocity_m_s * tau + 0.5 * kG * tau * tau;
    if (warp) r = warp(tau, r);
    pos(k, 0) = r.x() + sigma_m * nd(rng);
    pos(k, 1) = r.y() + sigma_m * nd(rng);
  }
  TrajectoryOptions o;
  o.fixed_acceleration_m_s2 = kG;
  auto f = fitTrajectory(time, pos, Weights::fromSigmas(sig), kTc, o);
  if (!f) throw std::runtime_error(f.error().message);
  return *f;
}

struct MeasuredShot {
  std::array<std::array<TrajectoryFit, 2>, 2> fits;
  ShotModel model;
  /// w_before had the contact distance's two instants been weighed alone
  /// (beforeInstantWeight), as they were before the kinks.
  double pair_w_before = 0.5;
};

MeasuredShot measured(const Truth& t, double sigma_m, std::mt19937_64& rng) {
  MeasuredShot s;
  ShotModel& m = s.model;
  for (int i = 0; i < 2; ++i)
    for (int side = 0; side < 2; ++side) {
      s.fits[i][side] = track(t, i, side, sigma_m, rng);
      m.inflation[i][side] = 1;
      m.drift[i][side] = 0;
      m.spin[i][side] = (side == 0 ? t.before : t.after)[i].spin_rad_s;
      m.spin_cov[i][side] = Eigen::Matrix3d::Identity() * 1e-6;
    }
  m.offset = {0, 0};
  m.diameter = {kD, kD};
  m.mass = {kM, kM};
  m.contact = kD;
  m.nz_sigma = 1e-6;
  m.vz_fraction = 0;
  return s;
}

// The analysis' instants and weights (vision/shot_analysis.cpp, useInstants),
// with the contact distance stated to `contact_sigma_m`.
void bind(MeasuredShot& s, double contact_m = kD, double contact_sigma_m = 0) {
  s.model.contact = contact_m;
  s.model.contact_sigma = contact_sigma_m;
  for (int i = 0; i < 2; ++i)
    for (int side = 0; side < 2; ++side) s.model.fit[i][side] = &s.fits[i][side];
  auto cb = collisionInstant(s.fits[0][0], s.fits[1][0], contact_m, CollisionSide::kBefore);
  auto ca = collisionInstant(s.fits[0][1], s.fits[1][1], contact_m, CollisionSide::kAfter);
  if (!cb || !ca) throw std::runtime_error("no contact");
  s.model.t_before = cb->t_s;
  s.model.t_after = ca->t_s;
  std::array<double, 2> vn{};  // |v_n| before and after, at each side's instant
  for (int side = 0; side < 2; ++side) {
    const double at = side == 0 ? cb->t_s : ca->t_s;
    const Vec3 dr = s.fits[0][side].positionAt_m(at).value - s.fits[1][side].positionAt_m(at).value;
    const Vec3 dv =
        s.fits[0][side].velocityAt_m_s(at).value - s.fits[1][side].velocityAt_m_s(at).value;
    vn[side] = std::abs(dr.dot(dv)) / dr.norm();
  }
  s.model.w_before = beforeInstantWeight(cb->sigma_s, ca->sigma_s, contact_sigma_m, vn[0], vn[1]);
  s.pair_w_before = s.model.w_before;
  const double t_c = s.model.w_before * cb->t_s + (1 - s.model.w_before) * ca->t_s;
  const InstantWeights w = instantWeights(s.model, t_c);
  s.model.w_before = w.before;
  s.model.w_kink = w.kink;
  s.model.w_position_before = contactPositionWeights(s.model, t_c);
}

TEST(PropagateShot, ExactTracksGiveTheExactShot) {
  std::mt19937_64 rng(1);
  const Truth t = collision(0.5);
  MeasuredShot s = measured(t, 0.0, rng);
  bind(s);
  const ShotUncertainty u = propagateShot(s.model, 50);
  ASSERT_TRUE(u.nominal.ok);
  EXPECT_NEAR(u.nominal.t_c, kTc, 1e-9);
  EXPECT_NEAR(u.nominal.dt_ba, 0, 1e-9);
  const WaltonMeasurement& m = u.nominal.inverse.m;
  EXPECT_NEAR(m.e, 0.97, 1e-6);
  EXPECT_NEAR(m.beta, t.contact.beta, 1e-6);
  EXPECT_NEAR(m.f, t.contact.f, 1e-6);
  for (int i = 0; i < 2; ++i) {
    EXPECT_LT((u.nominal.v_before[i] - t.before[i].velocity_m_s).norm(), 1e-6);
    EXPECT_LT((u.nominal.v_after[i] - t.after[i].velocity_m_s).norm(), 1e-6);
  }
}

TEST(PropagateShot, StatedSigmasMatchTheErrorsMade) {
  // 0.02 mm centre noise (0.1 px at 120 px per diameter), 80 shots.
  std::mt19937_64 rng(2);
  const Truth t = collision(0.5);
  double pe = 0, pb = 0, pt = 0;
  const int n = 80;
  for (int i = 0; i < n; ++i) {
    MeasuredShot s = measured(t, 2e-5, rng);
    bind(s);
    const ShotUncertainty u = propagateShot(s.model, 200, 100 + i);
    ASSERT_TRUE(u.nominal.ok);
    const WaltonMeasurement& m = u.nominal.inverse.m;
    pe += std::pow((m.e - 0.97) / u.e.sigma(), 2);
    pb += std::pow((m.beta - t.contact.beta) / u.beta.sigma(), 2);
    pt += std::pow((u.nominal.t_c - kTc) / u.t_c.sigma(), 2);
  }
  pe = std::sqrt(pe / n), pb = std::sqrt(pb / n), pt = std::sqrt(pt / n);
  std::printf("pull RMS over %d shots: e %.2f, beta %.2f, t_c %.2f\n", n, pe, pb, pt);
  // 80 shots: a pull RMS is known to about +-8 %; 0.75..1.3 allows for the
  // Monte Carlo's own scatter (200 draws) and non-linearity.
  for (const double p : {pe, pb, pt}) {
    EXPECT_GT(p, 0.75);
    EXPECT_LT(p, 1.3);
  }
}

// The centres of touching spheres found a little nearer or further apart
// than the diameters (a radius bias): at grazing incidence (psi ~ 70 deg) the
// instants at which the centres are one contact distance apart, and with
// them the line of centres, move by dD / |v_n|, and e errs by several times
// its noise-only sigma. Drawing the contact distance with its stated sigma
// (which the instants' weights also know) covers it: pull RMS near 1 with
// it, far above without.
TEST(PropagateShot, ABiasedContactDistanceIsCoveredByItsStatedSigma) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> nd;
  const Truth t = collision(1.2);  // n at 69 deg to the approach (along x)
  const double sigma_d = 4e-5;     // 0.2 px at 0.2 mm per pixel
  double with = 0, without = 0;
  const int n = 40;
  for (int i = 0; i < n; ++i) {
    const double bias = sigma_d * nd(rng);
    for (const double stated : {sigma_d, 0.0}) {
      std::mt19937_64 same(1000 + i);            // the same tracks for both
      MeasuredShot s = measured(t, 5e-7, same);  // noise well below the bias
      bind(s, kD + bias, stated);
      const ShotUncertainty u = propagateShot(s.model, 200, 500 + i);
      ASSERT_TRUE(u.nominal.ok);
      const double pull = (u.nominal.inverse.m.e - 0.97) / u.e.sigma();
      (stated > 0 ? with : without) += pull * pull;
    }
  }
  with = std::sqrt(with / n), without = std::sqrt(without / n);
  std::printf("e pull RMS over %d shots: %.2f with the contact distance drawn, %.2f without\n", n,
              with, without);
  EXPECT_GT(with, 0.7);
  EXPECT_LT(with, 1.4);
  EXPECT_GT(without, 3.0);
}

// Each sphere's centre does not jump at the impact, so its position at
// contact is measured twice, by the pre- and the post-impact fit, with
// independent noise. Weighted by their inverse variances: a fit with four
// times the other's centre noise gets 1/17 of the weight; two alike about
// half each. At grazing incidence (psi 69 deg) the line of centres' error is
// most of e's: with the pre-impact fits four times noisier than the
// post-impact ones, taking the positions from both (mostly the better ones)
// halves the line of centres' error and cuts e's by more than a fifth
// against the pre-impact fits' positions alone, with the stated sigmas
// still covering the errors. The instant, weighed by least squares over the
// contact distance's two instants and the spheres' kinks, is no worse than
// the two instants alone (here, in the normal direction, the kinks add up
// to what those two say; they help where the contact distance errs).
TEST(PropagateShot, BothFitsPlaceTheContactAndEErrsLessAtGrazingIncidence) {
  {
    std::mt19937_64 rng(11);
    const Truth t = collision(1.2);
    MeasuredShot s = measured(t, 2e-5, rng);
    for (int i = 0; i < 2; ++i) s.fits[i][0] = track(t, i, 0, 8e-5, rng);
    bind(s);
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(s.model.w_position_before[i], 1.0 / 17, 0.01);
    MeasuredShot alike = measured(t, 2e-5, rng);
    bind(alike);
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(alike.model.w_position_before[i], 0.5, 0.1);
  }
  std::mt19937_64 rng(12);
  const Truth t = collision(1.2);
  const Vec3 n_true(std::cos(1.2), std::sin(1.2), 0);
  const auto angle = [&](const ShotDraw& d) {
    return d.inverse.m.before.normal.cross(n_true).norm();
  };
  const int n = 80;
  // [0]: both fits' positions and kinks; [1]: the contact distance's
  // instants and the pre-impact fits' positions alone.
  std::array<double, 2> e2{}, t2{}, a2{};
  double pulls = 0, t_pulls = 0;
  for (int i = 0; i < n; ++i) {
    MeasuredShot s = measured(t, 1e-5, rng);
    for (int k = 0; k < 2; ++k) s.fits[k][0] = track(t, k, 0, 4e-5, rng);
    bind(s);
    const ShotUncertainty u = propagateShot(s.model, 200, 7000 + i);
    ASSERT_TRUE(u.nominal.ok);
    pulls += std::pow((u.nominal.inverse.m.e - 0.97) / u.e.sigma(), 2);
    t_pulls += std::pow((u.nominal.t_c - kTc) / u.t_c.sigma(), 2);
    s.model.w_position_before = {1.0, 1.0};
    s.model.w_kink = {0.0, 0.0};
    s.model.w_before = s.pair_w_before;
    std::mt19937_64 unused;
    const ShotDraw alone = evaluateShot(s.model, unused, true);
    ASSERT_TRUE(alone.ok);
    int k = 0;
    for (const ShotDraw* d : {&u.nominal, &alone}) {
      e2[k] += std::pow(d->inverse.m.e - 0.97, 2);
      t2[k] += std::pow(d->t_c - kTc, 2);
      a2[k] += std::pow(angle(*d), 2);
      ++k;
    }
  }
  for (auto* v : {&e2, &t2, &a2})
    for (double& x : *v) x = std::sqrt(x / n);
  pulls = std::sqrt(pulls / n), t_pulls = std::sqrt(t_pulls / n);
  std::printf(
      "RMS over %d shots, with both fits / the pre-impact ones and contact distance alone: "
      "e %.2e / %.2e, t_c %.2f / %.2f us, line of centres %.2f / %.2f mrad; pulls e %.2f, "
      "t_c %.2f\n",
      n, e2[0], e2[1], 1e6 * t2[0], 1e6 * t2[1], 1e3 * a2[0], 1e3 * a2[1], pulls, t_pulls);
  EXPECT_LT(a2[0], 0.7 * a2[1]);
  EXPECT_LT(e2[0], 0.8 * e2[1]);
  EXPECT_LT(t2[0], 1.02 * t2[1]);
  for (const double p : {pulls, t_pulls}) {
    EXPECT_GT(p, 0.75);
    EXPECT_LT(p, 1.3);
  }
}

// The instant's weights: none negative, the kinks' and the contact
// distance's pair adding up to one; a sphere whose two fits have the same
// velocity has no kink and gets no weight; a contact distance stated far
// less certain than the fits leaves the instant to the kinks.
TEST(InstantWeights, NoneNegativeAKinklessSphereNoneAndAnUncertainContactLittle) {
  std::mt19937_64 rng(13);
  const Truth t = collision(0.8);
  MeasuredShot s = measured(t, 2e-5, rng);
  bind(s);
  const auto check = [](const InstantWeights& w) {
    EXPECT_GE(w.before, 0.0);
    EXPECT_LE(w.before, 1.0);
    for (const double k : w.kink) EXPECT_GE(k, 0.0);
    EXPECT_LE(w.kink[0] + w.kink[1], 1.0 + 1e-12);
  };
  const double t_c = s.model.w_before * s.model.t_before + (1 - s.model.w_before) * s.model.t_after;
  const InstantWeights w = instantWeights(s.model, t_c);
  check(w);
  EXPECT_GT(w.kink[0], 0.0);
  EXPECT_GT(w.kink[1], 0.0);

  MeasuredShot kinkless = s;
  kinkless.fits[1][1] = kinkless.fits[1][0];
  for (int i = 0; i < 2; ++i)
    for (int side = 0; side < 2; ++side) kinkless.model.fit[i][side] = &kinkless.fits[i][side];
  const InstantWeights wk = instantWeights(kinkless.model, t_c);
  check(wk);
  EXPECT_EQ(wk.kink[1], 0.0);

  s.model.contact_sigma = 1e-3;  // 5 px at 0.2 mm per pixel
  const InstantWeights wu = instantWeights(s.model, t_c);
  check(wu);
  EXPECT_GT(wu.kink[0] + wu.kink[1], 0.9);
}

// The error budget separates what each input contributes. Shots at grazing
// incidence whose centres carry real noise, analysed with a contact distance
// sigma (and spins, and n_z) stated beside it but not realised in the truth:
// the trajectory fits' row alone covers the errors made (pulls near 1), the
// whole sigma, widened by the rest, does not match them (pulls well below 1),
// the rows add up in quadrature to the whole, and a source with nothing to
// draw contributes nothing.
TEST(ErrorBudget, EachRowIsWhatItsSourceContributes) {
  std::mt19937_64 rng(7);
  const Truth t = collision(1.2);  // n at 69 deg to the approach
  const int n = 40;
  double fits_pulls = 0, whole_pulls = 0, ratio = 0;
  for (int i = 0; i < n; ++i) {
    MeasuredShot s = measured(t, 4e-6, rng);  // 0.02 px at 0.2 mm per pixel
    bind(s);
    s.model.contact_sigma = 1.2e-4;  // about twice the fits' part of e's sigma
    s.model.nz_sigma = 0.005;
    for (auto& sides : s.model.spin_cov)
      for (Eigen::Matrix3d& cov : sides) cov = Eigen::Matrix3d::Identity() * 0.25;
    const ShotUncertainty whole = propagateShot(s.model, 200, 4000 + i);
    const std::vector<ErrorBudgetRow> rows = errorBudget(s.model, 200, 4000 + i);
    ASSERT_TRUE(whole.nominal.ok);
    ASSERT_EQ(rows.size(), 8u);
    const double e_err = whole.nominal.inverse.m.e - 0.97;
    double sum2 = 0;
    for (const ErrorBudgetRow& r : rows) {
      sum2 += r.e * r.e;
      if (r.source == kFitNoise) fits_pulls += std::pow(e_err / r.e, 2);
      // Nothing to draw: no drift, depth coupling, v_z prior or offset here.
      if (r.source == kCentreDrift || r.source == kDepth || r.source == kOutOfPlaneSpeed ||
          r.source == kPositionOffset)
        EXPECT_LT(r.e, 1e-9) << r.name;
      else
        EXPECT_GT(r.e, 0.0) << r.name;
    }
    ratio += std::sqrt(sum2) / whole.e.sigma() / n;
    whole_pulls += std::pow(e_err / whole.e.sigma(), 2);
  }
  fits_pulls = std::sqrt(fits_pulls / n), whole_pulls = std::sqrt(whole_pulls / n);
  std::printf(
      "e pull RMS over %d shots: %.2f against the fits' row, %.2f against the whole; the rows' "
      "quadrature sum / the whole: %.3f on average\n",
      n, fits_pulls, whole_pulls, ratio);
  // Each sigma from 200 draws is known to 5 %, independently in each row and
  // the whole: their ratio's mean over 40 shots to about 1 %.
  EXPECT_NEAR(ratio, 1.0, 0.03);
  EXPECT_GT(fits_pulls, 0.75);
  EXPECT_LT(fits_pulls, 1.3);
  EXPECT_LT(whole_pulls, 0.7);
}

// A centre placed on the wrong plane is off by -x dz / Z0 (x from the optical
// axis): a depth whose rate errs by dv_z moves a track's velocity along x and,
// as the track bends, along the velocity, and nowhere else. Drawn along that
// direction (ShotModel::depth), the velocity's per-axis pulls are near 1 on
// both axes; the same size drawn on both axes alike (a scalar drift) leaves
// the axis across that direction far too wide.
TEST(PropagateShot, ADepthRateErrorIsCoveredAlongItsDirection) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> nd;
  const Truth t = collision(0.5);
  const double z0 = 0.5, sigma_vz = 0.03;   // camera distance (m), v_z sigma (m/s)
  const Eigen::Vector2d axis(-0.05, 0.03);  // where the optical axis meets the plane, m
  const int n = 40;
  std::array<double, 2> along{0, 0}, alike{0, 0};  // per-axis pull sums of squares
  for (int i = 0; i < n; ++i) {
    const double dvz = sigma_vz * nd(rng);
    std::mt19937_64 same(2000 + i);
    MeasuredShot s = measured(t, 5e-7, same);
    s.fits[0][0] = track(t, 0, 0, 5e-7, same, [&](double tau, const Vec3& r) {
      const Eigen::Vector2d x = r.head<2>() - axis;
      return Vec3(r.x() - x.x() * dvz * tau / z0, r.y() - x.y() * dvz * tau / z0, r.z());
    });
    bind(s);
    const TrajectoryFit& f = s.fits[0][0];
    const Eigen::Vector2d x = Eigen::Vector2d(f.coefficients(0)[0], f.coefficients(1)[0]) - axis;
    const Eigen::Vector2d v(f.coefficients(0)[1], f.coefficients(1)[1]);
    const double bend = f.tFirst_s() + f.tLast_s() - 2 * f.tRef_s();
    const Eigen::Vector2d per_rate = -(x + v * bend) * sigma_vz / z0;
    for (const bool directed : {true, false}) {
      s.model.depth[0][0].per_rate = directed ? per_rate : Eigen::Vector2d::Zero();
      s.model.drift[0][0] = directed ? 0.0 : per_rate.norm();
      const ShotUncertainty u = propagateShot(s.model, 300, 700 + i);
      ASSERT_TRUE(u.nominal.ok);
      for (int k = 0; k < 2; ++k) {
        const double pull =
            (u.nominal.v_before[0][k] - t.before[0].velocity_m_s[k]) / u.v_before[0][k].sigma();
        (directed ? along : alike)[k] += pull * pull;
      }
    }
  }
  for (int k = 0; k < 2; ++k) {
    along[k] = std::sqrt(along[k] / n), alike[k] = std::sqrt(alike[k] / n);
    std::printf("axis %d: velocity pull RMS %.2f drawn along the direction, %.2f on both axes\n", k,
                along[k], alike[k]);
    EXPECT_GT(along[k], 0.7);
    EXPECT_LT(along[k], 1.4);
  }
  // Here the direction is mostly along y: x's sigma on both axes is several
  // times its error.
  EXPECT_LT(alike[0], 0.4);
}

// The dots' drift: each pair of draws has the two sigmas asked for and the
// correlation -1/2 of a wander independent at the tracks' far ends and shared
// at the contact.
TEST(DotDrift, PairsHaveTheirSigmasAndAreAntiCorrelated) {
  std::mt19937_64 rng(11);
  const int n = 40000;
  double sb = 0, sa = 0, sba = 0;
  for (int i = 0; i < n; ++i) {
    const auto [b, a] = drawDriftPair(2e-4, 5e-4, rng);
    sb += b * b, sa += a * a, sba += b * a;
  }
  EXPECT_NEAR(std::sqrt(sb / n), 2e-4, 0.02 * 2e-4);
  EXPECT_NEAR(std::sqrt(sa / n), 5e-4, 0.02 * 5e-4);
  EXPECT_NEAR(sba / std::sqrt(sb * sa), -0.5, 0.02);
}

// Tracks whose velocities carry such a drift (each sphere's pre- and
// post-impact errors from one wander shared at the contact): e's stated sigma
// covers its error. e = -v_n' / v_n takes the two sides' normal velocities
// together, so drawn independently (as before session 30) the pair's errors,
// which partly cancel in it, made that sigma about 1.4 times too wide.
TEST(PropagateShot, ADriftSharedAtTheContactIsCoveredInE) {
  const Truth t = collision(0.5);
  const double wander_m = 1e-5, span_s = 19e-3;
  const double drift = std::numbers::sqrt2 * wander_m / span_s;  // each side's velocity sigma
  const int n = 80;
  double pulls = 0;
  for (int i = 0; i < n; ++i) {
    std::mt19937_64 rng(3000 + i);
    std::normal_distribution<double> nd;
    MeasuredShot s = measured(t, 1e-7, rng);
    for (int sp = 0; sp < 2; ++sp) {
      // Per axis: the wander at the far end before, at the contact, at the far end after.
      const Eigen::Vector2d far_before(nd(rng), nd(rng)), contact(nd(rng), nd(rng)),
          far_after(nd(rng), nd(rng));
      const Eigen::Vector2d dv_before = wander_m * (contact - far_before) / span_s,
                            dv_after = wander_m * (far_after - contact) / span_s;
      for (int side = 0; side < 2; ++side) {
        const Eigen::Vector2d dv = side == 0 ? dv_before : dv_after;
        s.fits[sp][side] = track(t, sp, side, 1e-7, rng, [&](double tau, const Vec3& r) {
          return Vec3(r.x() + dv.x() * tau, r.y() + dv.y() * tau, r.z());
        });
        s.model.drift[sp][side] = drift;
      }
    }
    bind(s);
    const ShotUncertainty u = propagateShot(s.model, 400, 900 + i);
    ASSERT_TRUE(u.nominal.ok);
    const double pull = (u.nominal.inverse.m.e - 0.97) / u.e.sigma();
    pulls += pull * pull;
  }
  const double rms = std::sqrt(pulls / n);
  std::printf("e pull RMS over %d shots: %.2f\n", n, rms);
  EXPECT_GT(rms, 0.8);
  EXPECT_LT(rms, 1.25);
}

// One error of the depth's rate moves both the pre-impact v_z and the fit's
// in-plane velocity: drawn with one deviate, they are correlated as far as
// vz_before_shared says, and not at all without it.
TEST(PropagateShot, VzAndItsInPlaneMoveShareOneDeviate) {
  std::mt19937_64 rng(5);
  const Truth t = collision(0.5);
  MeasuredShot s = measured(t, 1e-7, rng);
  bind(s);
  s.model.depth[0][0].per_rate = Eigen::Vector2d(0.004, 0.0);
  s.model.vz_before[0] = std::array<double, 2>{0.0, 0.02};
  for (const double shared : {0.02, 0.0}) {
    s.model.vz_before_shared[0] = shared;
    std::mt19937_64 draws(6);
    double sx = 0, sz = 0, sxx = 0, szz = 0, sxz = 0;
    const int n = 2000;
    for (int i = 0; i < n; ++i) {
      const ShotDraw d = evaluateShot(s.model, draws, false);
      const double x = d.v_before[0].x(), z = d.v_before[0].z();
      sx += x, sz += z, sxx += x * x, szz += z * z, sxz += x * z;
    }
    const double cov = sxz / n - sx / n * sz / n;
    const double corr = cov / std::sqrt((sxx / n - sx / n * sx / n) * (szz / n - sz / n * sz / n));
    std::printf("vz_before_shared %.3f: correlation of v_x and v_z %.3f\n", shared, corr);
    if (shared > 0)
      EXPECT_GT(corr, 0.9);
    else
      EXPECT_LT(std::abs(corr), 0.1);
  }
}

}  // namespace

// A centre offset that holds over each track, drawn for each of a sphere's
// two fits on its own (ShotModel::offset, kPositionOffset), moves the
// instant as the linearised geometry says. Exact tracks, offset o per axis:
// - a sphere's kink, (P - Q) . dv = 0, moves by -(dP - dQ) . dv / |dv|^2:
//   standard deviation sqrt(2) o / |dv|;
// - the pre-impact contact instant, |r| = d, by -r . (dP1 - dP2) / (r . v):
//   sqrt(2) o |r| / |r . v|, with r and v the centres' separation and
//   relative velocity there.
TEST(PropagateShot, ATrackOffsetMovesTheInstantAsTheGeometrySays) {
  std::mt19937_64 rng(3);
  const Truth t = collision(1.1);  // psi about 60 degrees
  const double o = 20e-6;
  for (const bool kink : {true, false}) {
    MeasuredShot s = measured(t, 0.0, rng);
    bind(s);
    s.model.offset = {o, o};
    s.model.w_kink = kink ? std::array<double, 2>{1.0, 0.0} : std::array<double, 2>{0.0, 0.0};
    s.model.w_before = 1.0;
    const ShotUncertainty u = propagateShot(s.model, 4000, 7, kPositionOffset);
    ASSERT_TRUE(u.nominal.ok);
    double expected = 0;
    if (kink) {
      const Vec3 dv = t.after[0].velocity_m_s - t.before[0].velocity_m_s;
      expected = std::numbers::sqrt2 * o / dv.head<2>().norm();
    } else {
      const Vec3 r = t.before[0].position_m - t.before[1].position_m;
      const Vec3 v = t.before[0].velocity_m_s - t.before[1].velocity_m_s;
      expected = std::numbers::sqrt2 * o * r.norm() / std::abs(r.dot(v));
    }
    // 4000 draws: a standard deviation known to about 1.1 %.
    EXPECT_NEAR(u.t_c.sigma() / expected, 1.0, 0.05)
        << (kink ? "kink" : "pre-impact contact") << ": " << u.t_c.sigma() << " s against "
        << expected;
  }
}

// One impulse bends both spheres' tracks at once: on exact tracks the kinks'
// gap is 0; a per-track offset o spreads it by 2 o^2 (1/|dv_1|^2 +
// 1/|dv_2|^2) (the truth's velocity changes); with centre noise alone the
// gaps of many shots are spread as their stated sigmas say.
TEST(PropagateShot, TheKinksGapIsZeroAtTheTruthAndSpreadsAsItsSourcesSay) {
  std::mt19937_64 rng(5);
  const Truth t = collision(0.9);
  MeasuredShot exact = measured(t, 0.0, rng);
  bind(exact);
  const double o = 20e-6;
  exact.model.offset = {o, o};
  const ShotUncertainty u = propagateShot(exact.model, 4000, 7, kPositionOffset);
  ASSERT_TRUE(u.nominal.ok);
  EXPECT_NEAR(u.nominal.kink_gap, 0.0, 1e-9);
  double per_var = 0;
  for (int s = 0; s < 2; ++s)
    per_var += 2 / (t.after[s].velocity_m_s - t.before[s].velocity_m_s).head<2>().squaredNorm();
  EXPECT_NEAR(u.kink_gap_var_per_offset_var / per_var, 1.0, 1e-3);
  // 4000 draws: a standard deviation known to about 1.1 %.
  EXPECT_NEAR(u.kink_gap.sigma() / (o * std::sqrt(per_var)), 1.0, 0.05);

  double pull2 = 0;
  const int n = 80;
  for (int shot = 0; shot < n; ++shot) {
    MeasuredShot s = measured(t, 2e-5, rng);
    bind(s);
    const ShotUncertainty v = propagateShot(s.model, 300, 11 + shot, kFitNoise);
    ASSERT_TRUE(v.nominal.ok);
    pull2 += std::pow(v.nominal.kink_gap / v.kink_gap.sigma(), 2);
  }
  // 80 pulls: their RMS is known to about 8 % (as StatedSigmasMatchTheErrorsMade).
  EXPECT_GT(std::sqrt(pull2 / n), 0.75);
  EXPECT_LT(std::sqrt(pull2 / n), 1.3);
}

// Without the contact distance reached (a nearly grazing impact whose fits
// pass just outside it), the instant rests on the kinks alone: their weights
// add up to 1, the draws place it where the drawn tracks bend (exact tracks:
// the truth's instant), and the two contact instants are not looked for.
TEST(PropagateShot, WithoutTheContactReachedTheKinksAlonePlaceTheInstant) {
  std::mt19937_64 rng(5);
  const Truth t = collision(1.3);
  MeasuredShot s = measured(t, 2e-6, rng);
  bind(s);
  s.model.contact_reached = false;
  s.model.t_before = s.model.t_after = kTc + 3e-6;  // a start near the kinks
  const InstantWeights w = instantWeights(s.model, kTc);
  EXPECT_NEAR(w.kink[0] + w.kink[1], 1.0, 1e-12);
  EXPECT_GT(w.kink[0], 0.0);
  EXPECT_GT(w.kink[1], 0.0);
  s.model.w_kink = w.kink;
  const ShotUncertainty u = propagateShot(s.model, 400);
  ASSERT_TRUE(u.nominal.ok);
  EXPECT_NEAR(u.nominal.t_c, kTc, 5 * u.t_c.sigma());
  EXPECT_GT(u.t_c.sigma(), 0.0);
  EXPECT_EQ(u.dt_ba.sigma(), 0.0);
  EXPECT_NEAR(u.nominal.inverse.m.e, 0.97, 5 * u.e.sigma());
}

// Two estimates of one beta that share an error (the inputs before the
// impact) and each carry their own (the spins after, the velocities' change),
// drawn with known variances: the weight is the least-variance one worked by
// hand, and the combination's spread over the draws is what it states.
TEST(BetaCombination, TheWeightIsTheLeastVarianceOneAndItsSigmaTheDrawsSpread) {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> unit(0, 1);
  const double shared = 0.02, own_s = 0.05, own_i = 0.01, truth = 0.4;
  ShotUncertainty u;
  std::vector<std::pair<double, double>> draws;
  for (int i = 0; i < 20000; ++i) {
    const double c = shared * unit(rng);
    const double s = truth + c + own_s * unit(rng), b = truth + c + own_i * unit(rng);
    u.beta.add(s), u.beta_from_impulse.add(b), u.beta_spin_minus_impulse.add(s - b);
    draws.emplace_back(s, b);
  }
  // Var(w s + (1 - w) b) = w^2 own_s^2 + (1 - w)^2 own_i^2 + shared^2: least at
  // w = own_i^2 / (own_s^2 + own_i^2).
  const double w_hand = own_i * own_i / (own_s * own_s + own_i * own_i);
  const double w = betaSpinWeight(u);
  EXPECT_NEAR(w, w_hand, 0.01);
  Spread combined;
  for (const auto& [s, b] : draws) combined.add(w * s + (1 - w) * b);
  EXPECT_NEAR(combinedBetaSigma(u, w), combined.sigma(), 1e-9);
  EXPECT_LT(combinedBetaSigma(u, w), u.beta_from_impulse.sigma());
  EXPECT_NEAR(combinedBetaSigma(u, w), std::hypot(shared, own_s * own_i / std::hypot(own_s, own_i)),
              0.002);
  // w = 1 is the spins' own sigma; w = 0 the impulse's.
  EXPECT_DOUBLE_EQ(combinedBetaSigma(u, 1.0), u.beta.sigma());
  EXPECT_NEAR(combinedBetaSigma(u, 0.0), u.beta_from_impulse.sigma(), 1e-9);
}

TEST(BetaCombination, HeldWithinBothAndOneWhereASpreadIsMissing) {
  // The impulse's beta no better than the spins' and wholly correlated with
  // it: the least-variance weight would extrapolate beyond the spins (w > 1).
  EXPECT_DOUBLE_EQ(betaSpinWeight(0.01, 0.04, 0.01), 1.0);
  EXPECT_DOUBLE_EQ(betaSpinWeight(0.04, 0.01, 0.01), 0.0);
  EXPECT_DOUBLE_EQ(betaSpinWeight(0.01, 0.0, 0.01), 1.0);  // no spread: one estimate
  EXPECT_DOUBLE_EQ(betaSpinWeight(0.01, 0.01, 0.0), 1.0);  // identical estimates
  EXPECT_DOUBLE_EQ(betaSpinWeight(std::nan(""), 0.01, 0.02), 1.0);
  EXPECT_DOUBLE_EQ(betaSpinWeight(ShotUncertainty{}), 1.0);  // no draws
}
