// Out-of-plane motion from the apparent size (analysis/depth_from_size.hpp)
// against a pinhole camera written out here: r = f R / Z.
#include "analysis/depth_from_size.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace collide;

namespace {

constexpr double kR = 0.0127;           // sphere radius, m
constexpr double kZ0 = 1.0;             // object plane 1 m from the camera
constexpr double kF = 60.0 * kZ0 / kR;  // focal length, px: 60 px at the plane
double imagedRadius(double dz) {        // centre dz in front of the plane
  return kF * kR / (kZ0 - dz);
}

TEST(DepthFromRadius, InvertsThePinholeCamera) {
  EXPECT_DOUBLE_EQ(depthFromRadius(60.0, 60.0, kZ0), 0.0);
  for (const double dz : {-0.05, -0.001, 0.002, 0.1})
    EXPECT_NEAR(depthFromRadius(imagedRadius(dz), 60.0, kZ0), dz, 1e-12);
}

TEST(FitDepthMotion, ExactRadiiGiveTheTrueVelocity) {
  const int n = 20;
  Eigen::VectorXd t(n), r(n), s = Eigen::VectorXd::Constant(n, 0.01);
  const double vz = 0.03, dz0 = 0.004;  // towards the camera
  for (int i = 0; i < n; ++i) {
    t[i] = 1e-3 * i;
    r[i] = imagedRadius(dz0 + vz * t[i]);
  }
  auto m = fitDepthMotion(t, r, s, 60.0, kZ0, 0.0);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_NEAR(m->vz_m_s, vz, 1e-9);
  EXPECT_NEAR(m->dz0_m, dz0, 1e-12);
  EXPECT_NEAR(m->chi2, 0, 1e-12);
  EXPECT_GT(m->vz_sigma_m_s, 0);
}

TEST(FitDepthMotion, StatedSigmaMatchesTheScatter) {
  // 0.01 px radius noise, 20 frames at 1000 frames/s: pulls of v_z over 400 tracks.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> nd;
  const int n = 20, tracks = 400;
  double pull2 = 0;
  for (int k = 0; k < tracks; ++k) {
    Eigen::VectorXd t(n), r(n), s = Eigen::VectorXd::Constant(n, 0.01);
    for (int i = 0; i < n; ++i) {
      t[i] = 1e-3 * i;
      r[i] = imagedRadius(-0.002 - 0.02 * t[i]) + 0.01 * nd(rng);
    }
    auto m = fitDepthMotion(t, r, s, 60.0, kZ0, 0.0);
    ASSERT_TRUE(m.ok());
    pull2 += std::pow((m->vz_m_s + 0.02) / m->vz_sigma_m_s, 2);
  }
  const double pull = std::sqrt(pull2 / tracks);
  EXPECT_GT(pull, 0.9);
  EXPECT_LT(pull, 1.1);
}

TEST(FitDepthMotion, RefusesBadInput) {
  Eigen::VectorXd t(2), r(2), s(2);
  t << 0, 1e-3;
  r << 60, 60;
  s << 0.01, 0.01;
  EXPECT_FALSE(fitDepthMotion(t, r, s, 60, kZ0, 0).ok());  // 2 frames
  Eigen::VectorXd t3(3), r3(3), s3(3);
  t3 << 0, 1e-3, 2e-3;
  r3 << 60, -1, 60;
  s3 << 0.01, 0.01, 0.01;
  auto m = fitDepthMotion(t3, r3, s3, 60, kZ0, 0);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("frame 1"), std::string::npos) << m.error().message;
  r3[1] = 60;
  EXPECT_FALSE(fitDepthMotion(t3, r3, s3, 60, 0.0, 0).ok());  // no camera distance
}

}  // namespace

namespace {

// sim-lab's lens (as config/sim-lab.toml): 50 mm, 20 um pixels, 0.5292 m away.
PinholeCamera labLens(bool distorted) {
  PinholeCamera c;
  c.focal_px = 0.050 / 20e-6;
  c.principal_u_px = 319.5;
  c.principal_v_px = 239.5;
  c.centre_m = Vec3(0, 0, 0.5292);
  if (distorted) c.k1 = -0.08, c.k2 = 0.02;
  return c;
}

}  // namespace

// On the axis the silhouette is the circle of the tangent cone: tan(alpha) =
// R / sqrt(L^2 - R^2), radius f tan(alpha) (written out here, not the code's
// sampling of the tangent circle).
TEST(ApparentRadius, OnTheAxisIsTheTangentConesCircle) {
  const PinholeCamera c = labLens(false);
  for (const double z : {0.0, 0.01, -0.02}) {
    const double L = c.centre_m.z() - z;
    const double expected = c.focal_px * kR / std::sqrt(L * L - kR * kR);
    EXPECT_NEAR(apparentRadiusPx(c, Vec3(0, 0, z), kR), expected, 1e-6 * expected);
  }
}

