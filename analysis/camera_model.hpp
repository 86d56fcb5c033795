#pragma once
// A pinhole camera with OpenCV's lens-distortion model, looking along -z
// (world), and what it means for a sphere's image (docs/imaging.md): the one
// camera model of the project, used by the simulated camera to draw and by the
// analysis to turn pixels back into metres.
//
// Camera frame: X right, Y down, Z forward (= -z world), origin at the optical
// centre. Normalised ideal coordinates x = X/Z, y = Y/Z; distortion
//   r^2 = x^2 + y^2, x' = x (1 + k1 r^2 + k2 r^4) + 2 p1 x y + p2 (r^2 + 2 x^2),
//   y' = y (1 + k1 r^2 + k2 r^4) + p1 (r^2 + 2 y^2) + 2 p2 x y,
// pixels u = f x' + cu, v = f y' + cv.
#include <Eigen/Dense>

#include "analysis/types.hpp"

namespace collide {

struct PinholeCamera {
  double focal_px = 1000.0;  ///< focal length over pixel pitch
  double principal_u_px = 0.0, principal_v_px = 0.0;
  Vec3 centre_m = Vec3(0, 0, 1);  ///< optical centre, world frame (z = working distance)
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0;

  bool distorted() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0; }
  /// Normalised ideal (x, y) -> distorted (x', y').
  Eigen::Vector2d distort(const Eigen::Vector2d& xy) const;
  /// The inverse of distort, by fixed-point iteration (as cv::undistortPoints).
  Eigen::Vector2d undistort(const Eigen::Vector2d& xy_distorted) const;
  /// Where a world point appears, distortion included; NaN behind the camera.
  Eigen::Vector2d project(const Vec3& world_m) const;
  /// Pixel (u, v) -> normalised ideal (x, y) (distortion removed).
  Eigen::Vector2d normalised(double u_px, double v_px) const;
  /// The world point on the plane z = plane_z_m that pixel (u, v) sees.
  Vec3 onPlane(double u_px, double v_px, double plane_z_m = 0.0) const;

  /// A sphere of radius `radius_m` whose silhouette (an ellipse under
  /// perspective) is centred at pixel (u, v): the world position of its centre,
  /// given that the centre lies on the plane z = plane_z_m. The silhouette's
  /// centre is not the image of the sphere's centre: the tangent cone's
  /// section by the image plane reaches tan(theta + alpha) on the far side and
  /// tan(theta - alpha) on the near side of the axis (theta the axis' angle
  /// from the optical axis, sin alpha = radius / distance), and its centre is
  /// their mean, outward of tan(theta).
  Vec3 sphereCentre(double u_px, double v_px, double radius_m, double plane_z_m = 0.0) const;

  /// The shape of a sphere's outline seen near pixel (u, v), to first order:
  /// the symmetric map P (pixels to pixels) that takes a circle about (u, v)
  /// onto it. theta off the optical axis a sphere is seen as an ellipse
  /// 1 / cos(theta) longer away from the principal point, and the lens'
  /// distortion stretches that by its own local derivative (barrel distortion
  /// shortens it radially). P is scaled so that the outline's axis across
  /// that direction is 1 on an undistorted lens (P's eigenvalues are then
  /// 1 / cos(theta) and 1); the identity on the optical axis. The sphere
  /// detector fits its edge points in the circle P^-1 makes of them, and the
  /// silhouette fit writes its model there.
  Eigen::Matrix2d outlineShape(double u_px, double v_px) const;
};

}  // namespace collide
