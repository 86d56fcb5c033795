#pragma once
// Sphere-on-wall shots (issue 13 item 5): one sphere strikes a fixed plate
// whose face is a straight line in the image. Per frame the sphere
// (SphereDetector, either polarity); its centres before and after the impact
// fitted as free flight (gravity fixed, analysis/trajectory.hpp); the contact
// instants where each fit's outline reaches the face (centre one radius from
// it); the spins from the dots on each side (vision/spin_fit.hpp) when the
// sphere is front-lit; and Walton's inverse in the infinite-mass limit
// (analysis/walton.hpp measureWallCollision): e, beta, gamma with standard
// uncertainties from a Monte Carlo over the fits' and spins' covariances and
// the face line's. World frame: x right, y up (image u right, v down); the
// plate is taken perpendicular to the image plane. With a lens (settings'
// camera) every image position goes through it onto the plane z = 0.
#include <optional>
#include <string>
#include <vector>

#include "analysis/air_drag.hpp"
#include "analysis/camera_model.hpp"
#include "analysis/result.hpp"
#include "analysis/trajectory.hpp"
#include "analysis/walton.hpp"
#include "vision/frame.hpp"
#include "vision/render_wall.hpp"
#include "vision/sphere_detector.hpp"
#include "vision/spin_fit.hpp"

namespace collide::vision {

struct WallAnalysisSettings {
  double pixel_size_m = 0;  ///< object-plane metres per pixel, > 0
  double diameter_m = 0.0254;
  double mass_kg = 0.00978;
  /// The air the sphere flies through, kg/m^3 (AnalysisSettings' field): its
  /// drag is taken out of the trajectory fits. 0: a vacuum.
  double air_density_kg_m3 = kAirDensity_kg_m3;
  double origin_u_px = 0, origin_v_px = 0;  ///< image pixel of the world origin
  double fps = 0;                           ///< t = frame id / fps
  /// The plate's face in the image (from the rig profile or --wall-line); the
  /// normal's sign does not matter (the sphere's side is taken). None: found
  /// in the frames (vision/wall_line.hpp).
  std::optional<WallLine> wall_line;
  /// With a wall_line: refine it on the frames' edge (true) or take it as
  /// exact (false, e.g. a line the user measured).
  bool refine_wall_line = true;
  /// Standard uncertainty of a given (not refined) line's angle (rad) and offset (px).
  double wall_angle_sigma_rad = 1e-3, wall_offset_sigma_px = 0.5;
  /// Standard deviation of the sphere's velocity out of the image plane before
  /// impact, as a fraction of its speed (launch misalignment): taken as 0 in
  /// the values, it widens the uncertainties (as AnalysisSettings' field).
  double out_of_plane_speed_fraction = 0.005;
  /// Standard deviation of each component of a spin no dot shows, rad/s (as
  /// AnalysisSettings' field).
  double unknown_spin_sigma_rad_s = kDefaultUnknownSpinSigma;
  int monte_carlo_draws = 400;
  /// Under a lens: how much the sphere's detected outline changes over a
  /// track because the lit part of its limb is seen from a changing angle,
  /// px (the rig profile's [analysis] radius_systematic_px, as
  /// AnalysisSettings' field). The centre moves by as much: with the dots'
  /// drift, it widens each side's velocity by this over the track's span.
  double radius_systematic_px = 0.1;
  /// The lens the frames were taken through, when known (the rig profile's
  /// camera calibration, or a simulated camera's perspective): centres, the
  /// face line and the dots are then taken through it onto the collision
  /// plane z = 0 rather than with one pixel size (as AnalysisSettings' field).
  std::optional<PinholeCamera> camera;
};

struct WallShotAnalysis {
  double pixel_size_m = 0;
  int frames_used_before = 0, frames_used_after = 0;
  std::optional<TrajectoryFit> before, after;  ///< world metres, t = id / fps
  double t_contact_s = 0;                      ///< the pre-impact fit reaches the face
  double t_separation_s = 0;                   ///< the post-impact fit leaves it
  Wall wall;                                   ///< world frame, normal towards the sphere
  WallLine wall_line;                          ///< the face line used, image pixels
  bool wall_found_in_image = false;            ///< refined on (or found in) the frames' edge
  double wall_angle_sigma_rad = 0, wall_offset_sigma_px = 0;
  Sphere sphere_before, sphere_after;  ///< at contact: velocity, spin (position: before)
  bool spin_before_known = false, spin_after_known = false;
  Vec3 spin_sigma_before = Vec3::Zero(), spin_sigma_after = Vec3::Zero();
  /// Directions of the spin before that the dots pinned less well than the
  /// launchers' spread, combined with it (analysis/spin_prior.hpp): 0 to 3.
  int spin_before_prior_directions = 0;
  /// Velocity sigmas at contact and at separation: the fits' sigmas with the
  /// residuals' lag-1 inflation and the dots' drift (x, y; under a lens also
  /// the lamp's, radius_systematic_px over the track), widened under a lens
  /// by what the out-of-plane velocity's uncertainty moves them (a centre x
  /// off the optical axis placed on the wrong plane moves x dv_z / Z0 too
  /// fast or slow); z: the out-of-plane prior before the
  /// impact, the spread the spins leave after it. The propagation draws the
  /// same shares (v_z and the in-plane velocities together).
  Vec3 velocity_sigma_before = Vec3::Zero(), velocity_sigma_after = Vec3::Zero();
  WaltonMeasurement measured;
  double e_sigma = 0, beta_sigma = 0, gamma_sigma_rad = 0, f_sigma = 0;
  double vn_sigma_m_s = 0, vs_sigma_m_s = 0, beta_from_impulse_sigma = 0;
  /// Spread of beta - beta_from_impulse over the draws: the yardstick of the
  /// angular-momentum check ("spin_impulse_disagree", as ShotAnalysis).
  double beta_spin_minus_impulse_sigma = 0;
  /// measured.beta and beta_sigma are beta from the spins after the impact
  /// and beta_from_impulse combined (analysis/shot_uncertainty.hpp
  /// betaSpinWeight), beta_spin_weight on the first; the spins' own here.
  double beta_from_spins = 0, beta_from_spins_sigma = 0, beta_spin_weight = 1.0;
  std::vector<std::string> quality_flags;  ///< as ShotAnalysis; "no_spin_before", ...
  std::vector<std::string> notes;
};

/// The wall shot's sphere among a frame's detections: the one nearest the
/// expected radius `r_px` (within 30 % of it), or with r_px = 0 (the scale
/// unknown, footage) the largest; null when there is none.
const SphereMeasurement* wallSphere(const FrameSpheres& found, double r_px);

/// Analyses one wall burst, in stages: the sphere in each frame at the
/// working scale; the face (given or found); the flight on each side fitted
/// and where it meets the face; the spins from the dots; the sphere at the
/// face with the post-impact v_z from the spin change; Walton's inverse; the
/// uncertainties by Monte Carlo. Errors (saying what to do): no frame with the
/// sphere, fewer than 4 usable frames on a side of the impact, the sphere
/// never nearing the face line, settings out of range.
Result<WallShotAnalysis> analyzeWallBurst(const Burst& burst, const WallAnalysisSettings& settings);

}  // namespace collide::vision
