#pragma once
// The plate's face found in the footage (sphere-on-wall shots): the per-pixel
// median of frames spread over the burst removes the moving sphere; the
// strongest straight edge there (Canny + Hough) is the face's rough line,
// or a given line is the start; edge points are then measured to sub-pixel
// accuracy along profiles across the line (the 50 % crossing between the
// plate's level and the background's) and a straight line fitted to them by
// total least squares (in a lens' ideal pixels when one is given), outliers
// dropped.
#include <optional>

#include "analysis/camera_model.hpp"
#include "analysis/result.hpp"
#include "vision/frame.hpp"
#include "vision/render_wall.hpp"

namespace collide::vision {

struct WallLineFit {
  WallLine line;               ///< normal's sign arbitrary (the analysis takes the sphere's side)
  double angle_sigma_rad = 0;  ///< standard uncertainty of the line's direction
  double offset_sigma_px = 0;  ///< ... of its position along the normal (at the points' mean)
  double residual_rms_px = 0;
  int points = 0;  ///< edge points kept
};

/// Without a guess, the strongest straight edge; of the edges parallel to it
/// (a plate shows its face and its back), the one nearest `sphere_px` (a
/// sphere centre: the face is the edge the sphere flies at) when given.
/// With a `camera` whose lens bends straight lines, the edge points are
/// fitted in its ideal (undistorted) pixels, where the face is straight; the
/// line returned is then the image's tangent to the bent face at the points'
/// mean, and the sigmas are in ideal pixels (the same to within the
/// distortion's few per cent). The sigmas are those of independent residuals
/// or, where larger, a jackknife over ten stretches of the edge (residuals
/// that wander together along it).
/// Errors: no good frames; no straight edge found; too few edge points (< 10).
Result<WallLineFit> findWallLine(const Burst& burst, std::optional<WallLine> guess = std::nullopt,
                                 std::optional<Eigen::Vector2d> sphere_px = std::nullopt,
                                 const PinholeCamera* camera = nullptr);

}  // namespace collide::vision
