#pragma once
// Finds the bright spheres of one frame and measures each centre and radius to
// a small fraction of a pixel (SPEC step 1).
//
// Method. (1) Levels: the background and noise from a sparse sample of the
// frame (median, MAD). (2) Coarse: threshold a subsampled grid at a low level
// (background + 4 sigma: where a pixel leaves the background, so a limb in
// shadow, barely above the backdrop, is part of its sphere), keep connected
// blobs that also hold a sample above a high level (between background and the
// brightest pixels: hysteresis, so noise alone makes no blob), fit a circle to
// each blob's outline (a blob of two touching spheres is split in two; a blob
// that is only the lit part of its sphere, cut off by a chord where a limb
// darker than a grey backdrop crosses its level, gives the circle most of its
// outline lies on). (3) Fine: along image rows (left and right limbs) and
// columns (top and bottom), one edge point per line, each against the profile's
// OWN levels: its background is the mean of its outermost samples (which must
// be flat and dark: no other sphere, no glare), the limb's level is read just
// inside where the profile first leaves that background, and the crossing is
// 30 % of the way between. A profile that leaves its background downwards meets
// a limb darker than the backdrop (a grey backdrop, the shaded side under one
// lamp) and is read turned over about the background, its shading fitted apart
// from the brighter limbs'. The edge is then found by the area (zeroth-moment)
// method: the sum of the profile across the edge, minus the background, is the
// integral of the sphere's brightness over the covered length; that brightness
// near the limb is modelled per profile as a level plus a shape in the depth
// below the limb, either (depth, depth^2) (evenly or side lit) or (depth,
// sqrt(depth)) (Lambert's law where the limb faces the lamp's axis), chosen by
// fit. The shape is shared by the profiles of a stretch of the outline
// (one-sided light shades it differently all round) or by the whole outline
// when a stretch's own shape is not significantly better, and is refitted once
// from the measured edges. So neither a darker rim nor a dark or bright limb
// biases the edge, and any symmetric blur (optics, motion) cancels. Profiles
// that meet a dot, the other sphere, a highlight clipped at full scale or the
// frame border are rejected. (4) An algebraic circle fit then a geometric
// (Gauss-Newton) one with iterative outlier rejection; the covariance gives
// each sphere's uncertainty. A stretch of the outline whose points lie off
// the circle together is left out (fitCircle's leave_out_stretches; lit
// spheres only, not those step 5 measures): near the terminator, where the
// shadow line runs a few px inside the limb, the profile is a step, a
// plateau and a rise that the shading shapes do not hold, and once the
// sensor's noise hides it from the shading misfit its edge is read too
// deep. When the fitted circle lies farther from the coarse one than the
// coarse stage errs (a blob that was only part of its sphere), the profiles
// are read again around it, twice at most. With
// settings().camera the points are first mapped by the inverse of the outline's
// shape (PinholeCamera::outlineShape: off the optical axis a sphere is an
// ellipse up to ~1 % longer radially), so the fit sees a circle, and the circle
// is mapped back: the ellipse's centre, the mean of its semi-axes. (5) Small
// spheres (radius up to settings().silhouette_fit_max_radius_px, 30 px) are
// measured again by fitting every pixel around their outline with the image of
// a matte sphere under one lamp on a planar background
// (vision/silhouette_fit.hpp), started from the circle of (4), which stays if
// that fit fails: with 3-5 samples inside the limb the profiles' shading shapes
// flip with the noise.
//
// Backlit frames (dark silhouettes on a bright field, settings().polarity)
// are measured as their negative; their levels (background, rim) are
// reported in the frame's own grey levels.
//
// An outline cut by the frame's border is fitted on the arc in view, where a
// free radius and the centre trade off along the cut; when the radius is
// known from elsewhere (the same sphere's whole outlines), measureWithRadius
// fits the centre alone.
//
// Limits (issue 12): on shaded 60 px spheres the radius comes out ~0.04-0.07
// px small (a sqrt-shaped limb is extrapolated only approximately); the
// whole-image fit of (5) removes that (0.009 px centre, 0.007 px radius RMS
// on those frames) but costs ~3 times the detector's time at 60 px and, in
// the lab preset's whole chain (60 px spheres under a 50 mm lens at 0.53 m),
// made e worse (RMS 0.017 against 0.006-0.009) even fitting the perspective
// ellipse, for a reason not yet found (the same imaging made orthographic was
// fine), so it is not used there; on 18 px shaded spheres it gives 0.016 px
// centre RMS where the profiles gave 0.33. Where the limb crosses the
// backdrop's level it has no contrast: no edge there, and the profiles next
// to it are the least certain (on 60 px spheres before a grey backdrop,
// centre RMS about 0.075 px against 0.04-0.06 on a dark one). On a noisy
// sensor (a 4000 e- well under sim-lab's lamp) the shaded limb's faint edge
// is lost in the noise, and the stretches either side of it are still read
// somewhat deep: radius 0.5 px small, centre 0.6 px towards the lamp (0.6 and
// 0.73 px before such stretches were left out; at a 20,000 e- well 0.03 and
// 0.06 px).
//
// Image coordinates: u right, v down, origin at the top-left pixel's centre.
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/camera_model.hpp"
#include "analysis/result.hpp"

