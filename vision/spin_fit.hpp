#pragma once
// A sphere's spin from its dots over a run of frames in free flight (SPEC
// step 4), where the spin is constant.
//
// Matching. Dots of consecutive frames are matched after rotating the first
// frame's dots by the rotation predicted from the spin found so far (nearest
// neighbour on the sphere, both ways); the pair's rotation is then the
// weighted least-squares rotation of the matches (analysis fitRotation,
// Kabsch). Where no prediction exists yet (the first pair) or it matches
// poorly, every rotation that takes a pair of dots onto a pair of the next
// frame with the same angular separation is tried, and the one most dots agree
// with is kept. This is the thesis' triplet idea reduced to pairs and scored
// by all dots at once.
//
// Fit. Matches chain into tracks (one per physical dot). All frames are then
// fitted at once: dot j of frame k is seen at the image-plane (x, y) of
// exp([w] (t_k - t_0)) b_j, plus a small shift of the whole frame (the error
// of its sphere centre, with the detector's uncertainty as its prior), with
// the spin w, each dot's body position b_j and the shifts unknown (weighted
// Gauss-Newton, outlying observations dropped). Residuals are taken in the
// image plane, where the dots' errors are isotropic. This uses every frame,
// not only the first and last (the mean of inter-frame rotations telescopes to
// those), and its covariance, scaled by the residuals, is the spin's
// uncertainty from the dots' noise.
//
// Bias per dot. A dot's centroid is displaced in a way that depends on where
// it is on the sphere (shading, the limb); along one track the displacement
// changes slowly, so the residuals hardly show it, yet each track turns with a
// slightly wrong spin. The spread of the spin when each track in turn is left
// out (a jackknife over tracks, each refit one Gauss-Newton step from the full
// fit) shows it: the covariance is the larger of the two in every direction.
// On the lab imaging this halves the spins' pulls (accuracy_bench).
#include <Eigen/Dense>
#include <vector>

#include "analysis/result.hpp"
#include "analysis/types.hpp"

namespace collide::vision {

/// Standard deviation given by default to each component of a spin that
/// could not be measured (no dot followed), rad/s: wide enough for any spin
/// the launchers give. The rig profile's [analysis] launch_spin_rad_s states
/// the rig's own (AnalysisSettings::unknown_spin_sigma_rad_s).
inline constexpr double kDefaultUnknownSpinSigma = 50.0;

/// One frame's dots on one sphere.
struct SpinFrame {
  double t_s = 0;
  /// Unit vectors from the centre, camera axes, lifted from image positions:
  /// (x, y) is the image offset from the centre over the (effective) radius.
  std::vector<Vec3> dots;
  /// Relative weights of the dots' image positions (1/variance up to a common
  /// factor), one per dot; empty: all 1.
  std::vector<double> weights;
  /// Standard uncertainty of this frame's sphere centre per axis, in units of
  /// the radius; > 0 adds a shift of all the frame's dots, with that prior, to
  /// the fit, so an error shared by the frame's dots is not taken for spin.
  double centre_sigma = 0;
};

struct SpinOptions {
  /// Largest rotation between consecutive frames considered (rad).
  double max_rotation_per_frame_rad = 0.6;
  /// A predicted dot must land within this angle of its match (rad).
  double match_gate_rad = 0.08;
  /// Minimum matched dots for a frame pair to count (2 is tried when no pair
  /// reaches it).
  int min_matches = 3;
  /// After a first fit, every dot within this angle of a track's fitted place
  /// joins it (rad), so frames with one or two dots count too.
  double regrow_gate_rad = 0.04;
};

struct SpinFit {
  Vec3 spin_rad_s = Vec3::Zero();                        ///< camera axes
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< (rad/s)^2
  Vec3 sigma_rad_s = Vec3::Zero();
  int frames = 0;               ///< frames with matched dots
  int pairs = 0;                ///< consecutive pairs matched
  int tracks = 0;               ///< dots followed over at least two frames
  int observations = 0;         ///< dot positions used by the fit
  int rejected = 0;             ///< observations dropped as outliers
  double residual_rms_rad = 0;  ///< of the used observations, unweighted
  /// Per input frame and dot: the track the dot belongs to, -1 if unmatched.
  std::vector<std::vector<int>> track_of;
};

/// Spin from `frames` (in time order, times strictly increasing).
/// Errors: fewer than 2 frames; no consecutive pair with enough matched dots;
/// too few observations for the fit (the message says how many were matched).
Result<SpinFit> fitSpin(const std::vector<SpinFrame>& frames, const SpinOptions& options = {});

}  // namespace collide::vision
