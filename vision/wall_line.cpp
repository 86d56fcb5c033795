#include "vision/wall_line.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace collide::vision {

namespace {

// Per-pixel median of up to 15 good frames spread over the burst, as float.
cv::Mat medianImage(const Burst& burst) {
  std::vector<const cv::Mat*> frames;
  for (const Frame& f : burst.frames)
    if (f.good()) frames.push_back(&f.image);
  if (frames.empty()) return {};
  const std::size_t n = std::min<std::size_t>(15, frames.size());
  std::vector<cv::Mat> pick;
  for (std::size_t i = 0; i < n; ++i) {
    cv::Mat f;
    frames[i * (frames.size() - 1) / std::max<std::size_t>(1, n - 1)]->convertTo(f, CV_32F);
    pick.push_back(f);
  }
  cv::Mat out(pick[0].size(), CV_32F);
  std::vector<float> px(n);
  for (int v = 0; v < out.rows; ++v)
    for (int u = 0; u < out.cols; ++u) {
      for (std::size_t i = 0; i < n; ++i) px[i] = pick[i].at<float>(v, u);
      std::nth_element(px.begin(), px.begin() + n / 2, px.end());
      out.at<float>(v, u) = px[n / 2];
    }
  return out;
}

// The strongest straight edge and the strong edges parallel to it (a plate
// shows its face and its back), strongest first.
std::vector<WallLine> houghLines(const cv::Mat& median) {
  cv::Mat img8, edges;
  cv::normalize(median, img8, 0, 255, cv::NORM_MINMAX, CV_8U);
  cv::Canny(img8, edges, 20, 60);
  std::vector<cv::Vec2f> lines;
  cv::HoughLines(edges, lines, 1, CV_PI / 720, std::max(30, median.cols / 8));
  std::vector<WallLine> out;
  for (std::size_t i = 0; i < std::min<std::size_t>(lines.size(), 30); ++i) {
    if (std::abs(lines[i][1] - lines[0][1]) > CV_PI / 90) continue;
    WallLine l;
    l.normal = {std::cos(lines[i][1]), std::sin(lines[i][1])};
    l.point_px = lines[i][0] * l.normal;
    out.push_back(l);
  }
  return out;
}

float bilinear(const cv::Mat& img, double u, double v) {
  const int u0 = static_cast<int>(std::floor(u)), v0 = static_cast<int>(std::floor(v));
  if (u0 < 0 || v0 < 0 || u0 + 1 >= img.cols || v0 + 1 >= img.rows) return NAN;
  const double a = u - u0, b = v - v0;
  return static_cast<float>(
      (1 - a) * (1 - b) * img.at<float>(v0, u0) + a * (1 - b) * img.at<float>(v0, u0 + 1) +
      (1 - a) * b * img.at<float>(v0 + 1, u0) + a * b * img.at<float>(v0 + 1, u0 + 1));
}

// Edge points across the line every 2 px along it: where the profile crosses
// halfway between its two sides' levels, interpolated linearly.
std::vector<Eigen::Vector2d> edgePoints(const cv::Mat& img, const WallLine& l) {
  const Eigen::Vector2d n = l.normal.normalized(), t(-n.y(), n.x());
  const double reach = std::hypot(img.cols, img.rows);
  std::vector<Eigen::Vector2d> out;
  constexpr int kHalf = 8;
  for (double s = -reach; s <= reach; s += 2.0) {
    const Eigen::Vector2d c = l.point_px + s * t;
    float prof[2 * kHalf * 4 + 1];
    bool ok = true;
    for (int i = 0; i <= 2 * kHalf * 4; ++i) {
      const Eigen::Vector2d p = c + (i / 4.0 - kHalf) * n;
      prof[i] = bilinear(img, p.x(), p.y());
      ok = ok && std::isfinite(prof[i]);
    }
    if (!ok) continue;
    double lo = 0, hi = 0;
    for (int i = 0; i < 12; ++i) lo += prof[i] / 12.0;
    for (int i = 2 * kHalf * 4 - 11; i <= 2 * kHalf * 4; ++i) hi += prof[i] / 12.0;
    if (std::abs(hi - lo) < 3.0) continue;  // no edge here (the sphere, or nothing)
    const double half = 0.5 * (lo + hi);
    int crossings = 0;
    double where = 0;
    for (int i = 0; i < 2 * kHalf * 4; ++i)
      if ((prof[i] - half) * (prof[i + 1] - half) <= 0 && prof[i] != prof[i + 1]) {
        ++crossings;
        where = i + (half - prof[i]) / (prof[i + 1] - prof[i]);
      }
    if (crossings != 1) continue;  // noise or a second edge: not a clean step
    out.push_back(c + (where / 4.0 - kHalf) * n);
  }
  return out;
}

}  // namespace

Result<WallLineFit> findWallLine(const Burst& burst, std::optional<WallLine> guess,
                                 std::optional<Eigen::Vector2d> sphere_px) {
  const cv::Mat median = medianImage(burst);
  if (median.empty()) return fail("no good frames to find the wall in");
  if (!guess) {
    // Of the candidate edges with enough edge points under them, the one
    // nearest the sphere (or the strongest).
    double best = std::numeric_limits<double>::infinity();
    for (const WallLine& l : houghLines(median)) {
      int near = 0;
      for (const auto& p : edgePoints(median, l))
        near += std::abs(l.distancePx(p.x(), p.y())) < 3.0;
      if (near < 10) continue;
      const double d = sphere_px ? std::abs(l.distancePx(sphere_px->x(), sphere_px->y())) : 0.0;
      if (d < best) {
        best = d;
        guess = l;
      }
    }
  }
  if (!guess)
    return fail("no straight edge found for the wall: give its line (--wall-line u1,v1,u2,v2)");
  WallLine line = *guess;
  line.normal.normalize();
  WallLineFit fit;
  for (int round = 0; round < 3; ++round) {
    std::vector<Eigen::Vector2d> pts = edgePoints(median, line);
    // Drop points far from the current line (the sphere's outline, clutter).
    std::vector<Eigen::Vector2d> kept;
    for (const auto& p : pts)
      if (std::abs(line.distancePx(p.x(), p.y())) < (round == 0 ? 3.0 : 1.0)) kept.push_back(p);
    if (kept.size() < 10)
      return fail("only " + std::to_string(kept.size()) +
                  " edge points along the wall line (10 needed): give the line with "
                  "--wall-line u1,v1,u2,v2");
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : kept) mean += p;
    mean /= kept.size();
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& p : kept) cov += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
    Eigen::Vector2d n = es.eigenvectors().col(0);  // smallest spread: the normal
    if (n.dot(line.normal) < 0) n = -n;
    line.point_px = mean;
    line.normal = n;
    double ss = 0, spread = 0;
    for (const auto& p : kept) {
      const double d = (p - mean).dot(n);
      ss += d * d;
      const double along = (p - mean).dot(Eigen::Vector2d(-n.y(), n.x()));
      spread += along * along;
    }
    const double m = static_cast<double>(kept.size());
    fit.residual_rms_px = std::sqrt(ss / std::max(1.0, m - 2));
    fit.offset_sigma_px = fit.residual_rms_px / std::sqrt(m);
    fit.angle_sigma_rad = fit.residual_rms_px / std::sqrt(spread);
    fit.points = static_cast<int>(kept.size());
  }
  fit.line = line;
  return fit;
}

}  // namespace collide::vision
