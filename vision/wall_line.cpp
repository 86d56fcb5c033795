#include "vision/wall_line.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <vector>

namespace collide::vision {

namespace {

// Per pixel, the median of the picked frames' values, row by row on their
// own type (no conversion of whole frames); within `band` px of `line` only,
// when one is given (NaN elsewhere).
template <class T>
void medianRows(const std::vector<const cv::Mat*>& pick, const std::optional<WallLine>& line,
                double band, cv::Mat& out) {
  const std::size_t n = pick.size();
  std::vector<T> px(n);
  std::vector<const T*> rows(n);
  const Eigen::Vector2d nrm = line ? line->normal.normalized() : Eigen::Vector2d::UnitY();
  for (int v = 0; v < out.rows; ++v) {
    int u0 = 0, u1 = out.cols - 1;
    if (line) {
      // |(u - p.x) n.x + (v - p.y) n.y| <= band, solved for u on this row.
      const double rest = (v - line->point_px.y()) * nrm.y();
      if (std::abs(nrm.x()) < 1e-9) {
        if (std::abs(rest) > band) u1 = -1;
      } else {
        const double a = line->point_px.x() + (-band - rest) / nrm.x();
        const double b = line->point_px.x() + (band - rest) / nrm.x();
        u0 = std::max(u0, static_cast<int>(std::floor(std::min(a, b))));
        u1 = std::min(u1, static_cast<int>(std::ceil(std::max(a, b))));
      }
    }
    for (std::size_t i = 0; i < n; ++i) rows[i] = pick[i]->ptr<T>(v);
    float* o = out.ptr<float>(v);
    for (int u = u0; u <= u1; ++u) {
      for (std::size_t i = 0; i < n; ++i) px[i] = rows[i][u];
      std::nth_element(px.begin(), px.begin() + n / 2, px.end());
      o[u] = static_cast<float>(px[n / 2]);
    }
  }
}

// Per-pixel median of up to 15 good frames spread over the burst, as float
// (empty when there are none, or they differ in size or type); with a line,
// only within `band` px of it (the refinement looks no further).
cv::Mat medianImage(const Burst& burst, const std::optional<WallLine>& line = std::nullopt,
                    double band = 0) {
  std::vector<const cv::Mat*> frames;
  for (const Frame& f : burst.frames)
    if (f.good()) frames.push_back(&f.image);
  if (frames.empty()) return {};
  const std::size_t n = std::min<std::size_t>(15, frames.size());
  std::vector<const cv::Mat*> pick;
  for (std::size_t i = 0; i < n; ++i)
    pick.push_back(frames[i * (frames.size() - 1) / std::max<std::size_t>(1, n - 1)]);
  cv::Mat out(pick[0]->size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (const cv::Mat* m : pick)
    if (m->size() != out.size() || m->type() != pick[0]->type() || m->channels() != 1) return {};
  switch (pick[0]->depth()) {
    case CV_8U: medianRows<std::uint8_t>(pick, line, band, out); break;
    case CV_16U: medianRows<std::uint16_t>(pick, line, band, out); break;
    default: {
      std::vector<cv::Mat> converted(n);
      std::vector<const cv::Mat*> as_float;
      for (std::size_t i = 0; i < n; ++i) {
        pick[i]->convertTo(converted[i], CV_32F);
        as_float.push_back(&converted[i]);
      }
      medianRows<float>(as_float, line, band, out);
    }
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

// Total least squares line through points: their mean, the unit normal
// (smallest spread; sign as `orient`), the squared residuals' sum and the
// squared spread along the line.
struct Tls {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero(), normal = Eigen::Vector2d::UnitY();
  double ss = 0, spread = 0;
};
Tls fitTls(const std::vector<Eigen::Vector2d>& pts, const Eigen::Vector2d& orient) {
  Tls t;
  for (const auto& p : pts) t.mean += p;
  t.mean /= static_cast<double>(pts.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& p : pts) cov += (p - t.mean) * (p - t.mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
  t.normal = es.eigenvectors().col(0);  // smallest spread: the normal
  if (t.normal.dot(orient) < 0) t.normal = -t.normal;
  const Eigen::Vector2d along(-t.normal.y(), t.normal.x());
  for (const auto& p : pts) {
    const double d = (p - t.mean).dot(t.normal), a = (p - t.mean).dot(along);
    t.ss += d * d;
    t.spread += a * a;
  }
  return t;
}

// The line's angle and offset (along the normal, at the full fit's mean)
// refitted with each of kBlocks stretches of the edge left out in turn: their
// jackknife sigmas, which see residuals that are correlated along the edge
// over less than a stretch. Zero with too few points for the blocks.
struct BlockJackknife {
  double angle_sigma_rad = 0, offset_sigma_px = 0;
};
BlockJackknife blockJackknife(const std::vector<Eigen::Vector2d>& pts, const Tls& full) {
  constexpr int kBlocks = 10;
  BlockJackknife out;
  if (pts.size() < 5 * kBlocks) return out;
  const Eigen::Vector2d along(-full.normal.y(), full.normal.x());
  std::vector<std::pair<double, std::size_t>> order;
  for (std::size_t i = 0; i < pts.size(); ++i)
    order.emplace_back((pts[i] - full.mean).dot(along), i);
  std::sort(order.begin(), order.end());
  std::array<double, kBlocks> angle{}, offset{};
  double angle_mean = 0, offset_mean = 0;
  for (int b = 0; b < kBlocks; ++b) {
    const std::size_t lo = pts.size() * b / kBlocks, hi = pts.size() * (b + 1) / kBlocks;
    std::vector<Eigen::Vector2d> rest;
    for (std::size_t k = 0; k < order.size(); ++k)
      if (k < lo || k >= hi) rest.push_back(pts[order[k].second]);
    const Tls t = fitTls(rest, full.normal);
    angle[b] = std::atan2(full.normal.x() * t.normal.y() - full.normal.y() * t.normal.x(),
                          full.normal.dot(t.normal));
    // Where this line crosses the full fit's normal through its mean.
    offset[b] = (t.mean - full.mean).dot(t.normal) / std::max(1e-9, t.normal.dot(full.normal));
    angle_mean += angle[b] / kBlocks;
    offset_mean += offset[b] / kBlocks;
  }
  double va = 0, vo = 0;
  for (int b = 0; b < kBlocks; ++b) {
    va += (angle[b] - angle_mean) * (angle[b] - angle_mean);
    vo += (offset[b] - offset_mean) * (offset[b] - offset_mean);
  }
  const double f = (kBlocks - 1.0) / kBlocks;
  out.angle_sigma_rad = std::sqrt(f * va);
  out.offset_sigma_px = std::sqrt(f * vo);
  return out;
}

// Image pixels and ideal ones (the pinhole's, distortion removed: u = f x + cu
// for normalised ideal x); the same pixels without a camera or distortion.
class IdealPixels {
 public:
  explicit IdealPixels(const PinholeCamera* camera)
      : cam_(camera && camera->distorted() ? camera : nullptr) {}
  Eigen::Vector2d of(const Eigen::Vector2d& image_px) const {
    if (!cam_) return image_px;
    return cam_->focal_px * cam_->normalised(image_px.x(), image_px.y()) + principal();
  }
  Eigen::Vector2d image(const Eigen::Vector2d& ideal_px) const {
    if (!cam_) return ideal_px;
    return cam_->focal_px * cam_->distort((ideal_px - principal()) / cam_->focal_px) + principal();
  }
  // An image line (its point and direction there) in ideal pixels.
  WallLine line(const WallLine& image_line) const {
    if (!cam_) return image_line;
    const Eigen::Vector2d t(-image_line.normal.y(), image_line.normal.x());
    return fromPoints(of(image_line.point_px - t), of(image_line.point_px + t), image_line.normal);
  }
  // A straight line in ideal pixels as the image shows it at its point: the
  // point's image and the tangent of the (bent) image line there.
  WallLine imageLine(const Eigen::Vector2d& ideal_point,
                     const Eigen::Vector2d& ideal_normal) const {
    if (!cam_) return WallLine{ideal_point, ideal_normal};
    const Eigen::Vector2d t(-ideal_normal.y(), ideal_normal.x());
    WallLine l = fromPoints(image(ideal_point - t), image(ideal_point + t), ideal_normal);
    l.point_px = image(ideal_point);
    return l;
  }

 private:
  Eigen::Vector2d principal() const { return {cam_->principal_u_px, cam_->principal_v_px}; }
  static WallLine fromPoints(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                             const Eigen::Vector2d& orient) {
    Eigen::Vector2d n(-(b - a).y(), (b - a).x());
    n.normalize();
    if (n.dot(orient) < 0) n = -n;
    return WallLine{0.5 * (a + b), n};
  }
  const PinholeCamera* cam_;
};

}  // namespace

Result<WallLineFit> findWallLine(const Burst& burst, std::optional<WallLine> guess,
                                 std::optional<Eigen::Vector2d> sphere_px,
                                 const PinholeCamera* camera) {
  // With a guess, the median is needed only where the refinement's profiles
  // reach (8 px either side of a line that moves by a few px at most).
  const cv::Mat median = guess ? medianImage(burst, guess, 24.0) : medianImage(burst);
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
  // Through a lens the edge is fitted where a straight plate edge is a
  // straight line: in ideal (undistorted) pixels.
  const IdealPixels ideal(camera);
  WallLineFit fit;
  for (int round = 0; round < 3; ++round) {
    const WallLine ideal_line = ideal.line(line);
    std::vector<Eigen::Vector2d> pts = edgePoints(median, line);
    // Drop points far from the current line (the sphere's outline, clutter).
    std::vector<Eigen::Vector2d> kept;
    for (const auto& p : pts) {
      const Eigen::Vector2d q = ideal.of(p);
      if (std::abs(ideal_line.distancePx(q.x(), q.y())) < (round == 0 ? 3.0 : 1.0))
        kept.push_back(q);
    }
    if (kept.size() < 10)
      return fail("only " + std::to_string(kept.size()) +
                  " edge points along the wall line (10 needed): give the line with "
                  "--wall-line u1,v1,u2,v2");
    const Tls tls = fitTls(kept, ideal_line.normal);
    line = ideal.imageLine(tls.mean, tls.normal);
    const double m = static_cast<double>(kept.size());
    fit.residual_rms_px = std::sqrt(tls.ss / std::max(1.0, m - 2));
    fit.offset_sigma_px = fit.residual_rms_px / std::sqrt(m);
    fit.angle_sigma_rad = fit.residual_rms_px / std::sqrt(tls.spread);
    fit.points = static_cast<int>(kept.size());
    if (round < 2) continue;
    // Independent residuals' sigmas, or the blocks' jackknife where the
    // residuals wander along the edge together (a pixel-phase bias of the
    // crossings), whichever is larger: on the final points only.
    const BlockJackknife jk = blockJackknife(kept, tls);
    fit.offset_sigma_px = std::max(fit.offset_sigma_px, jk.offset_sigma_px);
    fit.angle_sigma_rad = std::max(fit.angle_sigma_rad, jk.angle_sigma_rad);
  }
  fit.line = line;
  return fit;
}

}  // namespace collide::vision
