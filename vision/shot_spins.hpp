#pragma once
// Dots-and-spins stage of analyzeBurst (docs/SPEC.md step 4): the dots on
// each sphere in every fitted frame, lifted with the track's radius, and the
// spin of each sphere on each side of the impact.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "analysis/types.hpp"
#include "vision/dot_detector.hpp"
#include "vision/frame.hpp"
#include "vision/shot_fits.hpp"
#include "vision/spin_fit.hpp"

namespace collide::vision {

// The spin fits' scatter-based uncertainties fall short by about this factor
// (slowly changing dot-centroid errors); calibrated on simulated shots.
inline constexpr double kSpinSigmaScale = 1.25;
// A measured spin whose sigma on some axis is above this (rad/s) is no better
// known than an unmeasured one at the default prior: spin_poorly_measured.
inline constexpr double kPoorlyMeasuredSpinSigma = 50.0;
// Through a lens the spins carry an error common to all their dots: about
// 0.3 % of |omega| on simulated lab imaging, mostly a tilt of the axis by a
// few tenths of a degree, with even light and without distortion too. Its
// cause is not found (not the spheres' depth, the distortion, the dots' size
// or the light: docs/benchmarks.md, session 11); it is stated instead. It
// lies in the spin's parts about the image plane's axes (x, y), which come
// from the dots lifted onto the sphere through the lens; the part about the
// camera's axis (z) is read from the dots' turning in the image and does not
// carry it (session 32: on lab and wall-lab imaging the z errors lie within
// the fit's own sigma; on the lab the x and y errors go beyond it).
inline constexpr double kLensSpinRelativeSigma = 0.003;

/// Adds (kLensSpinRelativeSigma |spin|)^2 to the x and y variances of a
/// spin's covariance measured through a lens (z: the camera's axis).
void addLensSpinSystematic(Eigen::Matrix3d& cov, const Vec3& spin);

struct SideSpin {
  Vec3 spin = Vec3::Zero();                           ///< rad/s; zero when unknown
  Eigen::Matrix3d cov = Eigen::Matrix3d::Identity();  ///< scaled by kSpinSigmaScale^2
  Vec3 sigma = Vec3::Zero();                  ///< reported per-axis sigma (NaN when unknown)
  std::optional<std::string> unknown_reason;  ///< set when no spin could be fitted
  /// Before the impact: directions the dots pinned less well than the
  /// launchers' spread, combined with it (analysis/spin_prior.hpp), 0 to 3.
  int prior_directions = 0;
};

struct ShotSpins {
  std::array<std::array<SideSpin, 2>, 2> side;  ///< [sphere][0 before, 1 after]
  std::vector<std::array<DotFrame, 2>> dots;    ///< per FrameData, per sphere
};

/// Finds the dots of each sphere in the frames its side fits used and fits
/// the spins. An unknown spin is zero with `unknown_spin_sigma` (rad/s) per
/// axis: the launchers' spin, as the rig profile states it. A spin measured
/// before the impact is combined with that prior in the directions its dots
/// pin less well than it (combineWithLaunchPrior). When
/// `scale` carries the camera's lens, each dot is lifted onto its sphere
/// through the lens (liftThroughLens) rather than orthographically.
ShotSpins measureSpins(const Burst& burst, const std::vector<FrameData>& data,
                       const CollisionFits& fits, const std::array<double, 2>& r_med_px,
                       int max_value, double unknown_spin_sigma, const PixelScale* scale = nullptr);

/// The measured spins no better known than an unmeasured one: an axis' sigma
/// above kPoorlyMeasuredSpinSigma (a dot matched badly or followed too briefly; the
/// sigmas then understate errors of hundreds of rad/s). One note per such
/// spin, naming the sphere and the side; empty when there is none. Unknown
/// spins are not counted (they carry their own no_spin_* flags). The shot's
/// "spin_poorly_measured" flag.
std::vector<std::string> poorlyMeasuredSpins(const ShotSpins& spins);

/// Where pixel (u, v)'s ray meets a sphere of radius `radius_m` centred at
/// `centre_m` (world) nearest the camera, as a unit vector from the centre
/// (world axes: x right, y up, z towards the camera); a ray that misses it is
/// taken to its closest point. Under perspective the camera sees less than a
/// hemisphere (the limb lies R / L short of the equator), and an orthographic
/// lift misplaces dots near the limb by up to that: spins a few % off.
Vec3 liftThroughLens(const PinholeCamera& camera, const Vec3& centre_m, double radius_m,
                     double u_px, double v_px);

}  // namespace collide::vision
