#pragma once
// A fixed plate (sphere-on-wall shots) drawn into a rendered frame: the plate's
// face is a straight line in the image, the plate a band behind it. Pixels are
// blended by the share of their area behind the face (exact for a face along
// an image axis, within a few per cent of a pixel otherwise), so the face
// line is recoverable to sub-pixel accuracy; the band carries its own noise.
#include <Eigen/Dense>
#include <cstdint>
#include <opencv2/core.hpp>

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

struct WallLook {
  double thickness_px = 40;  ///< band width behind the face
  double level = 0.0;        ///< plate brightness, fraction of full scale
  double noise_grey = 0.0;   ///< std dev of the band's noise, grey levels
  std::uint64_t noise_seed = 1;
};

/// Paints the plate into `image` (CV_8U or CV_16U, full scale `max_value`).
/// Throws std::invalid_argument for another type or a zero normal (a bug).
void drawWall(cv::Mat& image, int max_value, const WallLine& wall, const WallLook& look);

}  // namespace collide::vision
