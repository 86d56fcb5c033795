#include "vision/camera_calibration.hpp"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace collide::vision {
namespace {

cv::Mat to8bit(const cv::Mat& image) {
  if (image.depth() == CV_8U) return image;
  double lo = 0, hi = 0;
  cv::minMaxLoc(image, &lo, &hi);
  cv::Mat out;
  image.convertTo(out, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0,
                  hi > lo ? -lo * 255.0 / (hi - lo) : 0);
  return out;
}

std::vector<cv::Point3f> boardPoints(const ChessboardSpec& b) {
  std::vector<cv::Point3f> p;
  for (int y = 0; y < b.inner_corners.height; ++y)
    for (int x = 0; x < b.inner_corners.width; ++x)
      p.emplace_back(static_cast<float>(x * b.square_m), static_cast<float>(y * b.square_m), 0.f);
  return p;
}

}  // namespace

Result<CameraCalibration> calibrateCamera(const std::vector<cv::Mat>& images,
                                          const ChessboardSpec& board, int plane_image) {
  if (images.empty()) return fail("no pictures to calibrate from");
  if (plane_image < 0 || plane_image >= static_cast<int>(images.size()))
    return fail("the plane picture's index " + std::to_string(plane_image) + " is not among the " +
                std::to_string(images.size()) + " pictures");
  if (board.inner_corners.width < 3 || board.inner_corners.height < 3 || !(board.square_m > 0))
    return fail("the chessboard needs at least 3 x 3 inner corners and a square size > 0");
  CameraCalibration out;
  std::vector<std::vector<cv::Point2f>> found;
  std::vector<std::vector<cv::Point3f>> object;
  int plane_slot = -1;
  const cv::Size size = images.front().size();
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (images[i].size() != size) {
      out.notes.push_back("picture " + std::to_string(i) + ": a different size, left out");
      continue;
    }
    const cv::Mat grey = to8bit(images[i]);
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(grey, board.inner_corners, corners,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
      out.notes.push_back("picture " + std::to_string(i) + ": no " +
                          std::to_string(board.inner_corners.width) + " x " +
                          std::to_string(board.inner_corners.height) + " chessboard found");
      continue;
    }
    cv::cornerSubPix(grey, corners, cv::Size(5, 5), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
    if (static_cast<int>(i) == plane_image) plane_slot = static_cast<int>(found.size());
    found.push_back(corners);
    object.push_back(boardPoints(board));
  }
  if (plane_slot < 0)
    return fail("the chessboard was not found in the plane picture (" +
                std::to_string(plane_image) +
                "): without it the collision plane's distance is "
                "unknown; show the whole board lying in the collision plane");
  if (found.size() < 3)
    return fail("the chessboard was found in " + std::to_string(found.size()) + " of " +
                std::to_string(images.size()) +
                " pictures; at least 3 in varied poses (tilted, near the corners) are needed");
  cv::Mat K, dist;
  std::vector<cv::Mat> rvecs, tvecs;
  // k1, k2, p1, p2 (the model's), no k3.
  const double rms =
      cv::calibrateCamera(object, found, size, K, dist, rvecs, tvecs, cv::CALIB_FIX_K3);
  if (!std::isfinite(rms)) return fail("the calibration did not converge");
  const double fx = K.at<double>(0, 0), fy = K.at<double>(1, 1);
  PinholeCamera& c = out.camera;
  c.focal_px = 0.5 * (fx + fy);
  c.principal_u_px = K.at<double>(0, 2);
  c.principal_v_px = K.at<double>(1, 2);
  c.k1 = dist.at<double>(0), c.k2 = dist.at<double>(1);
  c.p1 = dist.at<double>(2), c.p2 = dist.at<double>(3);
  // The plane picture: the board's normal in camera axes and its distance.
  cv::Mat R;
  cv::Rodrigues(rvecs[plane_slot], R);
  const cv::Mat& t = tvecs[plane_slot];
  const double n[3] = {R.at<double>(0, 2), R.at<double>(1, 2), R.at<double>(2, 2)};
  out.plane_tilt_deg = std::acos(std::min(1.0, std::abs(n[2]))) * 180.0 / 3.14159265358979323846;
  // Where the optical axis meets the board's plane n . X = n . t.
  const double distance =
      (n[0] * t.at<double>(0) + n[1] * t.at<double>(1) + n[2] * t.at<double>(2)) / n[2];
  c.centre_m = Vec3(0, 0, distance);
  out.focal_aspect = fy / fx;
  out.rms_px = rms;
  out.images_used = static_cast<int>(found.size());
  return out;
}

}  // namespace collide::vision
