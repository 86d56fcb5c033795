// Dots lifted onto their sphere through the lens (vision/shot_spins.hpp's
// liftThroughLens), against points placed on a sphere and projected by the
// pinhole camera here: the lift must give back the point's direction.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "analysis/camera_model.hpp"
#include "vision/dot_detector.hpp"
#include "vision/shot_spins.hpp"
#include "vision/spin_fit.hpp"

namespace collide::vision {
namespace {

PinholeCamera labLens() {  // config/sim-lab.toml's
  PinholeCamera c;
  c.focal_px = 0.050 / 20e-6;
  c.principal_u_px = 319.5;
  c.principal_v_px = 239.5;
  c.centre_m = Vec3(0, 0, 0.5292);
  c.k1 = -0.08, c.k2 = 0.02, c.p1 = 0.0001, c.p2 = -0.0001;
  return c;
}

TEST(LiftThroughLens, GivesBackTheDirectionOfAVisiblePoint) {
  const PinholeCamera cam = labLens();
  const double R = 0.0127;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> nd;
  for (const Vec3& centre : {Vec3(0, 0, 0), Vec3(0.07, -0.03, 0.002)}) {
    double worst = 0, worst_ortho = 0;
    int n = 0;
    while (n < 200) {
      const Vec3 dir = Vec3(nd(rng), nd(rng), nd(rng)).normalized();
      const Vec3 p = centre + R * dir;
      // Visible, and not within 25 degrees of the limb (dots there are not used).
      const Vec3 to_cam = (cam.centre_m - p).normalized();
      if (dir.dot(to_cam) < std::sin(25 * M_PI / 180)) continue;
      ++n;
      const Eigen::Vector2d uv = cam.project(p);
      const Vec3 lifted = liftThroughLens(cam, centre, R, uv.x(), uv.y());
      worst = std::max(worst, (lifted - dir).norm());
      // The orthographic lift about the centre's image, for comparison.
      const Eigen::Vector2d c_uv = cam.project(centre);
      const Eigen::Vector2d edge = cam.project(centre + Vec3(R, 0, 0));
      const Vec3 ortho = liftToSphere(uv.x(), uv.y(), c_uv.x(), c_uv.y(), (edge - c_uv).norm());
      worst_ortho = std::max(worst_ortho, (ortho - dir).norm());
    }
    EXPECT_LT(worst, 1e-6) << "centre " << centre.transpose();
    EXPECT_GT(worst_ortho, 0.02) << "the orthographic lift should be visibly off here";
  }
}

TEST(LiftThroughLens, ARayThatMissesGoesToTheClosestPoint) {
  const PinholeCamera cam = labLens();
  const Vec3 centre(0, 0, 0);
  // A pixel well outside the sphere's image: the closest point is on the limb,
  // perpendicular to the ray.
  const Vec3 v = liftThroughLens(cam, centre, 0.0127, 319.5 + 200, 239.5);
  EXPECT_NEAR(v.norm(), 1.0, 1e-12);
  EXPECT_GT(v.x(), 0.9);
}

// The dots of a sphere turning about `axis` at 40 rad/s, seen orthographically
// and lifted with a radius off by `scale` (x and y over a radius 1 % too
// small when scale = 1.01): the kind of error a lens' lifting makes.
Vec3 spinFromMisScaledLift(const Vec3& axis, double scale) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> nd;
  std::vector<Vec3> body;
  for (int i = 0; i < 12; ++i) body.push_back(Vec3(nd(rng), nd(rng), nd(rng)).normalized());
  const Vec3 w = axis.normalized() * 40.0;
  std::vector<SpinFrame> frames;
  for (int k = 0; k < 10; ++k) {
    SpinFrame f;
    f.t_s = 5e-4 * k;
    const Eigen::Matrix3d rot = Eigen::AngleAxisd(40.0 * f.t_s, w.normalized()).toRotationMatrix();
    for (const Vec3& b : body) {
      const Vec3 p = rot * b;
      if (p.z() < 0.3) continue;
      const double x = scale * p.x(), y = scale * p.y();
      f.dots.push_back(Vec3(x, y, std::sqrt(1 - x * x - y * y)));
    }
    frames.push_back(f);
  }
  const auto fit = fitSpin(frames);
  EXPECT_TRUE(static_cast<bool>(fit)) << (fit ? "" : fit.error().message);
  return fit ? Vec3(fit->spin_rad_s - w) : Vec3::Constant(1e9);
}

// Why addLensSpinSystematic widens only x and y: an error of the lifting
// leaves a turn about the camera's axis as it is (the lifted dots still turn
// rigidly about z) and moves a turn about an axis in the image plane.
TEST(LensSpinSystematic, ALiftingErrorMovesOnlyTheSpinAboutImagePlaneAxes) {
  EXPECT_LT(spinFromMisScaledLift(Vec3::UnitZ(), 1.01).norm(), 1e-6 * 40);
  EXPECT_GT(spinFromMisScaledLift(Vec3::UnitX(), 1.01).norm(), 1e-3 * 40);
  EXPECT_GT(spinFromMisScaledLift(Vec3(1, 1, 0), 1.01).norm(), 1e-3 * 40);
  // Lifted right, neither moves.
  EXPECT_LT(spinFromMisScaledLift(Vec3::UnitX(), 1.0).norm(), 1e-6 * 40);

  Eigen::Matrix3d cov = Eigen::Matrix3d::Identity() * 1e-4;
  const Vec3 spin(30, -40, 0);  // |spin| = 50 rad/s
  addLensSpinSystematic(cov, spin);
  const double sys = kLensSpinRelativeSigma * 50;
  EXPECT_NEAR(cov(0, 0), 1e-4 + sys * sys, 1e-12);
  EXPECT_NEAR(cov(1, 1), 1e-4 + sys * sys, 1e-12);
  EXPECT_EQ(cov(2, 2), 1e-4);
}

}  // namespace
}  // namespace collide::vision
