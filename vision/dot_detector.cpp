#include "vision/dot_detector.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "vision/avx2_clones.hpp"
#include "vision/morphology.hpp"

namespace collide::vision {
namespace {

struct Run {
  int y, x0, x1, parent;
  bool edge;  // touches the edge of the analysed disc or of the frame
};

int findRoot(std::vector<Run>& runs, int i) {
  while (runs[i].parent != i) i = runs[i].parent = runs[runs[i].parent].parent;
  return i;
}

// ------------------------------------------------------ bare sphere near a dot

// One pixel of the bare sphere near a dot: its offset from the dot's box
// centre and its level.
struct BareSample {
  double dx, dy, level;
};
// B(dx, dy) = c0 + c1 dx + c2 dy + c3 dx^2 + c4 dx dy + c5 dy^2.
using Quadratic = Eigen::Matrix<double, 6, 1>;

struct FitScratch {
  std::vector<char> use;
  std::vector<double> res, absr;
};

// The least-squares quadratic through the samples in use (all when `use` is
// empty), from the moments sum dx^i dy^j (i + j <= 4) and sum level dx^i dy^j
// (i + j <= 2): 21 sums a sample instead of a 6 x 6 outer product.
bool solveQuadratic(const std::vector<BareSample>& s, const std::vector<char>& use,
                    Quadratic& coef) {
  double m[5][5] = {}, r[3][3] = {};
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (!use.empty() && !use[i]) continue;
    const double x = s[i].dx, y = s[i].dy, v = s[i].level;
    const double x2 = x * x, y2 = y * y, xy = x * y;
    m[0][0] += 1, m[1][0] += x, m[0][1] += y, m[2][0] += x2, m[1][1] += xy, m[0][2] += y2;
    m[3][0] += x2 * x, m[2][1] += x2 * y, m[1][2] += x * y2, m[0][3] += y2 * y;
    m[4][0] += x2 * x2, m[3][1] += x2 * xy, m[2][2] += x2 * y2, m[1][3] += xy * y2,
        m[0][4] += y2 * y2;
    r[0][0] += v, r[1][0] += v * x, r[0][1] += v * y, r[2][0] += v * x2, r[1][1] += v * xy,
        r[0][2] += v * y2;
  }
  // The basis's powers of (dx, dy).
  constexpr int px[6] = {0, 1, 0, 2, 1, 0}, py[6] = {0, 0, 1, 0, 1, 2};
  Eigen::Matrix<double, 6, 6> a;
  Quadratic rhs;
  for (int c = 0; c < 6; ++c) {
    rhs(c) = r[px[c]][py[c]];
    for (int d = 0; d < 6; ++d) a(c, d) = m[px[c] + px[d]][py[c] + py[d]];
  }
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(a);
  if (ldlt.info() != Eigen::Success) return false;
  coef = ldlt.solve(rhs);
  return true;
}

double quadraticAt(const Quadratic& c, double dx, double dy) {
  return c[0] + c[1] * dx + c[2] * dy + c[3] * dx * dx + c[4] * dx * dy + c[5] * dy * dy;
}

// The bare sphere's brightness around a dot: a quadratic fitted to the
// samples, refitted once without those that stray beyond 3.5 robust standard
// deviations (plus one grey level) of the first fit: a neighbouring dot, a
// glint. False (coef untouched or not finite) with fewer than 24 samples or a
// degenerate fit.
bool fitBareQuadratic(const std::vector<BareSample>& s, FitScratch& k, Quadratic& coef) {
  if (s.size() < 24) return false;
  k.use.clear();
  if (!solveQuadratic(s, k.use, coef)) return false;
  if (!coef.allFinite()) return false;
  constexpr double kCut = 3.5 * 1.4826;  // robust standard deviations
  const std::size_t n = s.size(), mid = n / 2;
  k.res.resize(n);
  k.absr.resize(n);
  double largest = 0;
  for (std::size_t i = 0; i < n; ++i) {
    k.res[i] = s[i].level - quadraticAt(coef, s[i].dx, s[i].dy);
    k.absr[i] = std::abs(k.res[i]);
    largest = std::max(largest, k.absr[i]);
  }
  // Nothing strays when the median is at least what would put the limit above
  // the largest residual; counting the residuals below that tells without
  // finding the median (a pass instead of a selection).
  const double enough = (largest - 1.0) / kCut * (1 + 1e-9) + 1e-12;
  if (std::count_if(k.absr.begin(), k.absr.end(), [&](double r) { return r < enough; }) <=
      static_cast<std::ptrdiff_t>(mid))
    return true;
  std::nth_element(k.absr.begin(), k.absr.begin() + mid, k.absr.end());
  const double limit = kCut * k.absr[mid] + 1.0;
  k.use.resize(n);
  bool dropped = false;
  for (std::size_t i = 0; i < n; ++i) {
    k.use[i] = std::abs(k.res[i]) <= limit;
    dropped |= !k.use[i];
  }
  if (!dropped) return true;  // the refit would be the same fit
  // A failed refit keeps the first fit.
  Quadratic refit;
  if (solveQuadratic(s, k.use, refit)) coef = refit;
  return coef.allFinite();
}

// mask[x] = 1 where row[x] lies below halfway from `bg` to shade[x], for x
// in [0, n): the one per-pixel pass over the disc, so it is built for AVX2 as
// well (four levels a compare) and the loader picks the build the processor
// runs (GCC/Clang target_clones). The compare is the same in either build.
#define COLLIDE_DARK_MASK(T)                                                                 \
  COLLIDE_AVX2_CLONES void darkMask(const T* __restrict row, const float* __restrict shade,  \
                                    double bg, double depth, unsigned char* __restrict mask, \
                                    int n) {                                                 \
    for (int x = 0; x < n; ++x) {                                                            \
      const double b = static_cast<double>(shade[x]);                                        \
      mask[x] = static_cast<double>(row[x]) < std::min(0.5 * (b + bg), b - depth);           \
    }                                                                                        \
  }
COLLIDE_DARK_MASK(std::uint8_t)
COLLIDE_DARK_MASK(std::uint16_t)
#undef COLLIDE_DARK_MASK

// The chord's pixels darker than halfway from the dark reference `bg` to the
// bare sphere's level (`level`, from column bx0 and row v0), and by more
// than `depth` below it (the noise's reach, BareLevel::noise), as runs along
// each row, joined into 8-connected groups (Run::parent, a union-find). Each
// row is first turned into a mask in one vectorised pass (darkMask), then the
// mask is scanned for runs.
template <class T>
std::vector<Run> darkRuns(const cv::Mat& img, const cv::Mat& level, double bg, double depth, int v0,
                          int bx0, const std::vector<int>& lo, const std::vector<int>& hi,
                          const std::vector<char>& clipped) {
  const int rows = static_cast<int>(lo.size());
  std::vector<Run> runs;
  std::vector<int> row_first(rows + 1, 0);
  std::vector<unsigned char> mask(static_cast<std::size_t>(img.cols) + 1);
  for (int iy = 0; iy < rows; ++iy) {
    const int y = v0 + iy, x_lo = lo[iy], x_hi = hi[iy];
    row_first[iy] = static_cast<int>(runs.size());
    if (x_lo > x_hi) continue;
    const T* row = img.ptr<T>(y);
    const float* shade = level.ptr<float>(iy);
    darkMask(row + x_lo, shade + (x_lo - bx0), bg, depth, mask.data() + x_lo, x_hi - x_lo + 1);
    mask[x_hi + 1] = 0;  // a stop for the scan
    for (int x = x_lo; x <= x_hi;) {
      // Bare pixels, eight at a time while they last, then one at a time.
      for (std::uint64_t eight = 0; x + 8 <= x_hi + 1; x += 8) {
        std::memcpy(&eight, mask.data() + x, 8);
        if (eight != 0) break;
      }
      while (x <= x_hi && !mask[x]) ++x;
      if (x > x_hi) break;
      const int x0 = x;
      while (mask[x]) ++x;
      const int self = static_cast<int>(runs.size());
      const bool edge = x0 == x_lo || x - 1 == x_hi || iy == 0 || iy == rows - 1 || clipped[iy];
      runs.push_back({y, x0, x - 1, self, edge});
      if (iy == 0) continue;
      for (int k = row_first[iy - 1]; k < row_first[iy]; ++k) {
        if (runs[k].x1 < x0 - 1) continue;
        if (runs[k].x0 > x) break;
        const int a = findRoot(runs, k), b = findRoot(runs, self);
        if (a != b) runs[std::max(a, b)].parent = std::min(a, b);
      }
    }
  }
  return runs;
}

// ------------------------------------------------------------- the stages

// The disc analysed for dots: the sphere's outline less a margin at the limb
// (where dots are foreshortened to slivers), as a chord per row clipped to
// the frame, and the square around it that the bare level covers.
struct Disc {
  double cu = 0, cv = 0, r = 0, rin = 0;
  double bg = 0;              // the dark reference the dots are measured against
  int v0 = 0, v1 = 0;         // its rows
  int bx0 = 0, bx1 = 0;       // the columns of the square around it
  std::vector<int> lo, hi;    // each row's chord, from row v0
  std::vector<char> clipped;  // the chord cut by the frame's edge
  int rows() const { return v1 - v0 + 1; }
};

// False when the sphere is too small or too dim for dots, or out of the frame.
bool analysedDisc(const cv::Mat& img, const SphereMeasurement& s, const DotSettings& set, Disc& d) {
  d.cu = s.circle.u, d.cv = s.circle.v, d.r = s.circle.radius;
  // The dark reference: the backdrop, or black for a silhouette on a bright
  // field (backlit: the sphere darker than its background; its dots darker
  // still).
  d.bg = s.rim_level > s.background ? s.background : 0.0;
  if (!(d.r > 3) || !(s.rim_level > d.bg)) return false;
  const double margin = set.rim_margin_px > 0 ? set.rim_margin_px : std::max(2.5, 0.03 * d.r + 1.5);
  d.rin = d.r - margin;
  if (!(d.rin > 2)) return false;
  d.v0 = std::max(0, static_cast<int>(std::ceil(d.cv - d.rin)));
  d.v1 = std::min(img.rows - 1, static_cast<int>(std::floor(d.cv + d.rin)));
  if (d.v0 > d.v1) return false;
  const int rows = d.rows();
  d.lo.resize(rows), d.hi.resize(rows), d.clipped.resize(rows);
  for (int y = d.v0; y <= d.v1; ++y) {
    const double dy = y - d.cv;
    const double h = std::sqrt(std::max(0.0, d.rin * d.rin - dy * dy));
    const int a = static_cast<int>(std::ceil(d.cu - h)), b = static_cast<int>(std::floor(d.cu + h));
    d.lo[y - d.v0] = std::max(0, a);
    d.hi[y - d.v0] = std::min(img.cols - 1, b);
    d.clipped[y - d.v0] = a < 0 || b > img.cols - 1 || y == 0 || y == img.rows - 1;
  }
  d.bx0 = std::max(0, static_cast<int>(std::floor(d.cu - d.rin)) - 3);
  d.bx1 = std::min(img.cols - 1, static_cast<int>(std::ceil(d.cu + d.rin)) + 3);
  return d.bx0 <= d.bx1;
}

// The bare level, and the noise's standard deviation about it (1.4826 MAD of
// closing - image over the disc's pixels, the dots a minority among them).
struct BareLevel {
  cv::Mat level;
  double noise = 0;
};

// The bare sphere's brightness B around every pixel of the disc's square: a
// grey-level closing (dilation then erosion) with a square wider than a dot
// (separable: fast) fills the dark dots in from their surroundings and keeps
// the shading, however one-sided the lamp or wherever a highlight is; a
// light blur takes the noise's upward bias off. A dot is then dark RELATIVE
// to its own surroundings, so dots on the shaded side (barely above the
// backdrop) are found as well as on the lit side.
template <class T>
BareLevel bareLevel(const cv::Mat& img, const Disc& d) {
  // The closing runs on the frame's own integers (max and min commute with
  // the conversion, so it equals the closing of the converted levels); the
  // blur on floats.
  const cv::Mat roi = img(cv::Range(d.v0, d.v1 + 1), cv::Range(d.bx0, d.bx1 + 1));
  cv::Mat closed, level;
  closeWithSquare(roi, std::max(2, static_cast<int>(std::lround(0.17 * d.r))), closed);
  closed.convertTo(level, CV_32F);
  cv::GaussianBlur(level, level, cv::Size(5, 5), 1.0, 1.0, cv::BORDER_REPLICATE);
  // The closing rides on the noise's maxima: take the noise's spread in
  // the sphere off (the median of closing - image over bare pixels).
  std::vector<float> diff;
  for (int y = 0; y < roi.rows; y += 3) {
    const T* a = roi.ptr<T>(y);
    const float* b = level.ptr<float>(y);
    for (int x = std::max(0, d.lo[y] - d.bx0); x <= std::min(roi.cols - 1, d.hi[y] - d.bx0); x += 3)
      diff.push_back(b[x] - static_cast<float>(a[x]));
  }
  BareLevel out;
  if (diff.size() >= 10) {
    const auto mid = diff.begin() + static_cast<std::ptrdiff_t>(diff.size() / 2);
    std::nth_element(diff.begin(), mid, diff.end());
    const float median = *mid;
    level -= std::max(0.0f, median);
    for (float& x : diff) x = std::abs(x - median);
    std::nth_element(diff.begin(), mid, diff.end());
    out.noise = 1.4826 * *mid;
  }
  out.level = level;
  return out;
}

// An 8-connected group of dark runs: a dot candidate.
struct Group {
  int x0, x1, y0, y1;
  bool edge;  // touches the disc's edge or the frame's
  int pixels;
};

// The runs' groups (from their union-find roots); group_of[i]: run i's group.
std::vector<Group> groupRuns(std::vector<Run>& runs, std::vector<int>& group_of) {
  group_of.assign(runs.size(), -1);
  std::vector<Group> groups;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const int root = findRoot(runs, static_cast<int>(i));
    if (group_of[root] < 0) {
      group_of[root] = static_cast<int>(groups.size());
      groups.push_back({runs[i].x0, runs[i].x1, runs[i].y, runs[i].y, false, 0});
    }
    const int g = group_of[root];
    group_of[i] = g;
    Group& gr = groups[g];
    gr.x0 = std::min(gr.x0, runs[i].x0), gr.x1 = std::max(gr.x1, runs[i].x1);
    gr.y1 = std::max(gr.y1, runs[i].y);
    gr.edge |= runs[i].edge;
    gr.pixels += runs[i].x1 - runs[i].x0 + 1;
  }
  return groups;
}