// Off the axis the silhouette is an ellipse: half-axes f (tan(t + a) - tan(t -
// a)) / 2 radially and f sin(a) / sqrt(cos^2 t - sin^2 a) across (t the
// axis' angle, sin a = R / L). Its mean radius lies between them, above the
// on-axis value; barrel distortion takes some of it back.
TEST(ApparentRadius, OffTheAxisGrowsAsTheEllipseAndDistortionShrinksIt) {
  const PinholeCamera c = labLens(false);
  const Vec3 centre(0.08, 0.0, 0.0);
  const double L = (c.centre_m - centre).norm(), t = std::atan(0.08 / c.centre_m.z());
  const double a = std::asin(kR / L);
  const double radial = c.focal_px * 0.5 * (std::tan(t + a) - std::tan(t - a));
  const double across =
      c.focal_px * std::sin(a) / std::sqrt(std::pow(std::cos(t), 2) - std::pow(std::sin(a), 2));
  const double r = apparentRadiusPx(c, centre, kR);
  EXPECT_GT(r, std::min(radial, across));
  EXPECT_LT(r, std::max(radial, across));
  EXPECT_GT(r, apparentRadiusPx(c, Vec3(0, 0, 0), kR) * 1.005);  // > 0.5 % larger: it matters
  EXPECT_LT(apparentRadiusPx(labLens(true), centre, kR), r);
  EXPECT_TRUE(std::isnan(apparentRadiusPx(c, Vec3(0, 0, 1.0), kR)));  // behind the camera
}

// Momentum along z: velocities that conserve it come out as they went in;
// one poorly measured velocity off by dv takes (almost) all the correction,
// and the adjusted sigmas shrink.
TEST(ConserveMomentumZ, MovesThePoorlyMeasuredVelocityOntoTheConstraint) {
  const std::array<double, 2> m{0.00978, 0.00412};
  // A true impact: impulse P along z, v1' = v1 + P / m1, v2' = v2 - P / m2.
  const double v1 = 0.05, v2 = 0.03, p = 0.0008;
  const std::array<double, 4> truth{v1, v1 + p / m[0], v2, v2 - p / m[1]};
  std::array<double, 4> vz = truth, sigma{0.002, 0.002, 0.002, 0.002};
  conserveMomentumZ(vz, sigma, m);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(vz[i], truth[i], 1e-12);
  vz = truth;
  vz[3] += 0.08;  // sphere 2 after: a bad size fit
  sigma = {0.002, 0.002, 0.002, 0.05};
  conserveMomentumZ(vz, sigma, m);
  const double residual = -m[0] * vz[0] + m[0] * vz[1] - m[1] * vz[2] + m[1] * vz[3];
  EXPECT_NEAR(residual, 0.0, 1e-15);
  EXPECT_NEAR(vz[3], truth[3], 0.01);  // from 0.08 off to within 0.01
  EXPECT_LT(sigma[3], 0.05 / 4);
  // A sigma that is not a number: nothing changes.
  std::array<double, 4> v0 = vz, s0{0.002, NAN, 0.002, 0.002};
  conserveMomentumZ(v0, s0, m);
  EXPECT_EQ(v0, vz);
}

// The sigmas made whole: scaled by sqrt(chi2 / dof) when the residuals exceed
// the sigmas (never shrunk), and v_z's joined by a radius bias changing by
// sigma_r over the track: Z0 sigma_r / (r T) = 0.5 x 0.1 / (50 x 0.04) m/s.
TEST(CompleteDepthSigmas, ResidualScaleAndAChangingRadiusBias) {
  DepthMotion d;
  d.dz0_sigma_m = 1e-4;
  d.vz_sigma_m_s = 0.01;
  d.chi2 = 40;
  d.dof = 10;
  completeDepthSigmas(d, 0.5, 50, 0.04, 0.1);
  EXPECT_DOUBLE_EQ(d.dz0_sigma_m, 2e-4);
  EXPECT_DOUBLE_EQ(d.vz_sigma_m_s, std::hypot(0.02, 0.025));
  EXPECT_DOUBLE_EQ(d.chi2, 10);
  DepthMotion good;
  good.vz_sigma_m_s = 0.01;
  good.chi2 = 2;
  good.dof = 10;
  completeDepthSigmas(good, 0.5, 50, 0.04, 0.0);
  EXPECT_DOUBLE_EQ(good.vz_sigma_m_s, 0.01);
}

// The post-impact line: v_z the two estimates' weighted mean (an analytic
// case: sigmas 0.04 and 0.01 weigh 1 : 16), its depth continuous with the
// pre-impact line's at the contact instant.
TEST(HoldDepthToImpulse, WeighsBothVelocitiesAndJoinsTheLinesAtContact) {
  DepthMotion before, after;
  before.dz0_m = 0.002, before.dz0_sigma_m = 0.0005, before.vz_m_s = 0.04;
  after.dz0_m = 0.010, after.dz0_sigma_m = 0.001, after.vz_m_s = 0.186, after.vz_sigma_m_s = 0.04;
  const double t_ref = 0.0, t_contact = 0.0004;
  holdDepthToImpulse(after, before, 0.114, 0.01, t_contact, t_ref);
  EXPECT_NEAR(after.vz_m_s, (0.186 * 1 + 0.114 * 16) / 17, 1e-12);
  EXPECT_NEAR(after.vz_sigma_m_s, 1 / std::sqrt(1 / 0.0016 + 1 / 0.0001), 1e-12);
  const double dz_before = before.dz0_m + before.vz_m_s * (t_contact - t_ref);
  const double dz_after = after.dz0_m + after.vz_m_s * (t_contact - t_ref);
  EXPECT_NEAR(dz_after, dz_before, 1e-15);
  EXPECT_DOUBLE_EQ(after.dz0_sigma_m, before.dz0_sigma_m);
  // No usable impulse estimate: nothing moves.
  DepthMotion untouched = after;
  holdDepthToImpulse(untouched, before, std::nan(""), 0.01, t_contact, t_ref);
  holdDepthToImpulse(untouched, before, 0.1, 0.0, t_contact, t_ref);
  EXPECT_EQ(untouched.vz_m_s, after.vz_m_s);
  EXPECT_EQ(untouched.dz0_m, after.dz0_m);
}
