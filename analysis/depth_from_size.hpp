#pragma once
// Out-of-plane motion from the apparent size (issue 12 item 3). Under a
// pinhole camera a sphere of radius R at distance Z from the projection
// centre images with radius r = f R / Z (f in pixels; exact for the outline's
// circle to first order in R/Z). With Z0 the distance of the object plane
// (where the pixel size applies) and r0 the radius a sphere has there, a
// centre dz closer to the camera (z towards the camera) images with
//   r = r0 Z0 / (Z0 - dz),  so  dz = Z0 (1 - r0 / r).
// A straight-line fit of dz over a track gives the sphere's velocity out of
// the image plane, v_z. SI units: metres, seconds; radii in pixels.
//
// How much it can tell: d r / d z = r0 / Z0 per metre. For 60 px spheres 1 m
// from the camera a millimetre towards it grows the radius by 0.06 px; the
// detector's per-frame radius scatter (~0.01 px on simulated frames) then
// gives v_z to about 0.01 m/s over 20 frames at 1000 frames/s, i.e. about the
// thesis' 1 % launch misalignment at 1-2 m/s. A systematic radius error
// cancels in v_z (it shifts every dz alike) but not in the depth itself.
#include <Eigen/Dense>
#include <array>

#include "analysis/camera_model.hpp"
#include "analysis/result.hpp"

namespace collide {

/// dz = Z0 (1 - r0 / r): how far a centre imaged with radius r_px lies in
/// front of the object plane (m, > 0 towards the camera).
double depthFromRadius(double r_px, double r_plane_px, double camera_distance_m);

/// The radius (px) of the circle the detector fits to the silhouette of a
/// sphere of radius `radius_m` centred at `centre_m` (world), seen through
/// `camera`: the mean distance of the projected silhouette (the sphere's
/// tangent circle from the optical centre, distortion included) from its
/// centroid. Off the optical axis the silhouette is an ellipse larger than
/// f R / Z (by about 1 / cos^2 of the angle off axis radially, 1 / cos
/// tangentially: 1-2 % at the edge of a 50 mm lens' field) and barrel
/// distortion shrinks it again; a size change along a track is depth only
/// after this is taken out. NaN when the sphere is not in front of the camera.
double apparentRadiusPx(const PinholeCamera& camera, const Vec3& centre_m, double radius_m);

/// The radius (px) the lens gives a sphere of radius `radius_m` whose
/// silhouette is centred at (u, v) with its centre on the plane z = 0: what a
/// radius measured there is compared with for its depth. NaN as apparentRadiusPx.
double planeRadiusPx(const PinholeCamera& camera, double u_px, double v_px, double radius_m);

struct DepthMotion {
  double dz0_m = 0, dz0_sigma_m = 0;    ///< depth at t_ref, m
  double vz_m_s = 0, vz_sigma_m_s = 0;  ///< velocity towards the camera, m/s
  double chi2 = 0;
  int dof = 0;
};

/// Fits dz(t) = dz0 + v_z (t - t_ref) to a track's radii (px) with their
/// standard uncertainties (px): each dz carries Z0 r0 sigma_r / r^2. The
/// covariance is as the sigmas say (not rescaled by the residuals).
/// Errors: fewer than 3 frames, sizes that differ, a non-positive or
/// non-finite radius, sigma, r_plane_px or camera distance, all times equal.
Result<DepthMotion> fitDepthMotion(const Eigen::VectorXd& times_s, const Eigen::VectorXd& radii_px,
                                   const Eigen::VectorXd& radius_sigma_px, double r_plane_px,
                                   double camera_distance_m, double t_ref_s);

/// The same with each frame's own radius in the object plane (px), e.g.
/// apparentRadiusPx at the frame's position on the plane z = 0.
Result<DepthMotion> fitDepthMotion(const Eigen::VectorXd& times_s, const Eigen::VectorXd& radii_px,
                                   const Eigen::VectorXd& radius_sigma_px,
                                   const Eigen::VectorXd& r_plane_px, double camera_distance_m,
                                   double t_ref_s);

/// How far the fit's residuals exceed its sigmas: sqrt(chi2 / dof), at least 1.
double depthResidualScale(const DepthMotion& d);

/// The fit's sigmas made whole, for a track of radius `radius_px` spanning
/// `span_s`: scaled by depthResidualScale (then chi2 = dof), and v_z's with a
/// radius bias that changes by `radius_systematic_px` over the track (the lit
/// part of the limb seen from a changing angle): Z0 sigma_r / (r span). A
/// bias that stays the same cancels in v_z.
void completeDepthSigmas(DepthMotion& d, double camera_distance_m, double radius_px, double span_s,
                         double radius_systematic_px);

/// Momentum along z is conserved in the impact (the impulse is internal):
/// m1 (v1' - v1) + m2 (v2' - v2) = 0. Adjusts the four measured velocities
/// towards the camera, vz = {sphere 1 before, after, sphere 2 before, after}
/// (m/s) with standard uncertainties `sigma`, by weighted least squares onto
/// that constraint; `sigma` becomes the adjusted values' uncertainties. A
/// size-measured v_z after impact, off by a changing radius bias, is then
/// held by the three others. Nothing changes when a sigma is not finite and > 0.
void conserveMomentumZ(std::array<double, 4>& vz, std::array<double, 4>& sigma,
                       const std::array<double, 2>& mass_kg);

/// The post-impact depth line held to what the impact gives: its v_z becomes
/// the weighted mean of the size-measured one (`after`'s, with its sigma) and
/// `vz_impulse` (v_z before plus dP_z / m from the spin changes and the line
/// of centres, thesis appendix B: measured through the impulse, not through
/// a radius whose lit part changes along the track), and its depth joins the
/// pre-impact line's at the contact instant `t_contact_s` (a sphere does not
/// jump in depth), with that line's depth sigma. Both lines have their depth
/// at the same reference time (fitDepthMotion's t_ref_s), `t_ref_s`.
/// Nothing changes when vz_impulse or its sigma is not finite, or the sigma
/// is not > 0.
void holdDepthToImpulse(DepthMotion& after, const DepthMotion& before, double vz_impulse_m_s,
                        double vz_impulse_sigma_m_s, double t_contact_s, double t_ref_s);

}  // namespace collide