// Which group owns each dark pixel of the disc's square (-1: none), for the
// rings around each dot. The cells are a buffer each thread keeps from call
// to call, all -1 between calls: the runs are written in, and taken out
// again when the map goes, rather than the whole square filled every call.
class OwnerMap {
 public:
  OwnerMap(const Disc& d, const std::vector<Run>& runs, const std::vector<int>& group_of)
      : runs_(runs), v0_(d.v0), x0_(d.bx0), width_(d.bx1 - d.bx0 + 1) {
    thread_local std::vector<std::int32_t> cells;
    if (cells.size() < static_cast<std::size_t>(width_) * d.rows())
      cells.resize(static_cast<std::size_t>(width_) * d.rows(), -1);
    cells_ = cells.data();
    for (std::size_t i = 0; i < runs.size(); ++i)
      std::fill(row(runs[i].y) + runs[i].x0, row(runs[i].y) + runs[i].x1 + 1, group_of[i]);
  }
  ~OwnerMap() {
    for (const Run& run : runs_) std::fill(row(run.y) + run.x0, row(run.y) + run.x1 + 1, -1);
  }
  OwnerMap(const OwnerMap&) = delete;
  OwnerMap& operator=(const OwnerMap&) = delete;
  /// Row y's cells, indexed by the frame's column.
  const std::int32_t* row(int y) const {
    return cells_ + static_cast<std::size_t>(y - v0_) * width_ - x0_;
  }