namespace collide::vision {

struct CirclePoint {
  double u = 0, v = 0;
};

/// A circle fitted to edge points (pixels).
struct CircleFit {
  double u = 0, v = 0, radius = 0;
  double sigma_u = 0, sigma_v = 0, sigma_radius = 0;  ///< standard uncertainties
  double residual_rms = 0;                            ///< of the points kept
  int points = 0;                                     ///< points kept
  int rejected = 0;                                   ///< outliers dropped
};

/// Algebraic (Kasa) then geometric least-squares circle through `points`, with
/// outliers beyond `reject_sigmas` robust standard deviations (but at least
/// `min_reject_px` from the circle) dropped and the fit repeated. With
/// `ordered` (points in order along the outline) a fit that neighbouring
/// points disagree with as a group (a long run of outliers on one side) is
/// replaced by the best circle through triples of points (RANSAC), then trimmed.
/// With `held_radius_px` > 0 only the centre is fitted, the radius held there;
/// the radius' own standard uncertainty `held_radius_sigma_px` is carried into
/// the centre's sigmas (as far as the points' arc lets the radius move it)
/// and is the fit's sigma_radius. With `leave_out_stretches`, a stretch of the
/// outline (one of 16 sectors about the centre) whose points lie off the
/// circle together, by more than 0.1 px and 4 standard errors, is left out
/// and the circle refitted, the worst first, four at most, while half the
/// points remain (the fine stage's limb near the terminator, read too deep).
/// Errors: fewer than 5 points, collinear points, a fit that does not converge.
Result<CircleFit> fitCircle(const std::vector<CirclePoint>& points, double reject_sigmas = 3.5,
                            double min_reject_px = 0.05, bool ordered = false,
                            double held_radius_px = 0, double held_radius_sigma_px = 0,
                            bool leave_out_stretches = false);

struct SphereDetectorSettings {
  /// Bright spheres on a dark background (front light), dark silhouettes on a
  /// bright field (backlight), or Auto: dark when most of the coarse grid's
  /// samples (every coarse_step-th pixel of every coarse_step-th row) are
  /// brighter than half of full scale and at most a fifth clipped. Dark frames are
  /// measured as their negative (full scale - grey level), by the same method.
  enum class Polarity { Auto, Bright, Dark };
  Polarity polarity = Polarity::Auto;
  /// Smaller blobs are ignored (noise, specks); 0: 1/40 of the image's smaller side.
  double min_radius_px = 0.0;
  double max_radius_px = 0.0;  ///< 0: half the image's smaller side
  /// Subsampling of the coarse grid in pixels; 0: automatic (a third of the
  /// smallest radius, from 1 to 8).
  int coarse_step = 0;
  /// Half-width (pixels) of the blur the edge profiles must tolerate: the
  /// transition window spans +-(edge_half_width + 1) px around the threshold
  /// crossing. Raise it for strong motion blur (e.g. (speed * exposure) / 2).
  double edge_half_width_px = 1.5;
  /// Edge points on every n-th row and column; 0: automatic (radius / 30,
  /// at least 1), which keeps ~170 points on a 60 px sphere.
  int line_stride = 0;
  /// Spheres up to this radius (pixels) are measured again by fitting their
  /// whole image, a matte sphere under one lamp on its background
  /// (vision/silhouette_fit.hpp): on small spheres the edge profiles have too
  /// few samples inside the limb to place a shaded edge. 0: never.
  double silhouette_fit_max_radius_px = 30.0;
  /// The camera's pinhole, when known: off-axis spheres are ellipses under
  /// perspective, and both the edge points' fit (step 4) and the small
  /// spheres' whole-image fit (vision/silhouette_fit.hpp) fit them as such.
  std::optional<PinholeCamera> camera;
};

/// One sphere found in one frame (pixels).
struct SphereMeasurement {
  CircleFit circle;
  bool cut_by_border = false;  ///< the outline runs off the frame
  /// Edge profiles left out because their window ran off the frame: the
  /// outline is whole but comes within a profile's length (about 15 px) of
  /// the border, and the circle rests on the rest of it. Any shading the
  /// edge model misses then moves the centre instead of the radius.
  int border_profiles = 0;
  bool touching = false;        ///< its blob was merged with another sphere's
  double background = 0;        ///< local background level, grey levels
  double rim_level = 0;         ///< mean brightness at the limb, grey levels
  int saturated_pixels = 0;     ///< pixels at full scale seen on its profiles
  bool silhouette_fit = false;  ///< the circle is from the whole-image fit (small spheres)
  /// Only the centre fitted, the radius held (SphereDetector::measureWithRadius).
  bool radius_held = false;
};

struct FrameSpheres {
  std::vector<SphereMeasurement> spheres;  ///< sorted by u
  double background = 0;                   ///< grey levels (frame median)
  double noise_sigma = 0;                  ///< grey levels, from the background MAD
  double bright = 0;               ///< grey levels: the brightest objects' (the spheres') level
  double threshold = 0;            ///< blob seed threshold (between background and brightest)
  double low_threshold = 0;        ///< where a pixel leaves the background (blob extents)
  bool saturated = false;          ///< a large part of the frame at full scale
  bool dark_spheres = false;       ///< measured as dark silhouettes (backlit)
  int blobs_ignored = 0;           ///< blobs too small, too large or not round
  std::vector<std::string> notes;  ///< why something was not found
};

/// Whether a sequence of frames is backlit: most of them, `dark_frames` of
/// `frames`, measured their spheres as dark silhouettes
/// (FrameSpheres::dark_spheres).
inline bool mostlyDark(int dark_frames, int frames) {
  return 2 * dark_frames > frames;
}

class SphereDetector {
 public:
  explicit SphereDetector(SphereDetectorSettings settings = {});
  const SphereDetectorSettings& settings() const { return settings_; }

  /// All spheres in `image` (CV_8UC1 or CV_16UC1; `max_value` is the format's
  /// full scale, e.g. 4095 for Mono12). Never throws for any image content;
  /// an empty or unsupported image gives no spheres and a note.
  /// Thread-safe (const).
  FrameSpheres detect(const cv::Mat& image, int max_value) const;

  /// Sphere `m` (found by detect in `image`, which gave `frame`) measured
  /// again from its edge profiles, against the frame's levels, with the
  /// radius held at `radius_px` (with settings().camera the ellipse's mean
  /// semi-axis), only the centre fitted; the held radius' standard
  /// uncertainty `radius_sigma_px` enters the centre's sigmas. For an outline
  /// cut by the frame's border: on the arc left in view, a free radius and
  /// the centre trade off along the cut, and the radius the whole outlines of
  /// the same track give pins it. None when the image is unusable or too few
  /// clean edge points remain. Thread-safe (const).
  std::optional<SphereMeasurement> measureWithRadius(const cv::Mat& image, int max_value,
                                                     const FrameSpheres& frame,
                                                     const SphereMeasurement& m, double radius_px,
                                                     double radius_sigma_px) const;

 private:
  SphereDetectorSettings settings_;
};

}  // namespace collide::vision
