#pragma once
// From a burst to a shot's kinematics and collision properties (docs/SPEC.md steps
// 1-6): spheres and dots in every frame, tracks (outlines cut by the frame's
// border measured again with their track's radius), trajectory fits, the
// collision instant from both sides, spins, then analysis/'s inverse Walton
// operator. This header is the contract between vision (which implements it)
// and its users (collide analyze, the GUI, the benchmarks).
//
// Coordinates. Image pixels: u right, v down, origin at the top-left pixel's
// centre. World (metres): x right, y up, z towards the camera; the world
// position of pixel (u, v) is ((u - origin_u) s, -(v - origin_v) s) for pixel
// size s. Times are seconds from the first analysed frame's timestamp.
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "analysis/air_drag.hpp"
#include "analysis/camera_model.hpp"
#include "analysis/result.hpp"
#include "analysis/shot_uncertainty.hpp"
#include "analysis/track_offset.hpp"
#include "analysis/trajectory.hpp"
#include "analysis/types.hpp"
#include "analysis/walton.hpp"
#include "vision/frame.hpp"
#include "vision/sphere_detector.hpp"
#include "vision/spin_fit.hpp"

namespace collide::vision {

struct AnalysisSettings {
  /// Metres per pixel in the object plane. 0: derived from the measured sphere
  /// radii and diameter_m (the --frames path).
  double pixel_size_m = 0.0;
  std::array<double, 2> diameter_m{0.0254, 0.0254};  ///< [left, right] sphere, m
  /// Masses, kg; 0 = homogeneous spheres of equal density (only ratios matter
  /// for e, beta, f).
  std::array<double, 2> mass_kg{0.0, 0.0};
  /// Image position of the world origin (pixels). Only shifts positions.
  double origin_u_px = 0.0, origin_v_px = 0.0;
  /// Direction of gravity in the image (u, v), unit; default: down the image.
  std::array<double, 2> gravity_dir_image{0.0, 1.0};
  /// Fix the trajectory fits' acceleration to g along gravity_dir_image.
  bool fix_gravity = true;
  /// The air the spheres fly through (kg/m^3; 1.204: dry air at 20 degrees C,
  /// 101.325 kPa; [analysis] air_density_kg_m3). With gravity fixed and a
  /// sphere's mass given, its drag (analysis/air_drag.hpp) is taken out of
  /// the trajectory fits: unmodelled, it takes ~0.0006 off e on 30 ms tracks
  /// at 1.5 m/s. 0: a vacuum.
  double air_density_kg_m3 = kAirDensity_kg_m3;
  /// Frame rate used when frames carry no usable timestamps (frames/s).
  double fps = 0.0;
  /// Prior standard deviation of the z part (towards the camera) of the unit
  /// line of centres at contact: how far out of one plane the spheres may
  /// meet (0.01 = a quarter of a millimetre for 2.54 cm spheres; the rig
  /// profile's [analysis] line_of_centres_tilt_deg sets it). When the
  /// camera's distance is known, the two spheres' apparent sizes measure it
  /// and this prior is combined with that; the spin changes then tell it
  /// when friction acts. Near head-on it limits v_s and beta (their
  /// uncertainties say so).
  double line_of_centres_z_sigma = 0.01;
  /// Prior standard deviation of each sphere's velocity out of the image
  /// plane before impact, as a fraction of its speed (launch misalignment;
  /// the thesis found it below 1 %; [analysis] launch_out_of_plane_fraction).
  /// Combined with v_z from the apparent size when the camera's distance is
  /// known; otherwise taken as 0 in the values, it widens the uncertainties
  /// of v_s, beta and f.
  double out_of_plane_speed_fraction = 0.005;
  /// Standard deviation of each component of a spin no dot shows, rad/s
  /// (the rig profile's [analysis] launch_spin_rad_s: the spread of the spins
  /// the launchers give). Such a spin is taken as zero and this widens the
  /// uncertainties of gamma, beta and f; too wide a value makes them
  /// pessimistic (a bare silhouette's gamma pulls were 0.2 at 50 rad/s with
  /// launches spinning 10 rad/s per axis).
  double unknown_spin_sigma_rad_s = kDefaultUnknownSpinSigma;
  /// Longest plausible contact duration, s. The pre-impact fits reach the
  /// contact distance when the spheres first touch, the post-impact fits when
  /// they part, so the post-impact instant may lag the pre-impact one by up to
  /// this (Hertz: about 0.2 ms for 2.54 cm Nylon 6/6 spheres at 2 m/s, longer
  /// for softer Teflon; the thesis found its two instants 0.1 ms apart).
  double contact_duration_s = 2e-4;
  /// Standard uncertainty of the detector's systematic radius error, px. Both
  /// spheres' outlines carry it (same detector, same lighting), and through
  /// the pixel size (derived from, or calibrated with, the radii) it moves the
  /// contact distance by 2 x this many pixels: the pre-impact instant earlier,
  /// the post-impact one later (or the reverse). It is also taken as how much
  /// the radius bias may change along a track (v_z from the size: Z0 sigma /
  /// (r T)) and differ between the two spheres (n_z from the sizes), and,
  /// with a lens, as how far the centre drifts over each track (the lit limb
  /// seen from a changing angle): that over the track's span is in each fit's
  /// velocity sigma (centreDriftSigma_m_s, vision/shot_fits.hpp). The rig
  /// profile's [analysis] radius_systematic_px. A floor: a shot whose
  /// outlines scatter more from frame to frame is analysed with 0.75 times
  /// that scatter (ShotAnalysis::radius_systematic_px).
  double radius_systematic_px = 0.1;
  /// Standard deviation of the measured centres' distance at contact beyond
  /// the diameters, px (the rig profile's [analysis] contact_distance_sigma_px):
  /// drawn in the Monte Carlo, so the sigmas at grazing incidence carry it.
  double contact_distance_sigma_px = 0.0;
  /// Standard deviation per image axis of a centre offset that holds over a
  /// track and differs between tracks, px (the rig profile's [analysis]
  /// centre_offset_px): combined with the dots' own (dotBias_m) in
  /// ShotModel::offset, drawn in the Monte Carlo and in the instant's weights.
  double centre_offset_px = 0.0;
  /// The part of that offset motion blur adds (the rig profile's
  /// blur_offset_onset_px and blur_offset_per_px2): per sphere, k (s -
  /// onset)^2 px with s its faster track's smear over the exposure, px.
  double blur_offset_onset_px = 0.0, blur_offset_per_px2 = 0.0;
  /// Distance from the camera's projection centre to the object plane (where
  /// pixel_size_m holds), m. When > 0 the apparent radius's change along each
  /// track gives the sphere's velocity towards the camera
  /// (SphereKinematics::vz_from_size_m_s); 0: unknown, not measured.
  double camera_distance_m = 0.0;
  /// The camera's lens when it is known (a camera calibration, or the
  /// simulated camera's [camera.imaging] perspective lens): sphere centres are
  /// then turned into metres through it, distortion removed and each
  /// silhouette's centre taken back to its sphere's (under perspective they
  /// differ), on the collision plane z = 0. pixel_size_m still gives the
  /// expected radii; camera_distance_m defaults to the lens' distance. None:
  /// pixels are pixel_size_m apart everywhere.
  std::optional<PinholeCamera> camera;
  /// Which way round the spheres are lit (SphereDetectorSettings::polarity):
  /// auto-detected per frame unless forced (`--polarity`).
  SphereDetectorSettings::Polarity polarity = SphereDetectorSettings::Polarity::Auto;
  /// Also work out what each group of inputs contributes to the sigmas of e,
  /// beta and gamma (ShotAnalysis::error_budget; `--error-budget`). Eight more
  /// Monte Carlo propagations: off unless asked for.
  bool error_budget = false;
  /// Optional progress callback (frames detected, total), called on the
  /// calling thread with the count increasing and last equal to total (frames
  /// are detected in parallel, so not every count is reported); may be empty.
  std::function<void(int, int)> progress;
};

/// One sphere found in one frame (pixels).
struct SphereDetection {
  double u_px = 0, v_px = 0, radius_px = 0;
  double sigma_px = 0;  ///< standard uncertainty of the centre, per axis
  /// The outline runs off the frame: its centre was measured with the radius
  /// held at the track's (remeasureCutOutlines), whose uncertainty sigma_px
  /// carries.
  bool cut_by_border = false;
  bool touching = false;  ///< outline merged with the other sphere's
};

/// One dot found on one sphere in one frame.
struct DotDetection {
  double u_px = 0, v_px = 0;      ///< image position
  Vec3 on_sphere = Vec3::Zero();  ///< unit vector from the sphere centre (camera axes)
};

struct FrameDetections {
  std::int64_t frame_id = 0;
  double t_s = 0.0;
  /// [0] = sphere 1 (left before impact), [1] = sphere 2; empty when not found.
  std::array<std::optional<SphereDetection>, 2> sphere;
  std::array<std::vector<DotDetection>, 2> dots;
  std::vector<std::string> notes;  ///< e.g. "third blob ignored", "saturated"
};

/// A value with its standard uncertainty, in the unit its field name says.
struct Measured {
  double value = 0;
  double sigma = 0;
};

struct SphereKinematics {
  Estimate3 velocity_before_m_s, velocity_after_m_s;  ///< at the collision instant
  Estimate3 spin_before_rad_s, spin_after_rad_s;
  int frames_before = 0, frames_after = 0;  ///< frames used by the fits
  /// Directions of spin_before the dots pinned less well than the launchers'
  /// spread (the rig profile's launch_spin_rad_s), taken with it as a prior
  /// there (analysis/spin_prior.hpp): 0 to 3. Such a spin is not a measure of
  /// the launchers' spread (collide fit leaves it out of it).
  int spin_before_prior_directions = 0;
  /// Velocity towards the camera from the apparent radius under perspective
  /// (analysis/depth_from_size.hpp), [0 before, 1 after], m/s; set when
  /// AnalysisSettings::camera_distance_m > 0 (or a lens is given) and a side
  /// has 3 or more frames whose outline is neither cut by the border nor
  /// merged. With all four, they are held to momentum conservation along z;
  /// the sigma includes a radius bias changing by radius_systematic_px.
  std::array<std::optional<Measured>, 2> vz_from_size_m_s;
};

struct CollisionProperties {
  /// beta: beta_from_spins (the contact velocity after the impact, from the
  /// post-impact spins) and beta_from_impulse (the velocities' change and the
  /// spins before: angular momentum about the contact point) combined as two
  /// correlated estimates of one value, beta_spin_weight on the first
  /// (analysis/shot_uncertainty.hpp betaSpinWeight); its sigma the
  /// combination's over the draws.
  Measured e, beta, beta_from_spins, beta_from_impulse, f, gamma_deg;
  double beta_spin_weight = 1.0;
  Measured vn_m_s;        ///< normal contact velocity before, < 0 on approach
  Measured vs_m_s;        ///< tangential contact speed before, >= 0
  Measured vs_after_m_s;  ///< v_s' . t (signed along the pre-impact tangent)
  /// From the first analysed frame: the two instants combined (weighted to
  /// cancel the contact distance's error). Sigma: the draws' spread, and half
  /// of any disagreement of the two instants that is more than one sigma
  /// outside what they may differ by (as collision_instant_disagree judges).
  Measured t_collision_s;
  /// Total kinetic energy after minus before (translation + rotation, the
  /// masses of AnalysisSettings, I = m d^2 / 10), J; > 0 is unphysical.
  Measured kinetic_energy_change_J;
  /// z part (towards the camera) of the unit line of centres at contact, as
  /// the inverse found it (apparent sizes, spin changes, the prior).
  Measured line_of_centres_z;
  /// The same from the two spheres' apparent sizes alone (their depths at
  /// the contact), when the camera's distance is known.
  std::optional<Measured> line_of_centres_z_from_size;
  /// The two collision-instant estimates (pre- and post-impact fits), s.
  double t_collision_before_s = 0, t_collision_after_s = 0;
};

struct ShotAnalysis {
  double pixel_size_m = 0;  ///< used (given or derived)
  std::vector<FrameDetections> frames;
  /// Fits in world metres on the same clock as the frames: [sphere][0 before, 1 after].
  std::array<std::array<std::optional<TrajectoryFit>, 2>, 2> trajectory;
  std::array<SphereKinematics, 2> sphere;
  CollisionProperties collision;
  /// Machine-readable reasons to distrust the shot:
  ///  "few_frames_before", "few_frames_after": a sphere has fewer than 5 frames
  ///    on that side of the impact;
  ///  "collision_instant_disagree": t_after - t_before lies outside
  ///    [0, contact_duration_s] by more than 4 sigma, sigma combining the fits'
  ///    random errors (residual correlation inflation included) and systematic
  ///    centre drifts (the Monte Carlo's spread of the difference) with the
  ///    contact distance's uncertainty from radius_systematic_px, which moves
  ///    the two instants apart by dd (1/|v_n| + 1/|v_n'|);
  ///  "unphysical": a value physics forbids, beyond 3 of its sigmas: e > 1 or
  ///    e < 0, beta outside [-1, 1], or kinetic energy gained (translational +
  ///    rotational, after minus before > 0); the notes say which;
  ///  "large_residuals": a track's weighted residual RMS (one axis, one side)
  ///    exceeds 0.1 px and 10 times the detector's typical centre uncertainty,
  ///    and those residuals have order (a smooth bend or an alternating
  ///    offset, analysis/residual_structure.hpp) or exceed 1 px. Independent
  ///    scatter below 1 px only widens the fits' sigmas (scaled by chi^2);
  ///  "e_untrustworthy_geometry", "beta_untrustworthy_geometry": SPEC eq. 5.1
  ///    (with the residual scatter as s) gives |v_n| or v_s a relative error > 5 %;
  ///    e's also when v_n's stated sigma exceeds 5 % of |v_n| (at grazing
  ///    incidence the line of centres' direction, which eq. 5.1 leaves out);
  ///  "no_spin_before", "no_spin_after": a sphere's spin could not be measured
  ///    on that side (taken as 0 +- 50 rad/s per axis, so the sigmas of gamma,
  ///    v_s and f show it); beta (and vs_after after, beta_from_impulse
  ///    before) is then NaN: unavailable, never guessed;
  ///  "spin_poorly_measured": a measured spin's sigma exceeds those 50 rad/s
  ///    on some axis (dots followed too briefly or matched badly; its errors
  ///    can reach hundreds of rad/s, beyond what beta's and gamma's sigmas
  ///    say); `collide fit` leaves the shot out. Before the impact the
  ///    launchers' spread is first combined with the directions the dots pin
  ///    less well than it (measureSpins), so there it fires only when that
  ///    spread is above 50 rad/s;
  ///  "spin_impulse_disagree": angular momentum about the contact point is not
  ///    conserved: beta_from_spins and beta_from_impulse
  ///    (the spins before plus what the impulse from the velocity changes
  ///    turns them by) differ by more than 4 sigma of their difference (its
  ///    Monte Carlo spread); a measured spin or velocity is wrong (a dot
  ///    taken for another); not checked with no_spin_*; `collide fit` leaves
  ///    the shot out;
  ///  "saturated_frames": some frames were mostly at full scale;
  ///  "extra_blobs_ignored": round blobs that are not this shot's spheres
  ///    (on neither track, and not centred on a tracked sphere, which would
  ///    be a second reading of it, nor slivers cut by the border);
  ///  "frames_lost": frames missing or incomplete in the burst;
  ///  "gravity_scale_mismatch": a free fit's fall differs from g by > 10 % (and
  ///    5 sigma): the pixel size, a diameter or the frame rate is wrong.
  std::vector<std::string> quality_flags;
  /// With AnalysisSettings::error_budget: the sigmas of e, beta and gamma
  /// with one group of inputs drawn at a time (analysis/shot_uncertainty.hpp
  /// errorBudget), in quadrature about the collision's sigmas. Empty when not
  /// asked for.
  std::vector<ErrorBudgetRow> error_budget;
  /// How much the outlines' radii scatter from frame to frame, px: the robust
  /// spread of each track's radii about a straight line in time (less the
  /// lens' radius at each place), pooled; NaN with no track of 5 frames.
  double radius_scatter_px = std::numeric_limits<double>::quiet_NaN();
  /// The radius bias' change along a track the sigmas carry, px: the
  /// profile's radius_systematic_px, or 0.75 times radius_scatter_px where
  /// that is larger (a note then says so).
  double radius_systematic_px = 0;
  /// Where each sphere's tracks bend, sphere 1's minus sphere 2's, against
  /// its spread over the draws (analysis/track_offset.hpp): a campaign's
  /// gaps measure the centre offset its tracks carry (`collide fit`). NaN
  /// where a sphere's velocity does not change.
  KinkGap kink_gap;
  /// Sentences explaining flags and what was set aside (e.g. why a spin could
  /// not be had, the fall rate behind gravity_scale_mismatch).
  std::vector<std::string> notes;
};

/// Analyses one burst. Bad frames (status not Good) are skipped and counted.
/// Errors (the message says what was wrong and what to do): no good frames, fewer
/// than two spheres in too many frames, no collision in the burst, frames of
/// different sizes, impossible geometry (e.g. wrong diameter).
Result<ShotAnalysis> analyzeBurst(const Burst& burst, const AnalysisSettings& settings);

}  // namespace collide::vision