 private:
  std::int32_t* row(int y) { return cells_ + static_cast<std::size_t>(y - v0_) * width_ - x0_; }
  const std::vector<Run>& runs_;
  int v0_, x0_, width_;
  std::int32_t* cells_ = nullptr;
};

// The paint's own level (a little above the background in the simulator,
// often more on real spheres), from the dots' darkest pixels. The coverage
// is then (B - I) / (B - paint), so the areas (and the dots' size used for
// the limb correction) come out right. Under uneven light the paint is lit
// as the sphere around it is: its level P = p0 + p1 B is fitted to those
// pixels (p1 = 0 for a paint of one level, p0 = 0 for a paint lit like the
// sphere).
struct PaintLevel {
  double p0 = 0, p1 = 0;
  double at(double bare) const { return p0 + p1 * bare; }
};

template <class T>
PaintLevel paintLevel(const cv::Mat& img, const cv::Mat& level, const Disc& d,
                      const std::vector<Run>& runs) {
  PaintLevel p{d.bg, 0.0};
  double n = 0, sb = 0, sbb = 0, si = 0, sbi = 0;
  std::vector<double> core;
  for (const Run& run : runs) {
    const T* row = img.ptr<T>(run.y);
    const float* shade = level.ptr<float>(run.y - d.v0) - d.bx0;
    for (int x = run.x0; x <= run.x1; ++x) {
      const double b = shade[x], i = row[x];
      if (!(i - d.bg < 0.25 * (b - d.bg))) continue;
      n += 1, sb += b, sbb += b * b, si += i, sbi += b * i;
      core.push_back(i);
    }
  }
  if (core.size() < 5) return p;
  std::nth_element(core.begin(), core.begin() + core.size() / 2, core.end());
  p.p0 = core[core.size() / 2];
  const double var_b = sbb / n - (sb / n) * (sb / n);
  const double mean_b = sb / n;
  if (n >= 20 && var_b > 1e-4 * mean_b * mean_b) {
    p.p1 = std::clamp((sbi / n - mean_b * si / n) / var_b, 0.0, 0.5);
    p.p0 = si / n - p.p1 * mean_b;
  }
  return p;
}

