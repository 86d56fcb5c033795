#pragma once
// Draws what the rig's camera sees: white, front-lit spheres with black dots on
// a black background, with anti-aliased edges, a darker rim, optional motion
// blur over the exposure, sensor noise, and the camera's bit depth.
// Projection is orthographic (the camera looks along -z from far away).
// With RenderSettings::imaging it draws what a real lab camera records
// instead: spheres ray-cast in 3-D under lamps, through a pinhole lens with
// distortion, and a sensor (vision/imaging.hpp, render_raycast.cpp).
// Image coordinates: u to the right, v down, pixel (0,0)'s centre at (0,0).
#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "analysis/types.hpp"
#include "vision/frame.hpp"
#include "vision/imaging.hpp"

namespace collide::vision {

/// Dot centres on the unit sphere, in the sphere's body frame.
struct DotPattern {
  std::vector<Vec3> centres;      ///< unit vectors
  double angular_radius_rad = 0;  ///< each dot is a spherical cap of this half-angle

  /// Random, reproducible from `seed`: dots of diameter `dot_diameter_fraction`
  /// of the sphere's diameter covering about `coverage` of the surface
  /// (docs/SPEC.md: 1/10 and 5 %, about 20 dots), kept apart so they do not touch.
  /// Diameter means the face-on diameter: sin(angular_radius) = fraction. Centres
  /// are uniform on the sphere with at least one dot radius of bare surface
  /// between dots; a request too dense to place gets as many dots as fit.
  /// Throws std::invalid_argument unless 0 < fraction < 1 and 0 < coverage < 1
  /// (a bug: callers validate user input first).
  static DotPattern random(std::uint64_t seed, double dot_diameter_fraction = 0.1,
                           double coverage = 0.05);
};

/// One sphere as the camera sees it at the middle of the exposure.
struct SphereView {
  Eigen::Vector2d centre_px{0, 0};  ///< (u, v)
  double radius_px = 0;
  Quat orientation = Quat::Identity();  ///< body -> world (x right, y up, z towards camera)
  Eigen::Vector2d velocity_px_s{0, 0};  ///< (du/dt, dv/dt), for motion blur
  Vec3 spin_rad_s = Vec3::Zero();       ///< world frame, for motion blur
  const DotPattern* dots = nullptr;     ///< nullptr: no dots
  // The same sphere in the world (metres), for RenderSettings::imaging, which
  // ray-casts in 3-D; the pixel fields above are then not used.
  Vec3 centre_m = Vec3::Zero();
  double radius_m = 0;
  Vec3 velocity_m_s = Vec3::Zero();
};

struct RenderSettings {
  int width = 640;
  int height = 480;
  PixelFormat format = PixelFormat::Mono8;
  double exposure_s = 0.0;     ///< 0: no motion blur
  int blur_samples = 0;        ///< time samples over the exposure; 0 = choose from motion
  double sphere_level = 0.85;  ///< brightness at the sphere's centre, fraction of full scale
  double rim_level = 0.45;     ///< brightness at the limb, fraction of full scale (front light)
  double dot_level = 0.05;     ///< brightness of a dot, fraction of full scale
  double background_level = 0.02;
  double noise_grey = 0.0;  ///< std dev of additive Gaussian noise, in grey levels of the format
  std::uint64_t noise_seed = 1;
  /// Lamps, lens and sensor of a real camera (vision/imaging.hpp). Unset: the
  /// evenly lit orthographic picture described at render(), exactly as ever.
  /// Set: spheres are ray-cast from their world fields; sphere/rim/dot/
  /// background levels above are not used, noise_grey is (unless the sensor
  /// has a full well), exposure_s and blur_samples are.
  std::optional<Imaging> imaging;
};

/// A flat chessboard (a camera calibration target) somewhere in the world:
/// squares of side square_m, alternately dark and light, with the inner
/// corners (where four squares meet) at origin_m + (i x_axis + j y_axis)
/// square_m, i < inner_cols, j < inner_rows; one square of border beyond the
/// outer corners and a light margin of 0.6 squares round it (as printed
/// boards). Lit as a matte surface by the imaging's lamp: level = albedo
/// (ambient + (1 - ambient) |n.l|).
struct ChessboardTarget {
  Vec3 origin_m = Vec3::Zero();  ///< the first inner corner, world frame
  Vec3 x_axis = Vec3::UnitX();   ///< unit, world: along a row of corners
  Vec3 y_axis = -Vec3::UnitY();  ///< unit, world, normal to x_axis: down a column
  int inner_cols = 9, inner_rows = 6;
  double square_m = 0.01;
  double dark_albedo = 0.05, light_albedo = 0.85;
};

class Renderer {
 public:
  /// Throws std::invalid_argument for width/height <= 0 or negative exposure,
  /// blur_samples or noise (a bug: callers validate user input first).
  explicit Renderer(RenderSettings settings);
  const RenderSettings& settings() const { return settings_; }
  /// A frame of settings().width x height in cvType(settings().format).
  /// `frame_index` varies the noise from frame to frame (reproducibly).
  /// Shading: rim + (centre - rim) cos^2(theta), theta between surface normal
  /// and line of sight. Every pixel is the exact average over its area (edge
  /// pixels to ~1e-3), so a dotless sphere's intensity centroid is its centre.
  /// Spheres overlapping in the image: later in the vector is drawn in front.
  /// Grey level = round(clamp(level * maxValue + noise, 0, maxValue)).
  /// Thread-safe (const, no shared mutable state).
  /// `time_s`: the frame's mid-exposure time, seconds on any fixed clock
  /// (the phase of mains flicker; used only with imaging).
  cv::Mat render(const std::vector<SphereView>& spheres, std::uint64_t frame_index,
                 double time_s = 0.0) const;
  /// A picture of `board` through the imaging's lens and sensor (noise,
  /// vignetting, fixed patterns, bit depth; no spheres, no blur, flicker at
  /// t = 0): each sample's ray meets the board's plane and the square it
  /// lands in sets the level; elsewhere the backdrop. Throws
  /// std::invalid_argument without RenderSettings::imaging (a bug).
  cv::Mat renderChessboard(const ChessboardTarget& board, std::uint64_t frame_index) const;

 private:
  struct ImagingTables;  // render_raycast.cpp
  static std::shared_ptr<const ImagingTables> makeImagingTables(const RenderSettings& s);
  cv::Mat renderImaging(const std::vector<SphereView>& spheres, std::uint64_t frame_index,
                        double time_s) const;
  std::shared_ptr<const ImagingTables> imaging_;
  RenderSettings settings_;
  std::vector<float> noise_table_;  // precomputed unit Gaussian samples
  // round(background + noise_grey * noise_table_[i]) in the output format's
  // bytes: rows of plain background are copied from here, not computed.
  std::vector<std::uint8_t> background_table_;
};

}  // namespace collide::vision
