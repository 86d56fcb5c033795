#include "vision/camera_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace collide::vision {
namespace {

constexpr double kPi = 3.14159265358979323846;

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

// The shortest distance, px, between neighbouring corners of a found board.
double cornerSpacing(const std::vector<cv::Point2f>& corners, cv::Size grid) {
  double best = std::numeric_limits<double>::infinity();
  for (int y = 0; y < grid.height; ++y)
    for (int x = 0; x < grid.width; ++x) {
      const cv::Point2f& p = corners[static_cast<std::size_t>(y * grid.width + x)];
      if (x + 1 < grid.width) best = std::min(best, cv::norm(p - corners[y * grid.width + x + 1]));
      if (y + 1 < grid.height)
        best = std::min(best, cv::norm(p - corners[(y + 1) * grid.width + x]));
    }
  return best;
}

// Sub-pixel corners. cv::cornerSubPix asks every pixel's gradient to be
// normal to its offset from the corner; on a sampled image a sharp edge's
// few pixels sit unevenly either side of it, and the corner moves by up to
// ~0.1 px, depending on how that corner falls on the pixel grid. Those errors
// repeat wherever a board is drawn the same way, so they do not average out
// over views: in session 15's tests they biased k1 by 1.2-2 of its stated
// sigma in every run (docs/benchmarks.md, "Camera calibration"). Smoothing
// first (Gaussian, sigma 2 px, less on small squares) spreads each edge over
// enough pixels for that balance to hold: corner errors 0.080 -> 0.019 px
// RMS on the boards of CameraCalibration.CornersLandWhereTheLensPutsThem,
// and k1 within its sigma. Done on the picture's own
// grey levels (not the 8-bit copy the board finder needs).
void refineCorners(const cv::Mat& image, cv::Size grid, std::vector<cv::Point2f>& corners) {
  const double spacing = cornerSpacing(corners, grid);
  const double sigma = std::clamp(spacing / 8.0, 0.5, 2.0);
  const int half = std::clamp(static_cast<int>(spacing / 4.0), 2, 5);
  cv::Mat grey, smooth;
  if (image.channels() == 1)
    image.convertTo(grey, CV_32F);
  else {
    cv::cvtColor(image, grey, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    grey.convertTo(grey, CV_32F);
  }
  cv::GaussianBlur(grey, smooth, cv::Size(0, 0), sigma);
  cv::cornerSubPix(smooth, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
}

// The boards found: corners per used picture and which picture each came from.
struct Found {
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> image;  // index into the pictures given
  int plane_slot = -1;
};

Found findBoards(const std::vector<cv::Mat>& images, const ChessboardSpec& board, int plane_image,
                 const std::vector<std::string>& names, CameraCalibration& out) {
  Found f;
  const cv::Size size = images.front().size();
  for (std::size_t i = 0; i < images.size(); ++i) {
    const std::string name = i < names.size() ? names[i] : "picture " + std::to_string(i);
    if (images[i].size() != size) {
      out.notes.push_back(name + ": " + std::to_string(images[i].cols) + " x " +
                          std::to_string(images[i].rows) + " px, not the first picture's " +
                          std::to_string(size.width) + " x " + std::to_string(size.height) +
                          ": left out");
      continue;
    }
    auto corners = findChessboard(images[i], board);
    if (!corners) {
      out.notes.push_back(name + ": no " + std::to_string(board.inner_corners.width) + " x " +
                          std::to_string(board.inner_corners.height) +
                          " chessboard (inner corners) found: left out");
      continue;
    }
    if (static_cast<int>(i) == plane_image) f.plane_slot = static_cast<int>(f.corners.size());
    f.corners.push_back(std::move(*corners));
    f.image.push_back(static_cast<int>(i));
  }
  return f;
}

// Leaves out the boards whose reprojection error is more than 3 times the
// median and above 0.5 px (a corner found on the wrong feature), never the
// plane picture's; returns how many.
int dropMisfits(Found& f, const cv::Mat& per_view, const std::vector<std::string>& names,
                std::vector<std::string>& notes) {
  std::vector<double> e(per_view.begin<double>(), per_view.end<double>());
  std::vector<double> sorted = e;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double limit = std::max(0.5, 3 * sorted[sorted.size() / 2]);
  Found kept;
  int dropped = 0;
  for (std::size_t k = 0; k < f.corners.size(); ++k) {
    const int i = f.image[k];
    if (e[k] > limit && static_cast<int>(k) != f.plane_slot) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.2f px, over %.2f px", e[k], limit);
      notes.push_back(
          (i < static_cast<int>(names.size()) ? names[i] : "picture " + std::to_string(i)) +
          ": the board fits the lens badly (reprojection error " + buf +
          "; a corner found on the wrong feature?): left out");
      ++dropped;
      continue;
    }
    if (static_cast<int>(k) == f.plane_slot)
      kept.plane_slot = static_cast<int>(kept.corners.size());
    kept.corners.push_back(f.corners[k]);
    kept.image.push_back(i);
  }
  if (dropped > 0) f = std::move(kept);
  return dropped;
}

// Metres per ideal pixel of the plane picture's board, with its standard
// uncertainty: a similarity (scale, rotation, shift) fitted from the board's
// corners (metres) to their undistorted pixels, by least squares in complex
// numbers. The uncertainty of k1 and k2 adds what it does to the scale over
// the board's field.
std::pair<double, double> planeScale(const std::vector<cv::Point2f>& corners,
                                     const ChessboardSpec& board, const PinholeCamera& c,
                                     const CalibrationSigma& s) {
  const std::vector<cv::Point3f> q3 = boardPoints(board);
  const std::size_t n = q3.size();
  std::vector<std::complex<double>> p(n), q(n);
  std::complex<double> pm, qm;
  double r2_mean = 0, r4_mean = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d xy = c.normalised(corners[i].x, corners[i].y);
    r2_mean += xy.squaredNorm() / n;
    r4_mean += xy.squaredNorm() * xy.squaredNorm() / n;
    p[i] = {c.focal_px * xy.x(), c.focal_px * xy.y()};
    q[i] = {q3[i].x, q3[i].y};
    pm += p[i] / static_cast<double>(n);
    qm += q[i] / static_cast<double>(n);
  }
  double best_res = std::numeric_limits<double>::infinity(), scale = 0, spread = 0;
  for (const bool mirror : {false, true}) {  // the board seen from either side
    std::complex<double> num, a;
    double den = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::complex<double> dq = mirror ? std::conj(q[i] - qm) : q[i] - qm;
      num += (p[i] - pm) * std::conj(dq);
      den += std::norm(dq);
    }
    a = num / den;
    double res = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::complex<double> dq = mirror ? std::conj(q[i] - qm) : q[i] - qm;
      res += std::norm(p[i] - pm - a * dq);
    }
    if (res < best_res) best_res = res, scale = std::abs(a), spread = den;
  }
  const double sigma_px = std::sqrt(best_res / std::max<double>(1, 2.0 * n - 4));
  // The residuals are mostly the corner finder's bias on a sampled image
  // (and a board not quite flat), alike for neighbouring corners, not
  // independent noise: they may stretch the whole board. So the scale's
  // uncertainty is the residual over the corners' RMS distance from their
  // centroid (what a coherent stretch of that size does), not that over
  // sqrt(n) times it (what independent noise would do). Conservative:
  // bench/calibration_bench finds the errors a few times smaller.
  const double spread_px = scale * std::sqrt(spread / static_cast<double>(n));
  const double rel_corners = sigma_px / spread_px;
  const double rel_lens = std::hypot(s.k1 * r2_mean, s.k2 * r4_mean);
  return {1.0 / scale, std::hypot(rel_corners, rel_lens) / scale};
}

}  // namespace

