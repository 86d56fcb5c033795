#pragma once
// How accurate a velocity component can be (docs/SPEC.md, thesis eq. 5.1):
//   dv/v = s / ((v/d) n_s q dt sqrt(N))
// s: centre uncertainty (pixels); n_s: pixels per diameter d; q dt: time between
// the frames used; N: frames per side.

namespace collide {

struct ImagingGeometry {
  double position_sigma_px = 0.25;  ///< s, centre uncertainty in pixels
  double pixels_per_diameter = 0;   ///< n_s
  double diameter_m = 0;            ///< d
  double frame_interval_s = 0;      ///< q dt
  int frames_per_side = 0;          ///< N
};

/// Absolute uncertainty (m/s) of a velocity component measured from a run of
/// frames: dv = s d / (n_s q dt sqrt(N)). Independent of v itself.
double velocitySigma_m_s(const ImagingGeometry& g);

/// Relative uncertainty dv/v of a component of magnitude |v| (m/s); +inf at v = 0.
double relativeVelocityError(const ImagingGeometry& g, double v_m_s);

}  // namespace collide
