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