// What measuring one dot needs, shared by all of a frame's dots.
struct DotScratch {
  std::vector<BareSample> bare;
  FitScratch fit;
};

// Dot candidate g's centre and area: each pixel weighted by its coverage
// (B - I) / (B - P), with B under the dot a quadratic in (x, y) fitted to the
// bare sphere in a frame around it (smooth and unbiased, where the closing
// is only good enough to find dots), refitted once without the pixels that
// stray (a neighbouring dot, a glint). None for an area below a pixel or
// above a quarter of the disc.
template <class T>
std::optional<Dot> measureDot(const cv::Mat& img, const cv::Mat& level, const Disc& d,
                              const OwnerMap& owner, const PaintLevel& paint, int g,
                              const Group& gr, DotScratch& k) {
  const int gap = 2, ring = std::max(3, static_cast<int>(std::lround(0.06 * d.r)));
  const double mx = 0.5 * (gr.x0 + gr.x1), my = 0.5 * (gr.y0 + gr.y1);
  Quadratic coef = Quadratic::Zero();
  k.bare.clear();
  for (int y = std::max(d.v0, gr.y0 - gap - ring); y <= std::min(d.v1, gr.y1 + gap + ring); ++y) {
    const int iy = y - d.v0;
    const T* row = img.ptr<T>(y);
    const std::int32_t* o = owner.row(y);
    for (int x = std::max(d.lo[iy], gr.x0 - gap - ring);
         x <= std::min(d.hi[iy], gr.x1 + gap + ring); ++x) {
      if (x >= gr.x0 - gap && x <= gr.x1 + gap && y >= gr.y0 - gap && y <= gr.y1 + gap) continue;
      if (o[x] >= 0) continue;
      k.bare.push_back({x - mx, y - my, static_cast<double>(row[x])});
    }
  }
  const bool local = fitBareQuadratic(k.bare, k.fit, coef);
  const auto bare = [&](int x, int y) {
    return local ? quadraticAt(coef, x - mx, y - my)
                 : static_cast<double>(level.at<float>(y - d.v0, x - d.bx0));
  };
  double sw = 0, su = 0, sv = 0;
  for (int y = std::max(d.v0, gr.y0 - 2); y <= std::min(d.v1, gr.y1 + 2); ++y) {
    const int iy = y - d.v0;
    const T* row = img.ptr<T>(y);
    const std::int32_t* o = owner.row(y);
    for (int x = std::max(d.lo[iy], gr.x0 - 2); x <= std::min(d.hi[iy], gr.x1 + 2); ++x) {
      if (o[x] >= 0 && o[x] != g) continue;
      const double b = bare(x, y);
      const double w = (b - row[x]) / std::max(1e-6 * (b + 1), b - paint.at(b));
      sw += w, su += w * x, sv += w * y;
    }
  }
  if (!(sw >= 1.0) || sw > 0.25 * d.r * d.r) return std::nullopt;
  Dot dot;
  dot.u_px = su / sw;
  dot.v_px = sv / sw;
  dot.area_px2 = sw;
  return dot;
}

