// The collision-instant stage (analysis/contact.hpp) against analytic cases.
#include "analysis/contact.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace collide;

namespace {

// x(t) = x0 + v (t - t_ref) + a (t - t_ref)^2 on one axis, constant y.
PlaneTrack line(double x0, double v, double y0, double accel_y = 0, double t_ref = 0) {
  PlaneTrack p;
  p.t_ref = t_ref;
  p.c[0] = Eigen::Vector3d(x0, v, 0);
  p.c[1] = Eigen::Vector3d(y0, 0, accel_y / 2);
  return p;
}

TEST(ContactTime, HeadOnApproachMeetsAtTheAnalyticInstant) {
  // Spheres 2 m apart closing at 2 + 1.5 m/s, both falling alike (gravity
  // cancels in the separation): |dr| = 2 - 3.5 t = d at t = (2 - d) / 3.5.
  const double d = 0.0254;
  const PlaneTrack a = line(-1, 2, 0.1, -9.81), b = line(1, -1.5, 0.1, -9.81);
  EXPECT_NEAR(contactTime(a, b, d, 0.55), (2 - d) / 3.5, 1e-12);
  // From either side of the root.
  EXPECT_NEAR(contactTime(a, b, d, 0.566), (2 - d) / 3.5, 1e-12);
}

TEST(ContactTime, ObliqueApproach) {
  // Sphere 2 offset by h in y: |dr|^2 = (2 - 3 t)^2 + h^2 = d^2.
  const double d = 0.0254, h = 0.015;
  const PlaneTrack a = line(-1, 1.5, 0), b = line(1, -1.5, h);
  const double t = (2 - std::sqrt(d * d - h * h)) / 3;
  EXPECT_NEAR(contactTime(a, b, d, 0.66), t, 1e-12);
}

// Two spheres on straight lines in 3D whose line of centres at contact
// leaves the image plane by n_z: the image-plane tracks reach the in-plane
// contact distance at the true instant, and the full diameter early.
// A sphere at (0.1, 0.2) m at t = 0.0305 s, moving (2, -0.5) m/s before and
// (-0.4, 1.1) m/s after, falling alike on both: its two tracks, extended,
// cross at the impact, found from either side of it.
TEST(KinkTime, TwoTracksOfOneSphereMeetAtTheImpact) {
  const double tc = 0.0305, g = -9.81;
  const auto through = [&](double vx, double vy) {
    PlaneTrack p;
    p.t_ref = 0.03;  // the fits' own reference, not the impact
    const double tau = tc - p.t_ref;
    p.c[0] = Eigen::Vector3d(0.1 - vx * tau, vx, 0);
    p.c[1] = Eigen::Vector3d(0.2 - vy * tau + 0.5 * g * tau * tau, vy - g * tau, g / 2);
    return p;
  };
  const PlaneTrack pre = through(2.0, -0.5), post = through(-0.4, 1.1);
  EXPECT_LT((pre.pos(tc) - Eigen::Vector2d(0.1, 0.2)).norm(), 1e-12);
  EXPECT_LT((post.pos(tc) - Eigen::Vector2d(0.1, 0.2)).norm(), 1e-12);
  EXPECT_NEAR(kinkTime(pre, post, tc - 0.002), tc, 1e-12);
  EXPECT_NEAR(kinkTime(pre, post, tc + 0.003), tc, 1e-12);
  // Tracks that do not differ have no kink: the start is returned.
  EXPECT_EQ(kinkTime(pre, pre, 0.029), 0.029);
}

TEST(InPlaneContactDistance, TiltedContactIsFoundAtTheTrueInstant) {
  const double d = 0.0254, nz = 0.05, t_contact = 0.01;
  const Eigen::Vector3d n(std::sqrt(1 - nz * nz) * std::cos(0.3),
                          std::sqrt(1 - nz * nz) * std::sin(0.3), nz);
  // Sphere 1 moves obliquely towards sphere 2, at rest at the origin, and
  // touches it at t_contact.
  const Eigen::Vector3d v(-1.2, 0.4, -0.03);
  const Eigen::Vector3d p1 = d * n - v * t_contact;  // sphere 1 at t = 0
  PlaneTrack a, b;
  a.c[0] = Eigen::Vector3d(p1.x(), v.x(), 0);
  a.c[1] = Eigen::Vector3d(p1.y(), v.y(), 0);
  b.c[0] = b.c[1] = Eigen::Vector3d::Zero();
  const double in_plane = inPlaneContactDistance(d, nz, 0);
  EXPECT_NEAR(in_plane, d * std::hypot(n.x(), n.y()), 1e-15);
  EXPECT_NEAR(contactTime(a, b, in_plane, 0.0), t_contact, 1e-10);
  // The whole diameter: the image-plane centres are that far apart before
  // the spheres touch.
  EXPECT_LT(contactTime(a, b, d, 0.0), t_contact - 1e-6);
}

TEST(InPlaneContactDistance, IsTheExpectationOverAnUncertainTilt) {
  // Over n_z ~ N(0.03, 0.02^2) the mean of d sqrt(1 - n_z^2), by quadrature.
  const double d = 0.02, m = 0.03, s = 0.02;
  double sum = 0, wsum = 0;
  for (double x = -8; x <= 8; x += 1e-3) {
    const double w = std::exp(-0.5 * x * x), nz = m + s * x;
    sum += w * d * std::sqrt(1 - nz * nz), wsum += w;
  }
  EXPECT_NEAR(inPlaneContactDistance(d, m, s), sum / wsum, 1e-3 * d * (m * m + s * s));
  // Known to lie in the plane: the whole distance.
  EXPECT_EQ(inPlaneContactDistance(d, 0, 0), d);
}

TEST(BeforeInstantWeight, InverseVariances) {
  EXPECT_DOUBLE_EQ(beforeInstantWeight(1e-6, 2e-6), 0.8);  // 4 / (4 + 1)
  EXPECT_DOUBLE_EQ(beforeInstantWeight(3e-6, 3e-6), 0.5);
  EXPECT_DOUBLE_EQ(beforeInstantWeight(std::numeric_limits<double>::quiet_NaN(), 1e-6), 0.5);
  EXPECT_DOUBLE_EQ(beforeInstantWeight(0, 0), 0.5);
}

// A grazing impact (70 degrees off head-on): the relative motion is mostly
// along the tangent, so the line of centres at the combined instant turns by
// v_t dt / d for an instant dt off. Spheres of diameter d meet at t = 0 with
// their centres d apart along n; before, the relative velocity is
// (-v_n n + v_t t); after, (e v_n n + v_t' t).
struct Grazing {
  double d = 0.0254, vn = 0.6, vt = 1.65, e = 0.9, vt_after = 1.4;
  Eigen::Vector2d n{std::cos(0.3), std::sin(0.3)}, t{-std::sin(0.3), std::cos(0.3)};
  // Sphere 2 fixed at the origin, sphere 1 moving: a relative track.
  PlaneTrack relative(bool after) const {
    const Eigen::Vector2d v =
        after ? Eigen::Vector2d(e * vn * n + vt_after * t) : Eigen::Vector2d(-vn * n + vt * t);
    PlaneTrack p;
    for (int k = 0; k < 2; ++k) p.c[k] = Eigen::Vector3d(d * n[k], v[k], 0);
    return p;
  }
  static PlaneTrack still() { return PlaneTrack{}; }
};

TEST(BeforeInstantWeight, AContactDistanceErrorCancelsInTheCombinedInstant) {
  const Grazing g;
  const double dd = 0.2 * 2.1e-4;  // 0.2 px at 0.21 mm/px
  // The instants where the fitted centres are the misstated distance apart.
  const double tb = contactTime(g.relative(false), Grazing::still(), g.d + dd, -1e-3);
  const double ta = contactTime(g.relative(true), Grazing::still(), g.d + dd, 1e-3);
  // To first order (the tangential motion adds ~1 %): 70 us early, 78 us late.
  EXPECT_NEAR(tb, -dd / g.vn, 0.01 * dd / g.vn);
  EXPECT_NEAR(ta, dd / (g.e * g.vn), 0.01 * dd / g.vn);
  // Fits precise to 5 and 15 us: by their variances alone, the instant is
  // pulled to the better side and lands ~60 us off, turning the line of
  // centres by ~0.2 degrees.
  const double w_fits = beforeInstantWeight(5e-6, 15e-6);
  const double t_fits = w_fits * tb + (1 - w_fits) * ta;
  EXPECT_GT(std::abs(t_fits), 40e-6);
  // With the distance's uncertainty (0.2 px, as dd) the weights lean to
  // cancelling it: the instant is off by what the fits' own errors allow.
  const double w = beforeInstantWeight(5e-6, 15e-6, dd, g.vn, g.e * g.vn);
  const double t_c = w * tb + (1 - w) * ta;
  EXPECT_LT(std::abs(t_c), 0.25 * std::abs(t_fits));
  const auto angle = [&](double t) {
    const Eigen::Vector2d r = g.relative(false).pos(t);
    return std::atan2(r.y(), r.x()) - std::atan2(g.n.y(), g.n.x());
  };
  EXPECT_LT(std::abs(angle(t_c)), 0.25 * std::abs(angle(t_fits)));
  // With no distance error at all, both forms agree.
  EXPECT_DOUBLE_EQ(beforeInstantWeight(5e-6, 15e-6, 0, g.vn, g.e * g.vn), w_fits);
  // And a perfect distance with perfect fits: exactly 1 / (1 + e).
  EXPECT_NEAR(beforeInstantWeight(0, 0, dd, g.vn, g.e * g.vn), 1 / (1 + g.e), 1e-12);
}

TEST(BeforeInstantWeight, WithTheDistanceTermItHasTheSmallestVariance) {
  // Variance of w t_b + (1 - w) t_a under the covariance the weight assumes,
  // computed here from its definition: no other weight does better.
  const double sb = 8e-6, sa = 20e-6, dd = 4e-5, vnb = 0.8, vna = 0.7;
  const double a = dd / vnb, b = dd / vna;
  const auto variance = [&](double w) {
    return w * w * (sb * sb + a * a) + (1 - w) * (1 - w) * (sa * sa + b * b) -
           2 * w * (1 - w) * a * b;
  };
  const double w = beforeInstantWeight(sb, sa, dd, vnb, vna);
  for (double dw : {-0.1, -0.01, -0.001, 0.001, 0.01, 0.1})
    EXPECT_LT(variance(w), variance(w + dw)) << dw;
}

InstantAgreementModel model() {
  InstantAgreementModel m;
  m.fit_sigma_s = 4e-6;
  m.contact_distance_sigma_m = 1e-5;  // 3e-6 s at |v_n| = 10 m/s and |v_n'| = 5 m/s
  m.vn_before_m_s = 10;
  m.vn_after_m_s = 5;
  m.contact_duration_s = 100e-6;
  return m;  // combined sigma: 5 us
}

TEST(CompareInstants, CombinedSigmaAddsTheContactDistanceTerm) {
  const InstantAgreement a = compareInstants(0, 0, model());
  EXPECT_NEAR(a.sigma_s, 5e-6, 1e-18);
  EXPECT_FALSE(a.disagree);
  EXPECT_EQ(a.excess_sigmas, 0);
}

TEST(CompareInstants, InsideTheContactDurationIsAgreement) {
  // The post-impact instant 80 us late: a contact of 80 us, allowed.
  const InstantAgreement a = compareInstants(1e-3, 1.08e-3, model());
  EXPECT_NEAR(a.difference_s, 80e-6, 1e-15);
  EXPECT_FALSE(a.disagree);
  EXPECT_EQ(a.outside_s, 0);
  EXPECT_EQ(a.excess_sigmas, 0);
  // 15 us beyond the longest contact: 3 sigma, within 4.
  EXPECT_FALSE(compareInstants(0, 115e-6, model()).disagree);
}

TEST(CompareInstants, BeyondTheBandByMoreThanFourSigmaDisagrees) {
  // 25 us past the band's upper edge: 5 sigma.
  InstantAgreement a = compareInstants(0, 125e-6, model());
  EXPECT_NEAR(a.outside_s, 25e-6, 1e-15);
  EXPECT_NEAR(a.excess_sigmas, 5, 1e-9);
  EXPECT_TRUE(a.disagree);
  // The post-impact instant earlier than the pre-impact one: below the band.
  a = compareInstants(30e-6, 0, model());
  EXPECT_NEAR(a.outside_s, 30e-6, 1e-15);
  EXPECT_NEAR(a.excess_sigmas, 6, 1e-9);
  EXPECT_TRUE(a.disagree);
  // 15 us early: 3 sigma, no.
  EXPECT_FALSE(compareInstants(15e-6, 0, model()).disagree);
}

TEST(CompareInstants, AnUncertainContactDistanceExcusesMore) {
  InstantAgreementModel m = model();
  m.fit_sigma_s = 0;
  m.contact_duration_s = 0;
  m.contact_distance_sigma_m = 1e-4;                     // 1e-4 (1/10 + 1/5) = 30 us
  EXPECT_FALSE(compareInstants(0, 100e-6, m).disagree);  // 3.3 sigma
  EXPECT_TRUE(compareInstants(0, 130e-6, m).disagree);   // 4.3 sigma
  // Without that uncertainty the same 100 us is far outside.
  m.contact_distance_sigma_m = 0;
  m.fit_sigma_s = 5e-6;
  EXPECT_TRUE(compareInstants(0, 100e-6, m).disagree);
}

}  // namespace
