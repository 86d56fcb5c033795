// The pinhole camera (analysis/camera_model.hpp) against geometry worked out
// here: projecting and back-projecting onto a plane, undistorting what was
// distorted, and the centre of a sphere from the centre of its perspective
// silhouette, whose edge is found by intersecting rays with the sphere.
#include "analysis/camera_model.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/analysis/cone_outline.hpp"

namespace collide {
namespace {

// sim-lab's lens: 50 mm, 20 um pixels, 0.5292 m away, mild barrel distortion.
PinholeCamera labCamera() {
  PinholeCamera c;
  c.focal_px = 0.050 / 20e-6;
  c.principal_u_px = 319.5;
  c.principal_v_px = 239.5;
  c.centre_m = Vec3(0, 0, 0.5292);
  c.k1 = -0.08, c.k2 = 0.02, c.p1 = 0.0001, c.p2 = -0.0001;
  return c;
}

TEST(CameraModel, PlanePointsRoundTripThroughThePixels) {
  const PinholeCamera c = labCamera();
  for (double x = -0.08; x <= 0.08; x += 0.02)
    for (double y = -0.06; y <= 0.06; y += 0.02) {
      const Vec3 w(x, y, 0.0);
      const Eigen::Vector2d px = c.project(w);
      const Vec3 back = c.onPlane(px.x(), px.y(), 0.0);
      EXPECT_LT((back - w).norm(), 1e-9) << x << ", " << y;
    }
  // Undistorted, the pixel of (x, y, 0) is f x / d from the principal point.
  PinholeCamera ideal = c;
  ideal.k1 = ideal.k2 = ideal.p1 = ideal.p2 = 0;
  const Eigen::Vector2d px = ideal.project(Vec3(0.05, -0.02, 0));
  EXPECT_NEAR(px.x(), 319.5 + ideal.focal_px * 0.05 / 0.5292, 1e-9);
  EXPECT_NEAR(px.y(), 239.5 + ideal.focal_px * 0.02 / 0.5292, 1e-9);
}

// Does the ray from the optical centre through normalised (x, y) meet the sphere?
bool hits(const PinholeCamera& c, const Eigen::Vector2d& xy, const Vec3& centre, double radius) {
  const Vec3 dir = Vec3(xy.x(), -xy.y(), -1).normalized();  // world direction
  const Vec3 oc = centre - c.centre_m;
  const double along = oc.dot(dir);
  return along > 0 && (oc - along * dir).squaredNorm() <= radius * radius;
}

TEST(CameraModel, SphereCentreFromItsPerspectiveSilhouette) {
  PinholeCamera c = labCamera();
  c.k1 = c.k2 = c.p1 = c.p2 = 0;  // the silhouette is an ellipse in ideal coordinates
  const double radius = 0.0127;
  for (const Vec3& centre :
       {Vec3(0.07, 0.05, 0), Vec3(-0.09, 0.01, 0), Vec3(0.0, -0.07, 0), Vec3(0.02, 0.0, 0)}) {
    // The silhouette's two ends along the radial line through the centre's
    // image, by bisection on ray-sphere intersection; their midpoint is the
    // ellipse's centre.
    const Eigen::Vector2d axis(centre.x() / c.centre_m.z(), -centre.y() / c.centre_m.z());
    const Eigen::Vector2d dir = axis.normalized();
    const auto edge = [&](double sign) {
      double in = 0, out = sign * 0.2;  // normalised offsets along dir from axis
      for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (in + out);
        (hits(c, axis + mid * dir, centre, radius) ? in : out) = mid;
      }
      return axis + 0.5 * (in + out) * dir;
    };
    const Eigen::Vector2d mid = 0.5 * (edge(1) + edge(-1));
    const double u = c.principal_u_px + c.focal_px * mid.x();
    const double v = c.principal_v_px + c.focal_px * mid.y();
    // The silhouette's centre is not the centre's image: it lies outward.
    const Eigen::Vector2d image_of_centre = c.project(centre);
    EXPECT_GT(std::hypot(u - c.principal_u_px, v - c.principal_v_px),
              (image_of_centre - Eigen::Vector2d(c.principal_u_px, c.principal_v_px)).norm());
    const Vec3 naive = c.onPlane(u, v, 0.0);
    const Vec3 found = c.sphereCentre(u, v, radius, 0.0);
    EXPECT_LT((found - centre).norm(), 1e-8) << centre.transpose();
    // ... by a shift that matters at a hundredth of a pixel (~2 um here).
    if (centre.head<2>().norm() > 0.05) {
      EXPECT_GT((naive - centre).norm(), 5e-6);
    }
  }
}

// The outline's shape against the tangent cone's section (truth from the
// geometry, not from outlineShape): off the axis by theta a sphere of angular
// radius alpha is an ellipse whose semi-axes along and across the radial
// direction have the ratio below; outlineShape's eigenvalues are 1 / cos(theta)
// along (to first order in alpha) and 1 across, along the radial direction.
// Barrel distortion shortens the radial axis by its derivative's excess over
// its tangential scale, (1 + 3 k1 r^2) / (1 + k1 r^2) for k1 alone.
TEST(CameraModel, OutlineShapeIsTheSilhouettesEllipse) {
  PinholeCamera c = labCamera();
  c.k1 = c.k2 = c.p1 = c.p2 = 0;
  EXPECT_TRUE(c.outlineShape(c.principal_u_px, c.principal_v_px).isIdentity(1e-12));
  const double radius = 0.0127, depth = c.centre_m.z();
  for (const Vec3& centre : {Vec3(0.07, 0.05, 0), Vec3(-0.09, 0.01, 0), Vec3(0.0, -0.07, 0)}) {
    const testing::ConeOutline cone = testing::coneOutline(centre.head<2>().norm(), depth, radius);
    const Eigen::Vector2d seen = c.project(centre);
    const Eigen::Matrix2d shape = c.outlineShape(seen.x(), seen.y());
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(shape);
    EXPECT_NEAR(eig.eigenvalues()(0), 1.0, 1e-9) << centre.transpose();
    EXPECT_NEAR(eig.eigenvalues()(1), cone.along / cone.across, 2e-4) << centre.transpose();
    // The long axis points away from the principal point (image v is down).
    const Eigen::Vector2d radial = Eigen::Vector2d(centre.x(), -centre.y()).normalized();
    EXPECT_NEAR(std::abs(eig.eigenvectors().col(1).dot(radial)), 1.0, 1e-9);
  }
  PinholeCamera barrel = c;
  barrel.k1 = -0.08;
  const Eigen::Vector2d seen = barrel.project(Vec3(0.07, 0.05, 0));
  const Eigen::Vector2d xy = barrel.normalised(seen.x(), seen.y());
  const double r2 = xy.squaredNorm();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(barrel.outlineShape(seen.x(), seen.y()));
  EXPECT_NEAR(eig.eigenvalues()(1),
              std::sqrt(1 + r2) * (1 + 3 * barrel.k1 * r2) / (1 + barrel.k1 * r2), 1e-6);
  EXPECT_NEAR(eig.eigenvalues()(0), 1.0, 1e-6);
}

}  // namespace
}  // namespace collide
