#pragma once
// A sphere's outline seen through a pinhole, from the tangent cone's geometry
// alone: a truth for tests that is not computed by the code under test.
#include <cmath>

namespace collide::testing {

/// Semi-axes of the ellipse a sphere of radius `radius_m` makes on the image
/// plane at unit distance (multiply by the focal length in pixels), its centre
/// `off_m` from the optical axis and `depth_m` in front of the optical centre:
/// theta off the axis, half-angle alpha, the tangent cone's section reaches
/// tan(theta + alpha) and tan(theta - alpha) along the radial direction.
struct ConeOutline {
  double along = 0, across = 0;  ///< radially and across
  double meanAxis() const { return 0.5 * (along + across); }
};

inline ConeOutline coneOutline(double off_m, double depth_m, double radius_m) {
  const double theta = std::atan(off_m / depth_m);
  const double alpha = std::asin(radius_m / std::hypot(off_m, depth_m));
  const double c = std::cos(theta), s = std::sin(alpha);
  return {0.5 * (std::tan(theta + alpha) - std::tan(theta - alpha)), s / std::sqrt(c * c - s * s)};
}

}  // namespace collide::testing
