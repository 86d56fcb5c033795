#pragma once
// Camera calibration from pictures of a chessboard (issue 11): the lens'
// focal length, principal point and distortion (OpenCV's model, as
// analysis/camera_model.hpp), their standard uncertainties, and the collision
// plane's distance and pixel scale from one picture of the board lying in
// that plane. With it the analysis turns pixels into metres through the real
// lens instead of one pixel size.
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/camera_model.hpp"
#include "analysis/result.hpp"

namespace collide::vision {

struct ChessboardSpec {
  cv::Size inner_corners{9, 6};  ///< corners where four squares meet, across x down
  double square_m = 0.01;        ///< side of one square
};

/// Fewest pictures with the board found that a calibration accepts.
inline constexpr int kMinCalibrationViews = 3;

/// Standard uncertainties (one sigma) of the fitted values, from OpenCV's
/// calibrateCameraExtended (stdDeviationsIntrinsics: the fit's covariance
/// scaled by its residuals) and, for the plane, from the plane picture's
/// corners. With k2 held at 0 each is at least the fit with k2 free gives
/// (k1 takes up an unmeasured k2).
struct CalibrationSigma {
  double focal_px = 0;
  double principal_u_px = 0, principal_v_px = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0;
  double plane_distance_m = 0;    ///< 0 without a plane picture
  double plane_pixel_size_m = 0;  ///< 0 without a plane picture
};

struct CameraCalibration {
  /// The lens, with centre_m = (0, 0, plane distance): the camera looks along
  /// -z at the collision plane z = 0, the world origin on the optical axis.
  /// Without a plane picture the distance is unknown: centre_m.z() = 0.
  PinholeCamera camera;
  CalibrationSigma sigma;
  cv::Size image_size;  ///< of the pictures, px
  /// fy / fx: 1 (square pixels, the camera model's; the fit holds it).
  double focal_aspect = 1.0;
  double rms_px = 0.0;              ///< reprojection error over every corner used
  std::vector<double> view_rms_px;  ///< per picture given; NaN where left out
  bool has_plane = false;           ///< a plane picture was given and used
  /// k2 was fitted; false: held at 0 (sigma.k2 = 0) because the pictures do
  /// not measure it (fitted, it was within 2 sigma of 0; a note says so).
  bool k2_fitted = true;
  /// Metres per pixel at the collision plane on the optical axis (distance /
  /// focal length); 0 without a plane picture.
  double plane_pixel_size_m = 0.0;
  double plane_tilt_deg = 0.0;     ///< the plane picture's board against the image plane
  int images_used = 0;             ///< pictures in which the board was found
  std::vector<std::string> notes;  ///< pictures left out and why; k2 held
};

/// The board's inner corners in `image` (8- or 16-bit grey), sub-pixel, in
/// OpenCV's order (row by row from one end of the board); nullopt when the
/// board is not found whole.
std::optional<std::vector<cv::Point2f>> findChessboard(const cv::Mat& image,
                                                       const ChessboardSpec& board);

/// Calibrates from `images` (8- or 16-bit grey; at least kMinCalibrationViews
/// with the board found, in varied poses); `plane_image` (an index into
/// `images`, or -1 for none) shows the board lying in the collision plane.
/// `names` (optional, one per image) name the pictures in notes and errors.
/// Fits f (square pixels), the principal point and k1 k2 p1 p2 (k3 held at
/// 0, as the camera model; k2 too when the pictures do not measure it). Errors name what is
/// missing: too few boards found (and how many are needed), the plane picture's board not found, a
/// fit that does not converge.
Result<CameraCalibration> calibrateCamera(const std::vector<cv::Mat>& images,
                                          const ChessboardSpec& board, int plane_image = 0,
                                          const std::vector<std::string>& names = {});

}  // namespace collide::vision
