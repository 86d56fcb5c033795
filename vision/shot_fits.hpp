#pragma once
// Trajectory-fit stage of analyzeBurst (docs/SPEC.md steps 2-3): each
// sphere's centres fitted before and after the impact, the frames split at
// the closest approach, and the two collision instants from the fits.
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

#include "analysis/air_drag.hpp"
#include "analysis/camera_model.hpp"
#include "analysis/residual_structure.hpp"
#include "analysis/result.hpp"
#include "analysis/trajectory.hpp"
#include "vision/shot_tracking.hpp"

namespace collide::vision {

/// Image pixels to world metres on the collision plane: through the lens when
/// it is known (AnalysisSettings::camera), else x = (u - origin_u) s,
/// y = -(v - origin_v) s.
struct PixelScale {
  double px = 0;  ///< metres per pixel
  double ou = 0, ov = 0;
  std::optional<PinholeCamera> camera;
  std::array<double, 2> radius_m{0, 0};  ///< each sphere's, for the silhouette correction
  /// Each sphere's depth (m, towards the camera) at time t (s), when known
  /// (from its apparent size under the lens); with the lens, the centre seen
  /// at time t is then placed on the plane z = depth, not z = 0: a sphere
  /// 2 mm nearer a camera 0.53 m away otherwise moves 0.4 % too fast.
  std::array<std::function<double(double)>, 2> depth_m;
  /// World (x, y) of the centre of sphere `sphere` whose outline is `c`, seen at t_s.
  Eigen::Vector2d world(const CircleFit& c, int sphere,
                        double t_s = std::numeric_limits<double>::quiet_NaN()) const {
    if (!camera) return {(c.u - ou) * px, -(c.v - ov) * px};
    const double z = depth_m[sphere] && std::isfinite(t_s) ? depth_m[sphere](t_s) : 0.0;
    return camera->sphereCentre(c.u, c.v, radius_m[sphere], z).head<2>();
  }
};

struct SideFit {
  TrajectoryFit fit;
  std::vector<int> frames;  ///< indices into the FrameData vector
  /// residualInflation(fit) (analysis/residual_structure.hpp).
  double inflation = 1;
};

/// Dots crossing the limb displace the detected edge, and so the centre, by
/// an amount that grows with the motion blur smearing them over it; as the
/// sphere turns, the displacement changes slowly: an error correlated over
/// many frames that the trajectory fits absorb, so their residuals cannot
/// reveal it. Its RMS, px, on a bright (front-lit) sphere: 0.22 px / radius x
/// max(blur, 0.5 px) / 1.9 px, calibrated on simulated shots of 120 px
/// spheres blurred by 1.9 px (1000 frames/s, 200 us), where it is 0.004 px,
/// and of 90 px spheres blurred by 0.5 px (4000 frames/s, 50 us), where a
/// term without the blur made the sigmas five times too wide; below 0.5 px of
/// blur (a slow sphere) it was not measured and is held there
/// (docs/benchmarks.md, "Uncertainty calibration").
///
/// On a `dark` sphere (a silhouette on a backlight whose dots show in the
/// room light on its face) it is kDarkDotBiasPx2 / radius, whatever the
/// blur: there a dot at the limb darkens the level the edge is cut against
/// (30 % of the way from the bright field to the limb) by too little to be
/// dropped as a stray profile, and it moves the edge on every profile it
/// touches. Measured on noise-free simulated wall-backlit shots (60 px
/// spheres, 1.9 px of blur): 0.023 px, where the bright-sphere term gives
/// 0.004 px; with 0.2 px of blur the velocity errors were no smaller; with
/// the dots unlit, or still (no spin before the impact), the velocity pulls
/// were about 1 without it (docs/benchmarks.md, "The dots' pull on a
/// silhouette"). A sphere whose dots were seen on neither side carries none.
inline constexpr double kDarkDotBiasPx2 = 1.4;
double dotBiasPx(double radius_px, double blur_px, bool dark = false);

/// How far a track's sphere moves over one exposure (px): its speed at the
/// fit's reference instant times the exposure, over the pixel size.
double smearPx(const TrajectoryFit& fit, double exposure_s, double pixel_m);

/// That bias for a track (m), its blur from the track's speed over the
/// exposure.
double dotBias_m(const TrajectoryFit& fit, double radius_px, double pixel_m, double exposure_s,
                 bool dark = false);

/// The systematic velocity sigma that bias gives a track fitted over `fit`'s
/// span (m/s): dotBias_m / span. The Monte Carlos draw a sphere's two sides'
/// together, anti-correlated (analysis/shot_uncertainty.hpp, drawDriftPair).
double dotDriftSigma_m_s(const TrajectoryFit& fit, double radius_px, double pixel_m,
                         double exposure_s, bool dark = false);

/// A track's systematic velocity sigma (m/s): the dots' pull `dots_m_s`
/// (dotDriftSigma_m_s, 0 where no dot was seen) and, `through_lens`, the
/// lamp's. Under a lens the lit part of the limb is seen from a changing
/// angle as the sphere crosses the field, which moves the detected centre by
/// up to `radius_systematic_px` over a track (docs/benchmarks.md, session
/// 32): that over the track's span. The two are independent and add in
/// quadrature; the Monte Carlos draw the sum as they draw the dots' drift.
double centreDriftSigma_m_s(const TrajectoryFit& fit, double dots_m_s, bool through_lens,
                            double radius_systematic_px, double pixel_m);

/// What moves a sphere between frames besides its velocity: gravity (known,
/// or fitted with the acceleration free) and, with gravity known, the air's
/// drag on each sphere (analysis/air_drag.hpp; none in a vacuum or where the
/// sphere's mass is not known).
struct FreeFlight {
  Vec3 gravity = kGravity_m_s2;
  bool fix_gravity = true;
  std::array<std::optional<AirDrag>, 2> drag;  ///< per sphere
};

/// Fits one sphere's centres over `frames` (metres, world axes), dropping
/// frames that lie far off the fit (more than 5 robust sigmas) once.
Result<SideFit> fitSide(const std::vector<FrameData>& data, std::vector<int> frames, int sphere,
                        const PixelScale& scale, const FreeFlight& flight, double t_ref);

/// Both spheres fitted on both sides of the impact, and the collision
/// instants the two pairs of fits give.
struct CollisionFits {
  std::array<std::array<std::optional<SideFit>, 2>, 2> fit;  ///< [sphere][0 before, 1 after]
  double t_split = 0;                                        ///< closest approach's frame time
  double t_before = 0, t_after = 0;                          ///< collision instants, s
  double sigma_before = 0, sigma_after = 0;                  ///< their fit uncertainties, s
  /// False when the fitted centres never came within the contact distance on
  /// some side (a nearly grazing impact): t_before and t_after are then both
  /// where each sphere's two fits meet (kinkInstant), and `shortfall_m` how
  /// far beyond the contact distance the fits' centres were there.
  bool contact_reached = true;
  double shortfall_m = 0;
};

/// Both collision instants of `fits` (collisionInstant: from the pre-impact
/// fits and from the post-impact ones) where the centres are `contact_m`
/// apart, with their sigmas. Where the fits never come that close on a side,
/// the instant where each sphere's two fits meet (kinkInstant), if it is
/// one. On failure the fits are left as they were.
Status findInstants(CollisionFits& fits, double contact_m, double contact_sigma_m);

/// A nearly grazing impact whose fitted centres pass just outside the contact
/// distance (the radius' bias, the fits' errors) still bent each sphere's
/// track where the spheres touched: the instant where a sphere's pre- and
/// post-impact fits meet (kinkTime), the spheres' two weighed by how
/// precisely each places it (its fits' position sigmas along its velocity
/// change). A sphere counts when its velocity changed by more than 5 sigmas
/// (spheres that missed each other did not change theirs). Errors: no sphere
/// counts; at that instant the pre- or post-impact fits' centres lie further
/// apart than the contact distance by more than 4 sigmas (the contact
/// distance's `contact_sigma_m` and the fits' own). Sets t_before = t_after,
/// their sigma, contact_reached false and shortfall_m.
Status kinkInstant(CollisionFits& fits, double contact_m, double contact_sigma_m);

/// Splits the tracks at the closest approach, fits each side, finds the
/// contact instants; the closest frame then joins the side it was exposed on
/// unless its exposure straddles the impact, and the fits are redone.
/// Errors: too few frames on a side, a failed fit, no contact found, an
/// instant outside the burst.
Result<CollisionFits> fitCollision(const std::vector<FrameData>& data, const PixelScale& scale,
                                   double contact_m, double contact_sigma_m,
                                   const FreeFlight& flight, double exposure_s, double frame_dt);

/// The acceleration along gravity (image direction gdir, unit) from free
/// fits (acceleration fitted) of every side with at least 6 frames, weighted
/// by their uncertainties: {value, sigma} m/s^2, or nullopt when none.
std::optional<std::array<double, 2>> fallAlongGravity(const std::vector<FrameData>& data,
                                                      const CollisionFits& fits,
                                                      const PixelScale& scale,
                                                      const Eigen::Vector2d& gdir);

}  // namespace collide::vision
