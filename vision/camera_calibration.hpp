#pragma once
// Camera calibration from pictures of a chessboard (issue 11): the lens'
// focal length, principal point and distortion (OpenCV's model, as
// analysis/camera_model.hpp), and the collision plane's distance from one
// picture of the board lying in that plane. With it the analysis turns
// pixels into metres through the real lens instead of one pixel size.
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "analysis/camera_model.hpp"
#include "analysis/result.hpp"

namespace collide::vision {

struct ChessboardSpec {
  cv::Size inner_corners{9, 6};  ///< corners where four squares meet, across x down
  double square_m = 0.01;        ///< side of one square
};

struct CameraCalibration {
  /// The lens, with centre_m = (0, 0, plane distance): the camera looks along
  /// -z at the collision plane z = 0, the world origin on the optical axis.
  PinholeCamera camera;
  double focal_aspect = 1.0;       ///< fy / fx as fitted (1 for square pixels)
  double rms_px = 0.0;             ///< reprojection error over every corner used
  double plane_tilt_deg = 0.0;     ///< the plane picture's board against the image plane
  int images_used = 0;             ///< pictures in which the board was found
  std::vector<std::string> notes;  ///< pictures left out and why
};

/// Calibrates from `images` (8- or 16-bit grey; at least 3 with the board
/// found, in varied poses); `plane_image` (an index into `images`) shows the
/// board lying in the collision plane. Errors name what is missing: too few
/// boards found, the plane picture's board not found, a fit that does not
/// converge.
Result<CameraCalibration> calibrateCamera(const std::vector<cv::Mat>& images,
                                          const ChessboardSpec& board, int plane_image = 0);

}  // namespace collide::vision
