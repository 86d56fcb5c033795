#include "analysis/camera_model.hpp"

#include <cmath>

namespace collide {

Eigen::Vector2d PinholeCamera::distort(const Eigen::Vector2d& xy) const {
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
  return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
          y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
}

Eigen::Vector2d PinholeCamera::undistort(const Eigen::Vector2d& xy_distorted) const {
  // As cv::undistortPoints: x = (x' - tangential(x)) / radial(x), iterated.
  // Up to 20 steps; it stops early once a step moves the point by less than
  // 1e-15 (the iteration contracts by ~2 |k1| r^2 a step: a few steps in the
  // field of an ordinary lens).
  Eigen::Vector2d xy = xy_distorted;
  for (int i = 0; i < 20; ++i) {
    const double x = xy.x(), y = xy.y();
    const double r2 = x * x + y * y;
    const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
    const double dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    const double dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
    const Eigen::Vector2d next((xy_distorted.x() - dx) / radial, (xy_distorted.y() - dy) / radial);
    const bool settled = (next - xy).cwiseAbs().maxCoeff() <= 1e-15;
    xy = next;
    if (settled) break;
  }
  return xy;
}

Eigen::Vector2d PinholeCamera::project(const Vec3& w) const {
  const double depth = centre_m.z() - w.z();
  if (!(depth > 0)) return {std::nan(""), std::nan("")};
  const Eigen::Vector2d ideal((w.x() - centre_m.x()) / depth, -(w.y() - centre_m.y()) / depth);
  const Eigen::Vector2d d = distort(ideal);
  return {focal_px * d.x() + principal_u_px, focal_px * d.y() + principal_v_px};
}

Eigen::Vector2d PinholeCamera::normalised(double u_px, double v_px) const {
  const Eigen::Vector2d d((u_px - principal_u_px) / focal_px, (v_px - principal_v_px) / focal_px);
  return distorted() ? undistort(d) : d;
}

Vec3 PinholeCamera::onPlane(double u_px, double v_px, double plane_z_m) const {
  const Eigen::Vector2d xy = normalised(u_px, v_px);
  const double depth = centre_m.z() - plane_z_m;
  return {centre_m.x() + xy.x() * depth, centre_m.y() - xy.y() * depth, plane_z_m};
}

Vec3 PinholeCamera::sphereCentre(double u_px, double v_px, double radius_m,
                                 double plane_z_m) const {
  const Eigen::Vector2d xy = normalised(u_px, v_px);
  const double rho_c = xy.norm();  // silhouette centre's distance from the axis (normalised)
  const double depth = centre_m.z() - plane_z_m;
  if (!(rho_c > 1e-12) || !(depth > radius_m)) return onPlane(u_px, v_px, plane_z_m);
  const Eigen::Vector2d dir = xy / rho_c;
  // Solve (tan(theta + alpha) + tan(theta - alpha)) / 2 = rho_c for theta,
  // with sin alpha = radius / distance and distance = depth / cos theta.
  double theta = std::atan(rho_c);
  for (int i = 0; i < 30; ++i) {
    const double alpha = std::asin(std::min(1.0, radius_m * std::cos(theta) / depth));
    const double f = 0.5 * (std::tan(theta + alpha) + std::tan(theta - alpha)) - rho_c;
    // d/dtheta, alpha's own change neglected (second order): the iteration
    // still converges to the root in a few steps.
    const double c1 = std::cos(theta + alpha), c2 = std::cos(theta - alpha);
    const double df = 0.5 * (1 / (c1 * c1) + 1 / (c2 * c2));
    const double step = f / df;
    theta -= step;
    if (std::abs(step) < 1e-15) break;
  }
  const Eigen::Vector2d axis = dir * std::tan(theta);
  return {centre_m.x() + axis.x() * depth, centre_m.y() - axis.y() * depth, plane_z_m};
}

Eigen::Matrix2d PinholeCamera::outlineShape(double u_px, double v_px) const {
  const Eigen::Vector2d xy = normalised(u_px, v_px);
  const double r2 = xy.squaredNorm();
  if (!xy.allFinite() || !(r2 > 1e-24)) return Eigen::Matrix2d::Identity();
  // The ellipse in ideal normalised coordinates: 1 / cos(theta) along e.
  const Eigen::Vector2d e = xy / std::sqrt(r2);
  const Eigen::Matrix2d stretch =
      Eigen::Matrix2d::Identity() + (std::sqrt(1 + r2) - 1) * e * e.transpose();
  // The distortion's derivative there (central differences), over its
  // tangential scale, the radial factor: the identity without distortion.
  const double h = 1e-6;
  Eigen::Matrix2d jac;
  jac.col(0) =
      (distort(xy + Eigen::Vector2d(h, 0)) - distort(xy - Eigen::Vector2d(h, 0))) / (2 * h);
  jac.col(1) =
      (distort(xy + Eigen::Vector2d(0, h)) - distort(xy - Eigen::Vector2d(0, h))) / (2 * h);
  const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
  const Eigen::Matrix2d map = jac * stretch / radial;
  // A circle's image under `map` is the ellipse of the symmetric (map map')^(1/2).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(map * map.transpose());
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0))
    return Eigen::Matrix2d::Identity();
  return eig.operatorSqrt();
}

}  // namespace collide
