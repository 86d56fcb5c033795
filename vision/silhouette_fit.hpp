#pragma once
// The whole image of a small sphere fitted at once (issue 12, item 1).
//
// On a sphere a few tens of pixels across, the edge profiles of
// sphere_detector.cpp have three to five samples inside the limb each: the
// shading of the limb is then poorly determined per stretch of the outline,
// and which shape a stretch takes changes from frame to frame with the noise.
// On the thesis' imaging (37 px spheres, photon-limited) that moved the
// centre by ~0.2 px from frame to frame along the lamp's direction, which is
// what limited e there. This stage fits every pixel of an annulus around the
// outline with the image of a matte (Lambertian) sphere under one distant
// lamp and ambient light, on a locally planar background:
//
//   outside: bg + gx (x - u0) + gy (y - v0)
//   inside:  A + E n_z^2 + max(0, Bx rho_x + By rho_y + C n_z),
//            rho = ((x, y) - (u, v)) / R, n_z = sqrt(1 - |rho|^2)
//
// (A the ambient share, (Bx, By, C) the lamp's direction times the lit
// albedo, the max the terminator; E n_z^2 a limb darkening a surface that is
// not quite matte may add, 0 for Lambert's law), averaged over each pixel's
// area near the outline. Eleven parameters, Gauss-Newton with Levenberg damping, and Tukey
// weights so that dots, a highlight and hot pixels do not pull it. The edge
// is then where the silhouette is, whatever the shading of the limb: a limb
// in shadow is found from the step off the background it makes, weighted by
// how much it shows. Dark silhouettes (backlight) are measured as their
// negative, where the model is the same with B = C = 0 (or a bright spot
// pulled out by the weights).
#include <opencv2/core.hpp>
#include <optional>
#include <span>

#include "analysis/camera_model.hpp"
#include "vision/sphere_detector.hpp"

namespace collide::vision {

struct SilhouetteFitSettings {
  int subsamples = 3;           ///< per axis, for pixels within edge_band_px of the outline
  double edge_band_px = 1.5;    ///< pixels this close to the outline are subsampled
  double inner_depth_px = 8.0;  ///< the annulus reaches this far inside (at most 0.6 R)
  double outer_px = 3.0;        ///< and this far outside (the background)
  int iterations = 6;
  /// A fit that moves the centre or the radius further than this from the
  /// start is not trusted (the start is kept).
  double max_shift_px = 1.5;
  /// The camera's pinhole, when known: a sphere theta off the optical axis is
  /// then fitted as the ellipse it is (1 / cos(theta) longer away from the
  /// principal point); its centre and the mean of its semi-axes are reported,
  /// as the profiles' circle fit reports them. nullopt: a circle.
  std::optional<PinholeCamera> camera;
};

struct SilhouetteFit {
  CircleFit circle;          ///< u, v, radius and their standard uncertainties
  double background = 0;     ///< model background at the centre, grey levels
  double ambient_level = 0;  ///< A: the sphere's level where the lamp does not reach
  int pixels = 0;            ///< pixels fitted
  int downweighted = 0;      ///< of them, given no weight (dots, highlights)
};

/// Refines `start` (a circle from the edge profiles) on `image` (CV_8UC1 or
/// CV_16UC1, spheres brighter than the background). `others` are the other
/// spheres' circles in the frame: pixels within 2 px of them are left out.
/// nullopt when the fit fails, strays further than max_shift_px, or finds no
/// step off the background at the limb larger than 3 noise sigmas + 2 grey
/// levels (the caller keeps `start`).
std::optional<SilhouetteFit> fitSilhouette(const cv::Mat& image, const CircleFit& start,
                                           std::span<const CircleFit> others,
                                           const SilhouetteFitSettings& settings = {});

}  // namespace collide::vision
