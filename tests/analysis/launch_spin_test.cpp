// The launchers' spin spread against spins drawn as the simulated launchers
// draw them (a random axis, a speed uniform in [a, b]), whose per-axis RMS is
// known in closed form: sqrt((a^2 + a b + b^2) / 9).
#include "analysis/launch_spin.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace collide {
namespace {

double truthPerAxis(double a, double b) {
  return std::sqrt((a * a + a * b + b * b) / 9);
}

// n spins, each measured with Gaussian noise of `noise` rad/s per axis.
std::vector<Estimate3> drawSpins(int n, double a, double b, double noise, std::mt19937_64& rng) {
  std::normal_distribution<double> unit(0, 1);
  std::uniform_real_distribution<double> speed(a, b);
  std::vector<Estimate3> out;
  for (int i = 0; i < n; ++i) {
    Vec3 axis(unit(rng), unit(rng), unit(rng));
    axis.normalize();
    Estimate3 s;
    s.value = speed(rng) * axis + noise * Vec3(unit(rng), unit(rng), unit(rng));
    s.sigma = Vec3::Constant(noise);
    out.push_back(s);
  }
  return out;
}

TEST(LaunchSpinSpread, RecoversTheLaunchersSpreadWithTheNoiseTakenOut) {
  std::mt19937_64 rng(3);
  // Noise 15 rad/s per axis on a 10 rad/s spread: the raw RMS would be 18.
  const auto spins = drawSpins(2000, 0, 30, 15, rng);
  const auto r = launchSpinSpread(spins);
  ASSERT_TRUE(r) << r.error().message;
  const double truth = truthPerAxis(0, 30);
  EXPECT_NEAR(r->per_axis_rad_s, truth, 3 * r->sigma_rad_s);
  EXPECT_LT(r->sigma_rad_s, 0.1 * truth);
  for (int ax = 0; ax < 3; ++ax) EXPECT_NEAR(r->rms_rad_s(ax), truth, 0.15 * truth) << ax;
  EXPECT_EQ(r->spins, 2000);
}

TEST(LaunchSpinSpread, ItsSigmaCoversTheErrorOverManyCampaigns) {
  std::mt19937_64 rng(11);
  const double truth = truthPerAxis(10, 40);
  double sum2 = 0;
  const int campaigns = 400;
  for (int c = 0; c < campaigns; ++c) {
    const auto r = launchSpinSpread(drawSpins(40, 10, 40, 3, rng));
    ASSERT_TRUE(r) << r.error().message;
    const double pull = (r->per_axis_rad_s - truth) / r->sigma_rad_s;
    sum2 += pull * pull;
  }
  const double pull_rms = std::sqrt(sum2 / campaigns);
  EXPECT_GT(pull_rms, 0.8);
  EXPECT_LT(pull_rms, 1.25);
}

TEST(LaunchSpinSpread, ASpinEveryLaunchGivesCountsAboutZero) {
  // A launcher that always backspins by 20 rad/s about z: the prior (centred
  // on 0) must be that wide along z.
  std::vector<Estimate3> spins(10);
  for (auto& s : spins) s.value = Vec3(0, 0, 20), s.sigma = Vec3::Constant(1e-3);
  const auto r = launchSpinSpread(spins);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_NEAR(r->rms_rad_s.z(), 20, 1e-6);
  EXPECT_NEAR(r->rms_rad_s.x(), 0, 1e-6);
  EXPECT_NEAR(r->per_axis_rad_s, 20 / std::sqrt(3.0), 1e-6);
}

TEST(LaunchSpinSpread, SpinsThatAreAllNoiseGiveASpreadNearZeroNotNaN) {
  // Launchers that do not spin, spins measured to 10 rad/s per axis.
  std::mt19937_64 rng(5);
  const auto r = launchSpinSpread(drawSpins(60, 0, 0, 10, rng));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_TRUE(std::isfinite(r->per_axis_rad_s));
  EXPECT_GT(r->sigma_rad_s, 0);
  EXPECT_LT(r->per_axis_rad_s, 3 * r->sigma_rad_s);  // 0 within its sigma
  EXPECT_LT(r->per_axis_rad_s, 5.0);                 // where the raw RMS is 10
  for (int ax = 0; ax < 3; ++ax) EXPECT_TRUE(std::isfinite(r->rms_rad_s(ax)));
}

TEST(LaunchSpinSpread, RefusesTooFewOrNonFiniteSpins) {
  std::vector<Estimate3> spins(2);
  auto r = launchSpinSpread(spins);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("at least 3"), std::string::npos) << r.error().message;
  spins.resize(4);
  spins[2].sigma.y() = NAN;
  r = launchSpinSpread(spins);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("spin 2"), std::string::npos) << r.error().message;
}

}  // namespace
}  // namespace collide
