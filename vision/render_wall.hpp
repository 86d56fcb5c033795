#pragma once
// A fixed plate (sphere-on-wall shots) drawn into a rendered frame: the plate's
// face is a straight line in the image (bent as a lens bends it, WallBend),
// the plate a band behind it. Pixels are
// blended by the share of their area behind the face (exact for a face along
// an image axis, within a few per cent of a pixel otherwise), so the face
// line is recoverable to sub-pixel accuracy; the band carries its own noise.
#include <Eigen/Dense>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace collide::vision {

/// The plate's face in the image (u right, v down).
struct WallLine {
  Eigen::Vector2d point_px{0, 0};  ///< any point of the face line
  /// Unit normal of the face in the image, out of the plate (towards the
  /// sphere's side); the plate lies where (p - point_px) . normal < 0.
  Eigen::Vector2d normal{0, -1};

  /// Signed distance of pixel (u, v) from the face, px (> 0: the sphere's side).
  double distancePx(double u, double v) const {
    return (Eigen::Vector2d(u, v) - point_px).dot(normal);
  }
};

/// How far the face's image departs from the straight WallLine under a lens
/// that bends straight lines (barrel or pincushion distortion): the offset
/// along the line's normal (px, > 0 towards the sphere's side) at positions
/// along it, s = (p - point_px) . t with t = (-n_v, n_u), tabulated every
/// `step_px` from `first_px`; linear between entries, the end values beyond.
/// Empty: a straight face (no lens, or an undistorted one).
struct WallBend {
  double first_px = 0, step_px = 1;
  std::vector<double> offset_px;
  double at(double s) const;
};

struct WallLook {
  double thickness_px = 40;  ///< band width behind the face
  double level = 0.0;        ///< plate brightness, fraction of full scale
  double noise_grey = 0.0;   ///< std dev of the band's noise, grey levels
  std::uint64_t noise_seed = 1;
};

/// Paints the plate into `image` (CV_8U or CV_16U, full scale `max_value`),
/// its face bent by `bend` when given (the band's back edge with it).
/// Throws std::invalid_argument for another type or a zero normal (a bug).
void drawWall(cv::Mat& image, int max_value, const WallLine& wall, const WallLook& look,
              const WallBend& bend = {});

}  // namespace collide::vision