std::optional<std::vector<cv::Point2f>> findChessboard(const cv::Mat& image,
                                                       const ChessboardSpec& board) {
  std::vector<cv::Point2f> corners;
  if (!cv::findChessboardCorners(to8bit(image), board.inner_corners, corners,
                                 cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
    return std::nullopt;
  refineCorners(image, board.inner_corners, corners);
  return corners;
}

namespace {

// OpenCV's fit of the views found: one focal length (square pixels, fy / fx
// held at 1), k1 k2 p1 p2, no k3: the camera model's parameters.
struct LensFit {
  std::vector<std::vector<cv::Point3f>> object;
  cv::Mat K, dist, sd_in, sd_ex, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  double rms = 0;

  Status fit(const Found& found, cv::Size image_size, int extra_flags) {
    object.resize(found.corners.size());  // views only ever dropped
    K = cv::Mat::eye(3, 3, CV_64F);
    dist = cv::Mat();
    rms =
        cv::calibrateCamera(object, found.corners, image_size, K, dist, rvecs, tvecs, sd_in, sd_ex,
                            per_view, cv::CALIB_FIX_K3 | cv::CALIB_FIX_ASPECT_RATIO | extra_flags);
    if (!std::isfinite(rms)) return fail("the calibration did not converge");
    return Ok{};
  }
};

// k2 only where the pictures measure it: a narrow field (a long lens) leaves
// k2 r^4 below the corners' noise, and an unmeasurable k2 drags k1 with it.
// Held at 0, k2 is not known to be 0: where it is not, k1 (and f) take up
// its part of the distortion. The fit with k2 free says how far that can
// go, so each sigma is at least that fit's (a 0.05 k2 held at 0 moved k1
// by 4 of the held fit's sigmas in tests/vision/camera_calibration_test).
Status holdUnmeasuredK2(LensFit& lens, const Found& found, CameraCalibration& out) {
  if (std::abs(lens.dist.at<double>(1)) > 2 * lens.sd_in.at<double>(5)) return Ok{};
  const double k2 = lens.dist.at<double>(1), sk2 = lens.sd_in.at<double>(5);
  const cv::Mat sd_free = lens.sd_in.clone();
  if (auto st = lens.fit(found, out.image_size, cv::CALIB_FIX_K2); !st) return st.error();
  for (int i = 0; i < 8; ++i)
    if (i != 5)
      lens.sd_in.at<double>(i) = std::max(lens.sd_in.at<double>(i), sd_free.at<double>(i));
  out.k2_fitted = false;
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "k2 held at 0: these pictures do not measure it (fitted %.3g +- %.3g); tilt "
                "the board more and fill the corners to measure it",
                k2, sk2);
  out.notes.push_back(buf);
  return Ok{};
}

// The lens (focal length, principal point, distortion) and their sigmas,
// the fit's residuals per picture.
void fillLens(const LensFit& lens, const Found& found, std::size_t pictures,
              CameraCalibration& out) {
  PinholeCamera& c = out.camera;
  c.focal_px = lens.K.at<double>(1, 1);
  c.principal_u_px = lens.K.at<double>(0, 2);
  c.principal_v_px = lens.K.at<double>(1, 2);
  c.k1 = lens.dist.at<double>(0), c.k2 = lens.dist.at<double>(1);
  c.p1 = lens.dist.at<double>(2), c.p2 = lens.dist.at<double>(3);
  c.centre_m = Vec3::Zero();
  const auto sd = [&](int i) { return lens.sd_in.at<double>(i); };
  CalibrationSigma& s = out.sigma;
  s.focal_px = std::max(sd(0), sd(1));  // fx follows fy: one free focal length
  s.principal_u_px = sd(2), s.principal_v_px = sd(3);
  s.k1 = sd(4), s.k2 = sd(5), s.p1 = sd(6), s.p2 = sd(7);
  out.focal_aspect = lens.K.at<double>(0, 0) / lens.K.at<double>(1, 1);
  out.rms_px = lens.rms;
  out.images_used = static_cast<int>(found.corners.size());
  out.view_rms_px.assign(pictures, std::nan(""));
  for (std::size_t k = 0; k < found.image.size(); ++k)
    out.view_rms_px[found.image[k]] = lens.per_view.at<double>(static_cast<int>(k));
}

// The plane picture: the board's normal in camera axes and its distance.
void fillPlane(const LensFit& lens, const Found& found, const ChessboardSpec& board,
               CameraCalibration& out) {
  PinholeCamera& c = out.camera;
  CalibrationSigma& s = out.sigma;
  const int slot = found.plane_slot;
  cv::Mat R;
  cv::Rodrigues(lens.rvecs[slot], R);
  const cv::Mat& t = lens.tvecs[slot];
  const double n[3] = {R.at<double>(0, 2), R.at<double>(1, 2), R.at<double>(2, 2)};
  out.plane_tilt_deg = std::acos(std::min(1.0, std::abs(n[2]))) * 180.0 / kPi;
  // Where the optical axis meets the board's plane n . X = n . t.
  const double distance =
      (n[0] * t.at<double>(0) + n[1] * t.at<double>(1) + n[2] * t.at<double>(2)) / n[2];
  c.centre_m = Vec3(0, 0, distance);
  out.has_plane = true;
  out.plane_pixel_size_m = distance / c.focal_px;
  // The distance alone is as uncertain as the focal length (the board's image
  // size fixes their ratio): tz's uncertainty from the joint fit (extrinsics
  // are rvec, tvec per view).
  s.plane_distance_m = lens.sd_ex.at<double>(6 * slot + 5);
  const auto [size_m, size_sigma_m] = planeScale(found.corners[slot], board, c, s);
  (void)size_m;  // the same scale as distance / focal for a board facing the camera
  s.plane_pixel_size_m = size_sigma_m;
}

}  // namespace

Result<CameraCalibration> calibrateCamera(const std::vector<cv::Mat>& images,
                                          const ChessboardSpec& board, int plane_image,
                                          const std::vector<std::string>& names) {
  if (images.empty()) return fail("no pictures to calibrate from");
  if (plane_image < -1 || plane_image >= static_cast<int>(images.size()))
    return fail("the plane picture's index " + std::to_string(plane_image) + " is not among the " +
                std::to_string(images.size()) + " pictures");
  if (board.inner_corners.width < 3 || board.inner_corners.height < 3 || !(board.square_m > 0))
    return fail("the chessboard needs at least 3 x 3 inner corners and a square size > 0");
  CameraCalibration out;
  Found found = findBoards(images, board, plane_image, names, out);
  if (plane_image >= 0 && found.plane_slot < 0)
    return fail("the chessboard was not found in the plane picture (" +
                (plane_image < static_cast<int>(names.size())
                     ? names[plane_image]
                     : "picture " + std::to_string(plane_image)) +
                "): without it the collision plane's distance is unknown; show the whole board "
                "lying in the collision plane");
  if (static_cast<int>(found.corners.size()) < kMinCalibrationViews)
    return fail("the chessboard was found in " + std::to_string(found.corners.size()) + " of " +
                std::to_string(images.size()) + " pictures; at least " +
                std::to_string(kMinCalibrationViews) +
                " in varied poses (tilted, near the corners) are needed, 10 or more for a good "
                "fit");
  out.image_size = images.front().size();
  LensFit lens;
  lens.object.assign(found.corners.size(), boardPoints(board));
  if (auto st = lens.fit(found, out.image_size, 0); !st) return st.error();
  // A board found with a corner on the wrong feature fits several times worse
  // than the rest: leave it out and fit again.
  if (dropMisfits(found, lens.per_view, names, out.notes) > 0) {
    if (static_cast<int>(found.corners.size()) < kMinCalibrationViews)
      return fail("only " + std::to_string(found.corners.size()) +
                  " pictures fit the lens; at least " + std::to_string(kMinCalibrationViews) +
                  " are needed (see the pictures left out)");
    if (auto st = lens.fit(found, out.image_size, 0); !st) return st.error();
  }
  if (auto st = holdUnmeasuredK2(lens, found, out); !st) return st.error();
  fillLens(lens, found, images.size(), out);
  if (found.plane_slot >= 0) fillPlane(lens, found, board, out);
  return out;
}

}  // namespace collide::vision