// The dots' size, given or from their areas (face-on area pi (R sin
// alpha)^2; a dot seen at polar angle theta covers that times cos(theta)),
// each dot lifted onto the sphere with it, and those left out that lie too
// near the limb or have the wrong area for a dot at their place (a fragment
// split by noise, a speck, two dots run together).
void sizeAndScreen(const Disc& d, const DotSettings& set, DotFrame& out) {
  std::vector<double> sin2;
  for (Dot& dot : out.dots) {
    dot.on_sphere = liftToSphere(dot.u_px, dot.v_px, d.cu, d.cv, d.r);
    if (dot.on_sphere.z() > 0.4)
      sin2.push_back(dot.area_px2 / (std::numbers::pi * d.r * d.r * dot.on_sphere.z()));
  }
  double alpha = set.angular_radius_rad;
  if (!(alpha > 0) && !sin2.empty()) {
    std::nth_element(sin2.begin(), sin2.begin() + sin2.size() / 2, sin2.end());
    alpha = std::asin(std::sqrt(std::clamp(sin2[sin2.size() / 2], 0.0, 0.25)));
  }
  out.angular_radius_rad = alpha > 0 ? alpha : 0.0;
  out.dot_area_px2 = std::numbers::pi * std::pow(d.r * std::sin(out.angular_radius_rad), 2);
  const double cos_max = std::cos(set.max_polar_deg * std::numbers::pi / 180.0);
  std::vector<Dot> kept;
  for (Dot& dot : out.dots) {
    dot.on_sphere = liftToSphere(dot.u_px, dot.v_px, d.cu, d.cv, d.r, out.angular_radius_rad);
    const double expected = out.dot_area_px2 * dot.on_sphere.z();
    const bool wrong_area =
        out.dot_area_px2 > 0 && (dot.area_px2 < 0.4 * expected || dot.area_px2 > 2.5 * expected);
    if (dot.on_sphere.z() < cos_max || wrong_area) {
      ++out.rejected;
      continue;
    }
    kept.push_back(dot);
  }
  out.dots = std::move(kept);
}

