#pragma once
// The dark dots on one sphere in one frame, located to a small fraction of a
// pixel and lifted onto the sphere (SPEC step 4).
//
// Method. The bare sphere's brightness B around every pixel comes from a
// grey-level closing of the sphere's box with a square wider than a dot (the
// dots filled in from their surroundings, the shading kept whatever the lamp
// and wherever a highlight is). Pixels darker than halfway between a dark
// reference and their own B are dot candidates, the reference being the
// backdrop (front light) or black (a backlit silhouette, darker than its
// field); so dots on a shaded side, barely brighter than the backdrop, are
// dark relative to it. A candidate must also lie 3 noise sigmas below B (the
// noise from the spread of B - I over the sphere), or on a shaded side of a
// noisy frame the noise alone makes specks. 8-connected groups of
// candidates are dots. Each dot's
// centre is the centroid of its coverage, (B - I) / (B - P) per pixel, over
// its pixels and a two-pixel ring around them, with B here a quadratic fitted
// to the bare sphere in a frame around the dot (smooth and unbiased) and the
// paint's level P = p0 + p1 B fitted to the dots' darkest pixels (a paint of
// one level, or lit like the sphere), so the blurred, anti-aliased border
// counts in proportion and the shading does not pull the centre. Dots within
// a margin of the limb (partly hidden, or merged with the dark background)
// are dropped.
//
// Lifting. A dot at image offset (dx, dy) from the centre, radius R, becomes
// the unit vector (x, y, z) = (dx / R', -dy / R', sqrt(1 - x^2 - y^2)) in
// camera axes (x right, y up, z towards the camera). The projected area of a
// spherical cap of half-angle alpha centred at polar angle theta has its
// centroid at sin(theta) cos(alpha) R from the centre, exactly; R' = R cos(alpha)
// therefore lifts the centroid to the cap's true centre.
#include <opencv2/core.hpp>
#include <vector>

#include "analysis/types.hpp"
#include "vision/sphere_detector.hpp"

namespace collide::vision {

struct Dot {
  double u_px = 0, v_px = 0;      ///< coverage centroid in the image
  double area_px2 = 0;            ///< coverage sum: the dot's projected area
  Vec3 on_sphere = Vec3::Zero();  ///< unit vector from the centre, camera axes
  /// Relative weight of the image position for rotation fits (1: the errors
  /// of the image centroids are about the same for every dot).
  double weight = 1;
};

struct DotSettings {
  /// Ignore dots closer than this to the limb (pixels); 0: 2 px plus the
  /// detector's edge half-width, at least 3 % of the radius.
  double rim_margin_px = 0;
  /// Dots seen farther than this from the line of sight are dropped (their
  /// lifted position is poorly conditioned), degrees.
  double max_polar_deg = 80;
  /// Half-angle of the dots on the sphere (rad) for the limb correction;
  /// 0: estimated from the dots' areas in this frame (face-on area = pi (R sin alpha)^2).
  double angular_radius_rad = 0;
};

struct DotFrame {
  std::vector<Dot> dots;
  double angular_radius_rad = 0;  ///< used for lifting (given or estimated)
  double dot_area_px2 = 0;        ///< median face-on area of the dots
  int rejected = 0;               ///< candidates dropped (at the limb, too small or large)
};

/// Dots on `sphere` in `image` (CV_8UC1 or CV_16UC1, full scale max_value).
/// Never throws; an unusable sphere or image gives no dots. Thread-safe.
DotFrame findDots(const cv::Mat& image, const SphereMeasurement& sphere, int max_value,
                  const DotSettings& settings = {});

/// Lifts image point (u, v) of a sphere at (cu, cv) with radius r onto the
/// sphere, correcting for dots of half-angle alpha (0: no correction).
Vec3 liftToSphere(double u, double v, double cu, double cv, double r, double alpha_rad = 0);

}  // namespace collide::vision
