#pragma once
// What a real lab camera adds to the ideal picture (issue 11): lamps and
// shading, a perspective lens with distortion, and the sensor (vignetting,
// mains flicker, fixed-pattern noise, hot pixels, shot and read noise, ADC bit
// depth). Renderer draws with these when RenderSettings::imaging is set, by
// ray-casting every sphere in 3-D (render_raycast.cpp); without it, it draws
// the original evenly lit orthographic picture, unchanged. docs/imaging.md
// describes the model and config/sim.toml the profile keys that set it.
//
// World frame as in the rest of the project: x right, y up, z towards the
// camera; the collision plane is z = 0. Image: u right, v down, pixel (0,0)'s
// centre at (0,0).
#include <Eigen/Dense>

#include "analysis/camera_model.hpp"
#include "analysis/types.hpp"

namespace collide::vision {

/// The lamps. Levels are fractions of the sensor's full scale at gain 1.
struct Lighting {
  enum class Mode {
    Front,  ///< a lamp on the camera's side: lit spheres on the backdrop
    Back,   ///< a bright field behind the spheres: dark silhouettes
  };
  Mode mode = Mode::Front;
  Vec3 lamp_direction = Vec3::UnitZ();  ///< unit, from the scene towards the lamp (world)
  /// Share of a surface's albedo lit by diffuse room light whatever its
  /// normal; the rest follows Lambert's law: level = albedo (ambient +
  /// (1 - ambient) max(0, n.l)).
  double ambient = 0.2;
  double sphere_albedo = 0.85;  ///< level of bare sphere facing the lamp
  double dot_albedo = 0.05;     ///< level of a dot facing the lamp
  /// Blinn-Phong highlight from the glossy surface (front light only):
  /// + strength max(0, n.h)^exponent, h the half vector of lamp and view.
  double specular_strength = 0.0;
  double specular_exponent = 60.0;
  double backdrop_level = 0.02;  ///< the background (the bright field when backlit)
  /// Backlit: light through/around a glossy sphere shows as a bright central
  /// spot of this level over the silhouette, where the normal is within
  /// asin(spot_fraction) of the line of sight (spot_fraction of the radius).
  double spot_level = 0.0;
  double spot_fraction = 0.0;
};

/// The lens. Orthographic (the default, as the original renderer) or a
/// pinhole at `centre_m` looking along -z with OpenCV's distortion model:
/// x = X/Z, y = Y/Z (camera frame: X right, Y down, Z forward = -z world),
/// r^2 = x^2 + y^2, x' = x (1 + k1 r^2 + k2 r^4) + 2 p1 x y + p2 (r^2 + 2 x^2),
/// y' = y (1 + k1 r^2 + k2 r^4) + p1 (r^2 + 2 y^2) + 2 p2 x y,
/// u = f x' + cu, v = f y' + cv.
struct Optics {
  bool perspective = false;
  // Orthographic: u = origin_u + x / pixel_size, v = origin_v - y / pixel_size.
  double pixel_size_m = 1.0;
  double origin_u_px = 0.0;
  double origin_v_px = 0.0;
  // Perspective.
  double focal_px = 1000.0;  ///< focal length over pixel pitch
  double principal_u_px = 0.0;
  double principal_v_px = 0.0;
  Vec3 centre_m = Vec3(0, 0, 1);  ///< optical centre, world frame (z = working distance)
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0;

  bool distorted() const { return perspective && (k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0); }
  /// The perspective fields as the project's camera model.
  PinholeCamera pinhole() const;
  /// Where a world point appears (distortion included); perspective points
  /// behind the camera give NaN.
  Eigen::Vector2d project(const Vec3& world_m) const;
  /// Normalised ideal (x, y) -> distorted (x', y') (perspective only).
  Eigen::Vector2d distort(const Eigen::Vector2d& xy) const;
  /// The inverse of distort, by fixed-point iteration (as cv::undistortPoints).
  Eigen::Vector2d undistort(const Eigen::Vector2d& xy_distorted) const;
};

/// The sensor between the light and the grey levels.
struct Sensor {
  /// cos^4 of the field angle (natural vignetting of a pinhole; perspective only).
  bool vignetting_cos4 = false;
  /// Extra radial falloff: gain 1 - falloff (r / r_corner)^2, r from the
  /// principal point (orthographic: the image centre).
  double vignetting_falloff = 0.0;
  /// Lamp intensity 1 + amplitude cos(2 pi hz t), t the frame's time; the
  /// exposure averages it. 100 Hz for 50 Hz mains, 120 Hz for 60 Hz.
  double flicker_hz = 0.0;
  double flicker_amplitude = 0.0;
  double prnu = 0.0;  ///< fixed-pattern gain: relative std dev per pixel
  double dsnu = 0.0;  ///< fixed-pattern offset: std dev per pixel, fraction of full scale
  double hot_pixel_fraction = 0.0;
  double hot_pixel_level = 0.5;  ///< added to a hot pixel, fraction of full scale
  /// Full-well capacity, electrons: full scale at gain 1. 0: no shot noise
  /// (the renderer's additive noise_grey applies instead).
  double full_well_e = 0.0;
  double read_noise_e = 0.0;  ///< std dev, electrons (with full_well_e)
  double gain = 1.0;          ///< analogue gain, linear: multiplies signal and noise
  /// ADC bits (8, 10, 12, 16); 0: the pixel format's. Fewer bits than the
  /// format stores are shifted up (Mono10 data in Mono12/Mono16 words).
  int adc_bits = 0;
};

struct Imaging {
  Lighting lighting;
  Optics optics;
  Sensor sensor;
  /// Samples per pixel along each axis (n x n per pixel per time sample).
  int samples_per_pixel = 2;
};

}  // namespace collide::vision
