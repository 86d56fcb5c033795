#include "vision/render_wall.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace collide::vision {

namespace {

// Share of pixel (u, v)'s unit square on the plate's side of the line at
// signed distance d (> 0: off the plate) for a line with unit normal n: the
// area of a square cut by a line, exact for any angle (the clipped square is
// the difference of two ramps of width |n_u| + |n_v|).
double coverage(double d, const Eigen::Vector2d& n) {
  const double a = std::abs(n.x()), b = std::abs(n.y());
  const double lo = std::min(a, b), hi = std::max(a, b);
  const double half = 0.5 * (a + b);
  const double s = -d;  // > 0: towards the plate
  if (s <= -half) return 0.0;
  if (s >= half) return 1.0;
  // Area of {x in [-1/2,1/2]^2 : n.x <= s}: piecewise quadratic/linear in s.
  const double x = s + half;  // 0 .. a + b
  if (lo < 1e-12) return std::clamp(x / hi, 0.0, 1.0);
  auto ramp2 = [](double t) { return t > 0 ? t * t : 0.0; };
  return (ramp2(x) - ramp2(x - lo) - ramp2(x - hi) + ramp2(x - lo - hi)) / (2 * lo * hi);
}

template <typename T>
void paint(cv::Mat& image, int max_value, const WallLine& wall, const WallLook& look,
           const WallBend& bend) {
  const Eigen::Vector2d along(-wall.normal.y(), wall.normal.x());
  std::mt19937_64 rng(look.noise_seed);
  std::normal_distribution<double> noise(0.0, look.noise_grey > 0 ? look.noise_grey : 1.0);
  const double level = look.level * max_value;
  for (int v = 0; v < image.rows; ++v) {
    T* row = image.ptr<T>(v);
    for (int u = 0; u < image.cols; ++u) {
      double d = wall.distancePx(u, v);
      if (!bend.offset_px.empty()) d -= bend.at((Eigen::Vector2d(u, v) - wall.point_px).dot(along));
      if (d > 1.0 || d < -look.thickness_px - 1.0) continue;
      // On the plate side of the face and in front of the band's back edge.
      const double c =
          coverage(d, wall.normal) * (1.0 - coverage(d + look.thickness_px, wall.normal));
      if (c <= 0) continue;
      const double plate = level + (look.noise_grey > 0 ? noise(rng) : 0.0);
      const double out = (1.0 - c) * row[u] + c * plate;
      row[u] = static_cast<T>(std::clamp(std::round(out), 0.0, double(max_value)));
    }
  }
}

}  // namespace

double WallBend::at(double s) const {
  if (offset_px.empty()) return 0.0;
  const double x = (s - first_px) / step_px;
  if (!(x > 0)) return offset_px.front();
  const auto i = static_cast<std::size_t>(x);
  if (i + 1 >= offset_px.size()) return offset_px.back();
  const double f = x - static_cast<double>(i);
  return (1 - f) * offset_px[i] + f * offset_px[i + 1];
}

void drawWall(cv::Mat& image, int max_value, const WallLine& wall, const WallLook& look,
              const WallBend& bend) {
  if (!(wall.normal.norm() > 0)) throw std::invalid_argument("drawWall: zero normal");
  WallLine unit = wall;
  unit.normal.normalize();
  if (image.type() == CV_8UC1)
    paint<std::uint8_t>(image, max_value, unit, look, bend);
  else if (image.type() == CV_16UC1)
    paint<std::uint16_t>(image, max_value, unit, look, bend);
  else
    throw std::invalid_argument("drawWall: image must be CV_8UC1 or CV_16UC1");
}

}  // namespace collide::vision