template <class T>
DotFrame findDotsTyped(const cv::Mat& img, const SphereMeasurement& s, const DotSettings& set) {
  DotFrame out;
  Disc d;
  if (!analysedDisc(img, s, set, d)) return out;
  const BareLevel bare = bareLevel<T>(img, d);
  const cv::Mat& level = bare.level;
  // A pixel is a dot candidate below halfway from the dark reference to B,
  // and more than kNoiseDepth noise sigmas below B: on a shaded side, where
  // halfway is only a few grey levels down, noise alone would otherwise make
  // specks by the dozen, and their areas would then set the dots' size.
  constexpr double kNoiseDepth = 3.0;  // a noise pixel's chance: 1.3e-3
  std::vector<Run> runs =
      darkRuns<T>(img, level, d.bg, kNoiseDepth * bare.noise, d.v0, d.bx0, d.lo, d.hi, d.clipped);
  if (runs.empty()) return out;
  std::vector<int> group_of;
  const std::vector<Group> groups = groupRuns(runs, group_of);
  const OwnerMap owner(d, runs, group_of);
  const PaintLevel paint = paintLevel<T>(img, level, d, runs);
  DotScratch scratch;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    std::optional<Dot> dot;
    if (!groups[g].edge)
      dot = measureDot<T>(img, level, d, owner, paint, static_cast<int>(g), groups[g], scratch);
    if (dot)
      out.dots.push_back(*dot);
    else
      ++out.rejected;
  }
  sizeAndScreen(d, set, out);
  return out;
}

}  // namespace

Vec3 liftToSphere(double u, double v, double cu, double cv, double r, double alpha_rad) {
  const double reff = r * std::cos(alpha_rad);
  double x = (u - cu) / reff, y = -(v - cv) / reff;
  const double rho2 = x * x + y * y;
  if (rho2 > 1.0) {
    const double k = 1.0 / std::sqrt(rho2);
    x *= k, y *= k;
    return Vec3(x, y, 0.0);
  }
  return Vec3(x, y, std::sqrt(1.0 - rho2));
}

DotFrame findDots(const cv::Mat& image, const SphereMeasurement& sphere, int /*max_value*/,
                  const DotSettings& settings) {
  if (image.empty() || image.channels() != 1) return {};
  if (image.depth() == CV_8U) return findDotsTyped<std::uint8_t>(image, sphere, settings);
  if (image.depth() == CV_16U) return findDotsTyped<std::uint16_t>(image, sphere, settings);
  return {};
}

}  // namespace collide::vision
