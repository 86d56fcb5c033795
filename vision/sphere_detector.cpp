#include "vision/sphere_detector.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "vision/avx2_clones.hpp"
#include "vision/kth_smallest.hpp"
#include "vision/silhouette_fit.hpp"

namespace collide::vision {
namespace {

// ---------------------------------------------------------------- circle fit

// Four doubles as one value (GCC/Clang vector extension): AVX2 takes them in
// one instruction, the baseline build in two.
using Lanes = double __attribute__((vector_size(4 * sizeof(double))));
using LaneMask = std::int64_t __attribute__((vector_size(4 * sizeof(double))));
// The same, read from a double array at any double's alignment.
using LanesAt =
    double __attribute__((vector_size(4 * sizeof(double)), aligned(alignof(double)), may_alias));
// (Macros, not functions: a function taking or returning Lanes would have a
// different calling convention in each build.)
#define COLLIDE_LOAD_LANES(p) (static_cast<Lanes>(*reinterpret_cast<const LanesAt*>(p)))
#define COLLIDE_TOTAL(a) (((a)[0] + (a)[1]) + ((a)[2] + (a)[3]))
// Eight floats as one value (one AVX2 instruction, two in the baseline
// build), for the per-profile loops that single precision serves.
using FLanes = float __attribute__((vector_size(8 * sizeof(float))));
using FLaneMask = std::int32_t __attribute__((vector_size(8 * sizeof(float))));
using FLanesAt =
    float __attribute__((vector_size(8 * sizeof(float)), aligned(alignof(float)), may_alias));
#define COLLIDE_LOAD_FLANES(p) (static_cast<FLanes>(*reinterpret_cast<const FLanesAt*>(p)))

struct Circle {
  double u = 0, v = 0, r = 0;
};

// The edge points as arrays, with a weight of 1 for each point in use and 0
// for one left out: the fits' loops over them have no branches.
struct PointArrays {
  // Padded to a whole number of kLanes with points of no weight far from any
  // circle (so the lanes of the last block need no test).
  static constexpr std::size_t kLanes = 4;
  std::vector<double> u, v, w;
  std::size_t n = 0;
  explicit PointArrays(const std::vector<CirclePoint>& p) : n(p.size()) {
    const std::size_t padded = (n + kLanes - 1) / kLanes * kLanes;
    u.assign(padded, 1e9), v.assign(padded, 1e9), w.assign(padded, 0.0);
    for (std::size_t i = 0; i < n; ++i) u[i] = p[i].u, v[i] = p[i].v, w[i] = 1.0;
  }
  std::size_t size() const { return n; }
};
static_assert(sizeof(Lanes) == PointArrays::kLanes * sizeof(double));

// Kasa's algebraic fit: minimises sum (x^2 + y^2 + D x + E y + F)^2, in
// coordinates centred on the points' mean so the normal equations stay well
// conditioned. Good to a fraction of the noise for full circles, biased low in
// radius for short arcs; only the starting point of the geometric fit.
bool kasaFit(const PointArrays& p, Circle& out) {
  double mu = 0, mv = 0, n = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    mu += p.w[i] * p.u[i], mv += p.w[i] * p.v[i], n += p.w[i];
  if (n < 3) return false;
  mu /= n;
  mv /= n;
  double sxx = 0, sxy = 0, syy = 0, sx = 0, sy = 0, bx = 0, by = 0, b1 = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double w = p.w[i], x = p.u[i] - mu, y = p.v[i] - mv;
    const double z = -(x * x + y * y);
    sxx += w * x * x, sxy += w * x * y, syy += w * y * y, sx += w * x, sy += w * y;
    bx += w * x * z, by += w * y * z, b1 += w * z;
  }
  Eigen::Matrix3d a;
  a << sxx, sxy, sx, sxy, syy, sy, sx, sy, n;
  const Eigen::Vector3d b(bx, by, b1);
  Eigen::FullPivLU<Eigen::Matrix3d> lu(a);
  if (lu.rank() < 3) return false;
  const Eigen::Vector3d s = lu.solve(b);
  const double cu = -0.5 * s[0], cv = -0.5 * s[1];
  const double r2 = cu * cu + cv * cv - s[2];
  if (!(r2 > 0) || !std::isfinite(r2)) return false;
  out = {cu + mu, cv + mv, std::sqrt(r2)};
  return true;
}

// The Gauss-Newton sums of the geometric fit about circle c: J_i = -(dx/d,
// dy/d, 1) and the residual d - r of each point, weighted. A point at the
// centre (d = 0) has no direction and is left out. The sums run in four lanes
// (point i in lane i % 4), added up in a fixed order at the end: the compiler
// may then vectorise the loop (the square roots and divisions four at a time
// with AVX2) without reordering any sum, so every build gives the same circle.
struct GaussNewtonSums {
  double sxx = 0, sxy = 0, syy = 0, sx = 0, sy = 0, n = 0, rx = 0, ry = 0, r1 = 0;
};
COLLIDE_INLINE_KERNEL GaussNewtonSums gaussNewtonSums(const double* __restrict pu,
                                                      const double* __restrict pv,
                                                      const double* __restrict pw,
                                                      std::size_t n_padded, double cu, double cv,
                                                      double cr) {
  Lanes sxx{}, sxy{}, syy{}, sx{}, sy{}, sn{}, rx{}, ry{}, r1{};
  const Lanes one = Lanes{} + 1.0;
  for (std::size_t i = 0; i < n_padded; i += PointArrays::kLanes) {
    const Lanes dx = COLLIDE_LOAD_LANES(pu + i) - cu, dy = COLLIDE_LOAD_LANES(pv + i) - cv;
    Lanes d = dx * dx + dy * dy;
    for (std::size_t l = 0; l < PointArrays::kLanes; ++l) d[l] = std::sqrt(d[l]);
    const LaneMask away = d > 0;  // all bits set where d > 0
    const Lanes w = (Lanes)((LaneMask)COLLIDE_LOAD_LANES(pw + i) & away);
    const Lanes inv = one / (Lanes)(((LaneMask)d & away) | ((LaneMask)one & ~away));
    const Lanes ex = dx * inv, ey = dy * inv, r = d - cr;
    const Lanes wex = w * ex, wey = w * ey;
    sxx += wex * ex, sxy += wex * ey, syy += wey * ey;
    sx += wex, sy += wey, sn += w;
    rx += wex * r, ry += wey * r, r1 += w * r;
  }
  return {COLLIDE_TOTAL(sxx), COLLIDE_TOTAL(sxy), COLLIDE_TOTAL(syy),
          COLLIDE_TOTAL(sx),  COLLIDE_TOTAL(sy),  COLLIDE_TOTAL(sn),
          COLLIDE_TOTAL(rx),  COLLIDE_TOTAL(ry),  COLLIDE_TOTAL(r1)};
}

// Gauss-Newton on the geometric distances; returns false if it diverges.
// With `hold_radius` only the centre moves (c.r stays as given).
COLLIDE_AVX2_CLONES bool geometricFit(const PointArrays& p, Circle& c, Eigen::Matrix3d& jtj_out,
                                      bool hold_radius) {
  for (int it = 0; it < 25; ++it) {
    const GaussNewtonSums z =
        gaussNewtonSums(p.u.data(), p.v.data(), p.w.data(), p.u.size(), c.u, c.v, c.r);
    Eigen::Matrix3d jtj;
    jtj << z.sxx, z.sxy, z.sx, z.sxy, z.syy, z.sy, z.sx, z.sy, z.n;
    const Eigen::Vector3d jtr(-z.rx, -z.ry, -z.r1);
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    if (hold_radius)
      step.head<2>() = jtj.topLeftCorner<2, 2>().ldlt().solve(-jtr.head<2>());
    else
      step = jtj.ldlt().solve(-jtr);
    if (!step.allFinite()) return false;
    c.u += step[0];
    c.v += step[1];
    c.r += step[2];
    jtj_out = jtj;
    if (!(c.r > 0)) return false;
    if (step.cwiseAbs().maxCoeff() < 1e-6) break;
  }
  return std::isfinite(c.u) && std::isfinite(c.v) && std::isfinite(c.r);
}

// ------------------------------------------------------------------ levels

struct Levels {
  double bg = 0, sigma = 0, bright = 0, threshold = 0;
  double low = 0;  // where a pixel leaves the background (noise), for blob extents
  double saturated_fraction = 0;
};

// Grid samples of the frame: every `step`-th pixel of every `step`-th row,
// starting at step/2.
struct Grid {
  int w = 0, h = 0, step = 1, off = 0;
  std::vector<std::uint16_t> v;
  std::uint16_t at(int x, int y) const { return v[static_cast<std::size_t>(y) * w + x]; }
};

template <class T>
Grid sampleGrid(const cv::Mat& img, int step) {
  Grid g;
  g.step = step;
  g.off = step / 2;
  g.w = (img.cols - g.off + step - 1) / step;
  g.h = (img.rows - g.off + step - 1) / step;
  g.v.resize(static_cast<std::size_t>(g.w) * g.h);
  // A frame just written by the camera is in main memory, not in a cache, and
  // each grid row reads every cache line of its image row: ask for the lines
  // of the rows kAhead grid rows on while this one is read, so the loads
  // overlap instead of waiting one row at a time.
  constexpr int kAhead = 4;
  const auto prefetchRow = [&](int gy) {
    if (gy >= g.h) return;
    const char* at = reinterpret_cast<const char*>(img.ptr<T>(gy * step + g.off));
    for (std::size_t b = 0; b < img.cols * sizeof(T); b += 64) __builtin_prefetch(at + b);
  };
  for (int gy = 0; gy < kAhead; ++gy) prefetchRow(gy);
  for (int gy = 0; gy < g.h; ++gy) {
    prefetchRow(gy + kAhead);
    const T* row = img.ptr<T>(gy * step + g.off) + g.off;
    std::uint16_t* out = g.v.data() + static_cast<std::size_t>(gy) * g.w;
    for (int gx = 0; gx < g.w; ++gx) out[gx] = row[gx * step];
  }
  return g;
}

// `clip_value`: the level at which a pixel is clipped (full scale; none for a
// backlit frame's negative, where full scale is the silhouette's black).
Levels measureLevels(const Grid& grid, int max_value, int clip_value) {
  // Histogram in at most 4096 bins.
  int shift = 0;
  while ((max_value >> shift) >= 4096) ++shift;
  const int bins = (max_value >> shift) + 1;
  std::vector<int> hist(bins, 0);
  // Every other grid sample of every other grid row: thousands of samples,
  // plenty for a median and a MAD.
  int n = 0;
  int at_max = 0;
  for (int y = 0; y < grid.h; y += 2)
    for (int x = (y / 2) % 2; x < grid.w; x += 2) {
      const int v = std::min<int>(grid.at(x, y), max_value);
      ++hist[v >> shift];
      at_max += v >= clip_value;
      ++n;
    }
  auto quantile = [&](const std::vector<int>& h, double q) {
    const double target = q * n;
    double acc = 0;
    for (int b = 0; b < static_cast<int>(h.size()); ++b) {
      if (acc + h[b] > target) {
        // Interpolate inside the bin so small integer MADs are not all zero.
        return b + (target - acc) / h[b];
      }
      acc += h[b];
    }
    return static_cast<double>(h.size());
  };
  const double width = 1 << shift;
  Levels l;
  const double med_bin = quantile(hist, 0.5);  // in bins, continuous
  l.bg = (med_bin - 0.5) * width;
  // MAD from the histogram of |x - median|, over the occupied bins only (a
  // frame's samples span far fewer than the 4096).
  int first = 0, last = bins - 1;
  while (first < last && hist[first] == 0) ++first;
  while (last > first && hist[last] == 0) --last;
  const auto deviation = [&](int b) {
    return std::min(static_cast<int>(std::abs(b + 0.5 - med_bin)), bins - 1);
  };
  // The bins near the median first: a bin farther than kNear from it has a
  // deviation of kNear - 1 or more, so when the median deviation is found
  // below that, the far bins (most of a lit frame's range) cannot change it.
  constexpr int kNear = 64;
  const int mid = static_cast<int>(med_bin);
  const auto madOver = [&](int lo, int hi, double& found) {
    std::vector<int> dev(std::max(deviation(lo), deviation(hi)) + 1, 0);
    for (int b = lo; b <= hi; ++b) dev[deviation(b)] += hist[b];
    found = quantile(dev, 0.5);
  };
  double mad_bins = 0;
  madOver(std::max(first, mid - kNear), std::min(last, mid + kNear), mad_bins);
  if (!(mad_bins < kNear - 2)) madOver(first, last, mad_bins);
  const double mad = mad_bins * width;
  l.sigma = std::max(1.4826 * mad, 0.3 * width);
  // Brightest level: the 3rd largest sample (one or two hot pixels aside).
  int seen = 0;
  for (int b = last; b >= 0; --b) {
    seen += hist[b];
    if (seen >= 3) {
      l.bright = (b + 0.5) * width;
      break;
    }
  }
  l.threshold = l.bg + std::max(0.15 * (l.bright - l.bg), 6.0 * l.sigma + width);
  // A shaded limb can be far darker than the sphere's lit side (ambient x
  // albedo): blobs extend down to what noise rarely reaches (isolated noise
  // makes no blob: a blob must also reach the threshold above).
  l.low = std::min(l.threshold, l.bg + std::max(4.0 * l.sigma + width, 0.01 * (l.bright - l.bg)));
  l.saturated_fraction = static_cast<double>(at_max) / std::max(1, n);
  return l;
}

// ------------------------------------------------------------- coarse stage

struct Blob {
  std::vector<CirclePoint> outline;  // grid-resolution outline points, pixels
  bool seeded = false;               // holds a sample at or above the seed level
  std::vector<cv::Point2d> cells;    // cell centres (pixels), for splitting
  int area = 0;                      // cells
  bool at_border = false;            // reaches the frame's border
};

// Runs of grid cells at or above a threshold along the grid rows, joined
// into connected (8-neighbour) sets by union-find.
struct GridRuns {
  struct Run {
    int y, x0, x1, parent;
  };
  std::vector<Run> runs;
  std::vector<int> row_first;  // runs of grid row y: [row_first[y], row_first[y + 1])

  int find(int i) {
    while (runs[i].parent != i) i = runs[i].parent = runs[runs[i].parent].parent;
    return i;
  }

  GridRuns(const Grid& g, int threshold) : row_first(g.h + 1, 0) {
    for (int y = 0; y < g.h; ++y) {
      row_first[y] = static_cast<int>(runs.size());
      const std::uint16_t* row = g.v.data() + static_cast<std::size_t>(y) * g.w;
      for (int x = 0; x < g.w;) {
        while (x < g.w && row[x] < threshold) ++x;
        if (x == g.w) break;
        const int x0 = x;
        while (x < g.w && row[x] >= threshold) ++x;
        const int self = static_cast<int>(runs.size());
        runs.push_back({y, x0, x - 1, self});
        if (y == 0) continue;
        for (int k = row_first[y - 1]; k < row_first[y]; ++k) {
          if (runs[k].x1 < x0 - 1) continue;
          if (runs[k].x0 > x) break;
          const int a = find(k), b = find(self);
          if (a != b) runs[std::max(a, b)].parent = std::min(a, b);
        }
      }
    }
    row_first[g.h] = static_cast<int>(runs.size());
  }
};

Circle bestTripleCircle(const std::vector<CirclePoint>& points, const PointArrays& pa, double band,
                        const Circle& start, int& best);
bool goodCoarse(const Result<CircleFit>& f, std::size_t total, int step);

// A blob that is only part of its sphere: the lit side of a sphere whose
// shaded limb is darker than a grey backdrop, cut off by a chord where the
// limb crosses the backdrop's level. The circle that most of its outline
// lies on (RANSAC over triples of outline points), refitted to those points,
// when they are at least 40 % of the outline, lie on it as closely as a
// whole sphere's outline does (goodCoarse) and span at least a third of it,
// and the blob's cells lie inside it; the fine stage then searches the rest
// of the limb around it (measureCandidate). Not for a blob at the frame's
// border: a sphere cut by it is an arc already, and one cut too deep for a
// circle stays unmeasured.
bool partialDisc(const Blob& blob, int step, CircleFit& out) {
  const std::vector<CirclePoint>& pts = blob.outline;
  if (blob.at_border || pts.size() < 12) return false;
  const PointArrays pa(pts);
  Circle start;
  if (!kasaFit(pa, start)) return false;
  const double band = 0.75 * step + 0.5;
  int best = -1;
  const Circle c = bestTripleCircle(pts, pa, band, start, best);
  if (best < std::max(8.0, 0.4 * static_cast<double>(pts.size()))) return false;
  std::vector<CirclePoint> on;
  for (const CirclePoint& p : pts)
    if (std::abs(std::hypot(p.u - c.u, p.v - c.v) - c.r) <= band) on.push_back(p);
  const Result<CircleFit> f = fitCircle(on, 3.0, band);
  if (!goodCoarse(f, on.size(), step)) return false;
  // A part of a disc lies inside the disc (a square, whose corners the best
  // circle through its sides leaves outside, does not).
  int outside = 0;
  for (const cv::Point2d& q : blob.cells)
    outside += std::hypot(q.x - f->u, q.y - f->v) > f->radius + step;
  if (outside > 0.02 * static_cast<double>(blob.cells.size())) return false;
  // The largest gap between the points' directions from the centre.
  std::vector<double> angle;
  for (const CirclePoint& p : on) angle.push_back(std::atan2(p.v - f->v, p.u - f->u));
  std::sort(angle.begin(), angle.end());
  double gap = angle.front() + 2 * std::numbers::pi - angle.back();
  for (std::size_t i = 1; i < angle.size(); ++i) gap = std::max(gap, angle[i] - angle[i - 1]);
  if (gap > 4 * std::numbers::pi / 3) return false;
  out = *f;
  return true;
}

// A blob's extent in grid cells.
struct Extent {
  int x0, x1, y0, y1;
};

// The blob of every run (blob_of), each blob's area, seed and extent.
void labelBlobs(const Grid& g, GridRuns& gr, int seed, std::vector<int>& blob_of,
                std::vector<Blob>& blobs, std::vector<Extent>& box) {
  const auto& runs = gr.runs;
  blob_of.assign(runs.size(), -1);
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const int root = gr.find(static_cast<int>(i));
    if (blob_of[root] < 0) {
      blob_of[root] = static_cast<int>(blobs.size());
      blobs.emplace_back();
      box.push_back({runs[i].x0, runs[i].x1, runs[i].y, runs[i].y});
    }
    const int b = blob_of[root];
    blob_of[i] = b;
    blobs[b].area += runs[i].x1 - runs[i].x0 + 1;
    if (!blobs[b].seeded) {
      const std::uint16_t* row = g.v.data() + static_cast<std::size_t>(runs[i].y) * g.w;
      for (int x = runs[i].x0; x <= runs[i].x1; ++x)
        if (row[x] >= seed) {
          blobs[b].seeded = true;
          break;
        }
    }
    Extent& e = box[b];
    e.x0 = std::min(e.x0, runs[i].x0), e.x1 = std::max(e.x1, runs[i].x1);
    e.y1 = std::max(e.y1, runs[i].y);
  }
}

// Blob b's cells and outline: the ends of its extent in every grid row and
// column, where they are not on the frame's border, half a cell outside.
// top, bottom, left, right: scratch, reused from blob to blob.
void traceBlob(const Grid& g, const GridRuns& gr, const std::vector<int>& blob_of, std::size_t b,
               const Extent& e, Blob& blob, std::vector<int>& top, std::vector<int>& bottom,
               std::vector<int>& left, std::vector<int>& right) {
  const double step = g.step, off = g.off;
  blob.at_border = e.x0 == 0 || e.y0 == 0 || e.x1 == g.w - 1 || e.y1 == g.h - 1;
  top.assign(e.x1 - e.x0 + 1, -1), bottom.assign(e.x1 - e.x0 + 1, -1);
  left.assign(e.y1 - e.y0 + 1, -1), right.assign(e.y1 - e.y0 + 1, -1);
  for (int y = e.y0; y <= e.y1; ++y)
    for (int k = gr.row_first[y]; k < gr.row_first[y + 1]; ++k) {
      if (blob_of[k] != static_cast<int>(b)) continue;
      const GridRuns::Run& r = gr.runs[k];
      int& l = left[y - e.y0];
      int& rr = right[y - e.y0];
      if (l < 0 || r.x0 < l) l = r.x0;
      rr = std::max(rr, r.x1);
      for (int x = r.x0; x <= r.x1; ++x) {
        int& t = top[x - e.x0];
        if (t < 0) t = y;
        bottom[x - e.x0] = y;
        blob.cells.emplace_back(x * step + off, y * step + off);
      }
    }
  for (int y = e.y0; y <= e.y1; ++y) {
    const int l = left[y - e.y0], r = right[y - e.y0];
    if (l < 0) continue;
    const double v = y * step + off;
    if (l > 0) blob.outline.push_back({l * step + off - 0.5 * step, v});
    if (r < g.w - 1) blob.outline.push_back({r * step + off + 0.5 * step, v});
  }
  for (int x = e.x0; x <= e.x1; ++x) {
    const int t = top[x - e.x0], bt = bottom[x - e.x0];
    if (t < 0) continue;
    const double u = x * step + off;
    if (t > 0) blob.outline.push_back({u, t * step + off - 0.5 * step});
    if (bt < g.h - 1) blob.outline.push_back({u, bt * step + off + 0.5 * step});
  }
}

// Connected (8-neighbour) blobs of grid cells at or above `threshold`, with
// each blob's outline (traceBlob).
std::vector<Blob> findBlobs(const Grid& g, double threshold_level, double seed_level) {
  // Samples are whole numbers: compare as integers.
  GridRuns gr(g, static_cast<int>(std::ceil(threshold_level)));
  std::vector<int> blob_of;
  std::vector<Blob> blobs;
  std::vector<Extent> box;
  labelBlobs(g, gr, static_cast<int>(std::ceil(seed_level)), blob_of, blobs, box);
  std::vector<int> top, bottom, left, right;
  for (std::size_t b = 0; b < blobs.size(); ++b)
    traceBlob(g, gr, blob_of, b, box[b], blobs[b], top, bottom, left, right);
  return blobs;
}

Result<CircleFit> fitCoarse(const std::vector<CirclePoint>& pts, int step) {
  return fitCircle(pts, 3.0, 0.75 * step + 0.5);
}

bool goodCoarse(const Result<CircleFit>& f, std::size_t total, int step) {
  return f.ok() && f->points >= 8 && f->rejected <= 0.25 * static_cast<double>(total) &&
         f->residual_rms <= 0.45 * step + 0.6;
}

// Two circles from the outline of one blob: 2-means on the cells along the
// blob's principal axis, outline points to the nearer cluster, fit, then each
// point to the circle it lies closer to and fit again.
bool splitPair(const Blob& blob, int step, std::array<CircleFit, 2>& out) {
  if (blob.cells.size() < 10) return false;
  cv::Point2d mean(0, 0);
  for (const auto& c : blob.cells) mean += c;
  mean *= 1.0 / static_cast<double>(blob.cells.size());
  double sxx = 0, syy = 0, sxy = 0;
  for (const auto& c : blob.cells) {
    const cv::Point2d d = c - mean;
    sxx += d.x * d.x, syy += d.y * d.y, sxy += d.x * d.y;
  }
  const double ang = 0.5 * std::atan2(2 * sxy, sxx - syy);
  const cv::Point2d axis(std::cos(ang), std::sin(ang));
  double lo = 0, hi = 0;
  for (const auto& c : blob.cells) {
    const double t = (c - mean).dot(axis);
    lo = std::min(lo, t), hi = std::max(hi, t);
  }
  std::array<cv::Point2d, 2> centre{mean + axis * (0.5 * lo), mean + axis * (0.5 * hi)};
  for (int it = 0; it < 8; ++it) {
    std::array<cv::Point2d, 2> sum{cv::Point2d(0, 0), cv::Point2d(0, 0)};
    std::array<int, 2> count{0, 0};
    for (const auto& c : blob.cells) {
      const cv::Point2d d0 = c - centre[0], d1 = c - centre[1];
      const int k = d0.dot(d0) <= d1.dot(d1) ? 0 : 1;
      sum[k] += c, ++count[k];
    }
    if (count[0] == 0 || count[1] == 0) return false;
    centre = {sum[0] * (1.0 / count[0]), sum[1] * (1.0 / count[1])};
  }
  std::array<std::vector<CirclePoint>, 2> part;
  for (const auto& p : blob.outline) {
    const cv::Point2d q(p.u, p.v);
    const cv::Point2d d0 = q - centre[0], d1 = q - centre[1];
    part[d0.dot(d0) <= d1.dot(d1) ? 0 : 1].push_back(p);
  }
  std::array<Result<CircleFit>, 2> fit{fitCoarse(part[0], step), fitCoarse(part[1], step)};
  if (!fit[0] || !fit[1]) return false;
  for (int round = 0; round < 2; ++round) {
    part[0].clear(), part[1].clear();
    for (const auto& p : blob.outline) {
      double res[2];
      for (int k = 0; k < 2; ++k)
        res[k] = std::abs(std::hypot(p.u - fit[k]->u, p.v - fit[k]->v) - fit[k]->radius);
      part[res[0] <= res[1] ? 0 : 1].push_back(p);
    }
    fit = {fitCoarse(part[0], step), fitCoarse(part[1], step)};
    if (!fit[0] || !fit[1]) return false;
  }
  for (int k = 0; k < 2; ++k)
    if (!goodCoarse(fit[k], part[k].size(), step)) return false;
  out = {*fit[0], *fit[1]};
  return true;
}

// -------------------------------------------------------------- fine stage

struct EdgeContext {
  double threshold = 0, dark_limit = 0, sigma = 0;
  double min_contrast = 0;       // smallest step off the background taken for an edge
  int clip_value = 0;            // a sample at or above this is clipped (saturated)
  int hw = 2;                    // transition window: [c - 1 - hw, c + hw]
  int n_out = 3;                 // background samples before it
  int n_in = 5;                  // sphere samples after it (the brightness at the limb)
  int search = 6;                // crossing searched within +-search of the predicted edge
  int line_stride = 1;           // every n-th row / column
  double radius = 1;             // of the circle the profiles were read around
  double local_shape_chi2 = 25;  // a stretch's own shading when it fits this much better
  double root_shape_chi2 = 3;    // the square-root shape when it fits this much better
  bool quadratic = true;         // shape with a delta^2 term (enough inside samples for it)
  bool front_lit = true;         // lit spheres (a lamp's terminator), not a backlit negative
};

struct EdgeStats {
  double sum_out = 0, sum_rim = 0;
  int accepted = 0, border = 0, saturated = 0;
};

// Shape of the sphere's brightness just inside the limb as a function of the
// depth delta (pixels inside the outline, along the radius):
//   D(delta) = A + b1 delta + b2 delta^2 + b3 sqrt(delta).
// The square root is Lambert's law at a limb that faces the lamp's axis (the
// normal's z component grows as sqrt(2 delta / R)), the polynomial the
// smooth rest (a front-lit rim, a lamp from the side, where the light falls
// off towards the terminator). The level A is per profile; (b1, b2, b3) are
// shared by the profiles of one stretch of the outline, so the per-profile
// noise does not enter the shape, whose noise would otherwise bias the
// covered length at second order.
constexpr int kShape = 3;
using ShapeVec = Eigen::Matrix<double, kShape, 1>;

// The shading fit's sums over inside samples (of one profile, or added up
// over a stretch of the outline): the centred shape regressors' Gram matrix
// as its six distinct entries g00 g01 g02 g11 g12 g22, their products with
// the centred samples c0 c1 c2, and the samples' centred sum of squares yy.
// Ten plain doubles: the fit adds thousands of these per frame.
struct ShadeMoments {
  enum { g00, g01, g02, g11, g12, g22, c0, c1, c2, yy, kCount };
  std::array<double, kCount> v{};
  double operator[](int i) const { return v[i]; }
  void add(const ShadeMoments& o) {
    for (int i = 0; i < kCount; ++i) v[i] += o.v[i];
  }
  void subtract(const ShadeMoments& o) {
    for (int i = 0; i < kCount; ++i) v[i] -= o.v[i];
  }
  double gram(int i, int j) const {
    static constexpr int index[kShape][kShape] = {
        {g00, g01, g02}, {g01, g11, g12}, {g02, g12, g22}};
    return v[index[i][j]];
  }
  double cross(const ShapeVec& b) const { return b(0) * v[c0] + b(1) * v[c1] + b(2) * v[c2]; }
  // b' G b
  double gramForm(const ShapeVec& b) const {
    return b(0) * b(0) * v[g00] + b(1) * b(1) * v[g11] + b(2) * b(2) * v[g22] +
           2 * (b(0) * b(1) * v[g01] + b(0) * b(2) * v[g02] + b(1) * b(2) * v[g12]);
  }
};

// Depth below the limb of a point `along` pixels inwards from the edge on a
// line that meets the limb at cosine g: R - sqrt(R^2 - 2 R g l + l^2).
inline double depthAlong(double along, double g, double h) {
  return std::max(1e-6, g * along - h * along * along);
}

// One line across the limb, sampled from outside to inside.
struct Profile {
  int line = 0, side = 0, axis = 0;
  int start = 0;       // pixel (along the line) of sample 0
  int c = 0;           // first sample at or above the profile's own threshold
  double thr = 0;      // that threshold: 30 % of the way from its background to the limb
  double g = 0;        // cosine between the line and the radius at the limb
  int bin = 0;         // angular sector of the outline it crosses (shading is fitted per sector)
  double out = 0;      // background level
  double mean_in = 0;  // of the inside samples (beyond the window)
  double len0 = 0;     // first guess of the covered length of the window (edge to its end)
  double in_off = 0;   // first inside sample's position from the window's end (+ inwards)
  // The inside samples' shading moments (ShadeMoments): the shading fit and
  // the residual checks need nothing else of them.
  ShadeMoments mom;
  ShapeVec shape = ShapeVec::Zero();  // the fitted (b1, b2, b3) around it
  bool darker = false;  // the limb is darker than the backdrop: its samples turned over
  bool ok = false;
};

// Sectors of the outline for the shading fit, by a cheap monotonic pseudo-angle
// of (dx, dy) in [0, 4) (no trigonometry per profile).
constexpr int kSectors = 32;
int angleBin(double dx, double dy) {
  const double s = std::abs(dx) + std::abs(dy);
  if (!(s > 0)) return 0;
  double a;
  if (dy >= 0)
    a = dx >= 0 ? dy / s : 2.0 - dy / s;
  else
    a = dx < 0 ? 2.0 - dy / s : 4.0 + dy / s;
  return std::clamp(static_cast<int>(a * (kSectors / 4.0)), 0, kSectors - 1);
}

template <class T>
void sampleProfiles(const cv::Mat& img, const Circle& c, const EdgeContext& ctx,
                    std::vector<Profile>& profiles, std::vector<float>& samples, int& len,
                    int& margin, EdgeStats& st) {
  const int w = img.cols, h = img.rows;
  margin = ctx.search + ctx.hw + ctx.n_out + 2;  // outside the predicted edge
  const int inner = ctx.search + ctx.hw + ctx.n_in + 2;
  len = margin + inner + 1;
  const double band = 0.7072 * c.r;  // each limb covers +-45 degrees
  const std::size_t stride = img.step1();
  const T* data = img.ptr<T>(0);
  for (int axis = 0; axis < 2; ++axis) {      // 0: rows (left/right), 1: columns (top/bottom)
    const double ca = axis == 0 ? c.v : c.u;  // across the lines
    const double cb = axis == 0 ? c.u : c.v;  // along the lines
    const int n_lines = axis == 0 ? h : w;
    const int n_along = axis == 0 ? w : h;
    const std::ptrdiff_t step_along = axis == 0 ? 1 : static_cast<std::ptrdiff_t>(stride);
    const std::ptrdiff_t step_line = axis == 0 ? static_cast<std::ptrdiff_t>(stride) : 1;
    const int l0 = std::max(0, static_cast<int>(std::ceil(ca - band)));
    const int l1 = std::min(n_lines - 1, static_cast<int>(std::floor(ca + band)));
    // Limb by limb, so that consecutive points are neighbours on the outline.
    for (int side = -1; side <= 1; side += 2)
      for (int line = l0; line <= l1; line += ctx.line_stride) {
        const double d = line - ca;
        const double half = std::sqrt(std::max(0.0, c.r * c.r - d * d));
        {
          const int edge = static_cast<int>(std::lround(cb + side * half));
          const int start = edge + side * margin;  // outermost sample
          const int end = edge - side * inner;
          if (std::min(start, end) < 0 || std::max(start, end) > n_along - 1) {
            ++st.border;
            continue;
          }
          // Its memory asked for now, read below: the frame is not in a
          // cache, and the loads of all profiles then overlap. A row's
          // samples are in one or two cache lines; a column's cache lines
          // serve the next columns too, so only its first column asks.
          const char* first = reinterpret_cast<const char*>(data + line * step_line +
                                                            std::min(start, end) * step_along);
          if (axis == 0) {
            __builtin_prefetch(first);
            __builtin_prefetch(first + (len - 1) * sizeof(T));
          } else if (line == l0 ||
                     (line * sizeof(T)) / 64 != ((line - ctx.line_stride) * sizeof(T)) / 64) {
            for (int i = 0; i < len; ++i) __builtin_prefetch(first + i * stride * sizeof(T));
          }
          Profile p;
          p.line = line, p.side = side, p.axis = axis, p.start = start;
          p.g = half / c.r;
          p.bin = angleBin(axis == 0 ? side * half : d, axis == 0 ? d : side * half);
          profiles.push_back(p);
        }
      }
  }
  samples.resize(profiles.size() * len);
  for (std::size_t k = 0; k < profiles.size(); ++k) {
    const Profile& p = profiles[k];
    const std::ptrdiff_t step_along = p.axis == 0 ? 1 : static_cast<std::ptrdiff_t>(stride);
    const std::ptrdiff_t step_line = p.axis == 0 ? static_cast<std::ptrdiff_t>(stride) : 1;
    const T* src = data + p.line * step_line + p.start * step_along;
    const std::ptrdiff_t dir = -p.side * step_along;
    float* buf = samples.data() + k * len;
    for (int i = 0; i < len; ++i) buf[i] = static_cast<float>(src[i * dir]);
  }
}

// The centred shape regressors of a profile's inside samples, their Gram
// matrix and products with the samples, for depths measured from the edge at
// pr.len0 from the window's end. Eight profiles at a time, one per lane of a
// single-precision vector (their samples are the same count, n_in, at most
// kMaxInside; a profile's eight sums of products of centred values keep
// single precision's 1e-7, and are added up in double from there on).
constexpr int kMaxInside = 16;
constexpr int kMomentLanes = 8;

// Per lane: the first inside sample's depth offset, the line's geometry, the
// samples' mean and the samples themselves (sample j of lane l at y[j][l]).
struct MomentLanes {
  float first[kMomentLanes], g[kMomentLanes], h[kMomentLanes], mean[kMomentLanes];
  float y[kMaxInside][kMomentLanes];
};
struct ShapeSums {
  FLanes g00, g01, g02, g11, g12, g22, c0, c1, c2, yy;
};

// The depth of sample j below the limb is depthAlong(first + j) (at least
// 1e-6); the regressors are (depth, depth^2 when quadratic, sqrt(depth)),
// centred on their means over the n samples, as the samples are on theirs.
COLLIDE_INLINE_KERNEL ShapeSums shapeSums(const MomentLanes& m, int n, bool quadratic) {
  const FLanes first = COLLIDE_LOAD_FLANES(m.first), g = COLLIDE_LOAD_FLANES(m.g),
               h = COLLIDE_LOAD_FLANES(m.h), mean = COLLIDE_LOAD_FLANES(m.mean);
  FLanes fa[kMaxInside], fb[kMaxInside], fc[kMaxInside];
  FLanes sa{}, sb{}, sc{};
  for (int j = 0; j < n; ++j) {
    const FLanes along = first + static_cast<float>(j);
    FLanes dd = g * along - h * along * along;
    dd = dd > 1e-6f ? dd : FLanes{} + 1e-6f;
    for (int l = 0; l < kMomentLanes; ++l) fc[j][l] = std::sqrt(dd[l]);
    fa[j] = dd;
    fb[j] = quadratic ? dd * dd : FLanes{};
    sa += fa[j], sb += fb[j], sc += fc[j];
  }
  const float inv_n = 1.0f / n;
  const FLanes ma = sa * inv_n, mb = sb * inv_n, mc = sc * inv_n;
  ShapeSums z{};
  for (int j = 0; j < n; ++j) {
    const FLanes a = fa[j] - ma, b = fb[j] - mb, c = fc[j] - mc;
    const FLanes y = COLLIDE_LOAD_FLANES(m.y[j]) - mean;
    z.g00 += a * a, z.g01 += a * b, z.g02 += a * c, z.g11 += b * b, z.g12 += b * c;
    z.g22 += c * c;
    z.c0 += y * a, z.c1 += y * b, z.c2 += y * c, z.yy += y * y;
  }
  return z;
}

// shapeSums for the profiles listed in `which` (indices into profiles).
COLLIDE_AVX2_CLONES void shapeMoments(const std::vector<float>& samples, int len,
                                      const EdgeContext& ctx, const std::vector<std::size_t>& which,
                                      std::vector<Profile>& profiles) {
  for (std::size_t k = 0; k < which.size(); k += kMomentLanes) {
    const std::size_t used = std::min<std::size_t>(kMomentLanes, which.size() - k);
    MomentLanes m;
    for (std::size_t l = 0; l < kMomentLanes; ++l) {
      const std::size_t i = which[k + std::min(l, used - 1)];  // spare lanes: a copy
      const Profile& pr = profiles[i];
      const float* y = samples.data() + i * len + pr.c + 2;
      m.first[l] = static_cast<float>(pr.len0 + pr.in_off);
      m.g[l] = static_cast<float>(pr.g);
      m.h[l] = static_cast<float>(0.5 * (1 - pr.g * pr.g) / ctx.radius);
      m.mean[l] = static_cast<float>(pr.mean_in);
      for (int j = 0; j < ctx.n_in; ++j) m.y[j][l] = y[j];
    }
    const ShapeSums z = shapeSums(m, ctx.n_in, ctx.quadratic);
    for (std::size_t l = 0; l < used; ++l) {
      Profile& pr = profiles[which[k + l]];
      pr.mom.v = {z.g00[l], z.g01[l], z.g02[l], z.g11[l], z.g12[l],
                  z.g22[l], z.c0[l],  z.c1[l],  z.c2[l],  z.yy[l]};
    }
  }
}

// Finds the edge's crossing on one profile against the profile's own levels
// and checks the background and the inside. The background is the mean of
// the outermost samples (beyond any edge the search admits); the limb's level
// is read just inside the first place the profile leaves that background
// (by more than noise), and the crossing is where the profile passes 30 % of
// the way from the one to the other (the old global threshold's place on an
// evenly lit sphere). So a limb in shadow, barely above the backdrop, and a lit
// limb are both cut at their own level, wherever the frame's brightest
// pixels are. A profile that leaves the background downwards meets a limb
// darker than the backdrop (a grey backdrop, the shaded side under one lamp):
// its samples are turned over about the background, 2 far - p, in place, so
// that it and everything after reads every limb as brighter.
void screenProfile(float* p, int len, int predicted, const EdgeContext& ctx, Profile& pr,
                   EdgeStats& st) {
  pr.ok = false;
  pr.darker = false;
  const int first = std::max(ctx.n_out + ctx.hw + 1, predicted - ctx.search);
  const int last = std::min(len - ctx.hw - ctx.n_in - 1, predicted + ctx.search);
  // Background far out: flat and dark (no other sphere, no glare).
  double far = 0;
  for (int i = 0; i < ctx.n_out; ++i) far += p[i];
  far /= ctx.n_out;
  if (far >= ctx.dark_limit) return;
  const double tol = 5.0 * ctx.sigma + 1.0;
  for (int i = 0; i < ctx.n_out; ++i)
    if (std::abs(p[i] - far) > tol) return;
  // Where the profile first leaves the background (two samples in a row),
  // up or down.
  const double step = std::max(3.0 * ctx.sigma + 1.0, ctx.min_contrast);
  const float leave = static_cast<float>(far + step), sink = static_cast<float>(far - step);
  int c0 = -1;
  for (int i = first - 1, end = std::min(last + 2 * ctx.hw, len - 2); i <= end; ++i) {
    if (p[i] >= leave && p[i + 1] >= leave) {
      c0 = i;
      break;
    }
    if (p[i] <= sink && p[i + 1] <= sink) {
      c0 = i;
      pr.darker = true;
      break;
    }
  }
  if (c0 < 0 || c0 > last) return;
  if (pr.darker)
    for (int i = 0; i < len; ++i) p[i] = static_cast<float>(2.0 * far) - p[i];
  // The limb's level just beyond the widest transition, and the crossing level.
  const int k = std::min(c0 + 2 * ctx.hw + 1, len - 2);
  const double near_in = 0.5 * (p[k] + p[k + 1]);
  if (!(near_in - far > 1.5 * step)) return;
  const float thr = static_cast<float>(far + 0.3 * (near_in - far));
  int c = -1;
  for (int i = std::max(first, c0 - ctx.hw - 1); i <= std::min(last, k); ++i)
    if (p[i - 1] < thr && p[i] >= thr) {
      c = i;
      break;
    }
  if (c < 0) return;
  const int a = c - 1 - ctx.hw, b = c + ctx.hw;
  // Background next to the window: as flat as far out.
  double out = 0;
  for (int i = a - ctx.n_out; i < a; ++i) {
    if (std::abs(p[i] - far) > tol) return;
    out += p[i];
  }
  // Sphere just inside: above the crossing level (no dot), not clipped. The
  // samples read for its shape start two past the crossing, clear of the edge
  // pixel and of a blur of edge_half_width, so the shape is extrapolated to the
  // limb over as little as possible.
  const int s0 = c + 2;
  double sy = 0;
  for (int j = 1; j <= ctx.n_in; ++j) {
    const float y = p[s0 + j - 1];
    if (y < thr) return;
    if (y >= ctx.clip_value) {
      ++st.saturated;
      return;
    }
    sy += y;
  }
  const double mean = sy / ctx.n_in;
  // The edge is first put where the profile crosses that level; the
  // inside samples' depths below the limb follow from it.
  const double t = (thr - p[c - 1]) / std::max(1e-6f, p[c] - p[c - 1]);
  pr.len0 = b + 0.5 - (c - 1 + std::clamp(t, 0.0, 1.0));
  pr.in_off = s0 - (b + 0.5);
  pr.c = c;
  pr.thr = thr;
  pr.out = out / ctx.n_out;
  pr.mean_in = mean;
  pr.ok = true;
}

// The shape (b1, b2, b3) by least squares over the usable profiles of a
// stretch of the outline around each profile (its sector and neighbouring
// ones, widened until enough profiles take part), each profile's own level
// eliminated by centring. One-sided light shades the limb very differently
// around the outline (flat ambient on the far side, a steep rise on the lit
// side), so the shape may be local; but a local shape is noisier, so a
// stretch keeps the whole outline's shape unless its own fits its profiles
// significantly better (by more than the noise can explain). Profiles whose
// inside samples stray from their shape (a dot edge, a highlight) are dropped
// and the fit repeated. Limbs darker than the backdrop (turned over) and
// brighter ones are fitted apart, `darker` those of one kind: the two shade
// oppositely where the limb crosses the backdrop's level.
// Returns whether any stretch took the square-root shape.
bool fitShadingOf(std::vector<Profile>& profiles, const EdgeContext& ctx, bool darker) {
  struct Sums {
    ShadeMoments s;
    int n = 0;
    void add(const Sums& o) { s.add(o.s), n += o.n; }
  };
  constexpr int kMinProfiles = 16;
  bool any_root = false;
  // Two shapes of two terms each: (delta, delta^2), the smooth falloff of an
  // evenly lit or side-lit limb, and (delta, sqrt(delta)), a limb facing the
  // lamp's axis. The square root is taken only when it fits significantly
  // better: where the truth is smooth it would only add noise.
  const auto solveWith = [&](const Sums& z, int drop, ShapeVec& b, double& rss) {
    const int k = drop == 2 ? 1 : 2;  // the second term kept besides delta
    const double m00 = z.s.gram(0, 0), m0k = z.s.gram(0, k), mkk = z.s.gram(k, k);
    const double r0 = z.s[ShadeMoments::c0], rk = z.s[ShadeMoments::c0 + k];
    const double det = m00 * mkk - m0k * m0k;
    if (!(det > 1e-12 * m00 * mkk) || !std::isfinite(det)) return false;
    b.setZero();
    b(0) = (mkk * r0 - m0k * rk) / det;
    b(k) = (m00 * rk - m0k * r0) / det;
    rss = std::max(0.0, z.s[ShadeMoments::yy] - b(0) * r0 - b(k) * rk);
    return std::isfinite(b(0)) && std::isfinite(b(k));
  };

  const auto solve = [&](const Sums& z, ShapeVec& b) {
    ShapeVec smooth, root;
    double rss_smooth = 0, rss_root = 0;
    const bool ok_smooth = solveWith(z, 2, smooth, rss_smooth);
    const bool ok_root = solveWith(z, 1, root, rss_root);
    if (!ok_smooth && !ok_root) return false;
    const int dof = z.n * (ctx.n_in - 1) - 2;
    const double var = dof > 0 ? rss_root / dof : 0;
    b = ok_root && (!ok_smooth || rss_smooth - rss_root > ctx.root_shape_chi2 * var) ? root
                                                                                     : smooth;
    return true;
  };
  // Per sector of the outline, and per stretch around each sector: its sums
  // and how many sectors it reaches out on either side.
  std::array<Sums, kSectors> sector{};
  for (const Profile& pr : profiles)
    if (pr.ok && pr.darker == darker) sector[pr.bin].s.add(pr.mom), ++sector[pr.bin].n;
  std::array<Sums, kSectors> stretch;
  std::array<int, kSectors> reach{};
  std::array<bool, kSectors> changed;  // a sector that lost profiles since the last round
  changed.fill(true);
  // Per stretch: its own shape, whether it has one, and the residual variance
  // about it (a stretch that did not change keeps them from the last round).
  std::array<ShapeVec, kSectors> local;
  std::array<bool, kSectors> has_local{};
  std::array<double, kSectors> local_var{};
  for (int round = 0; round < 2; ++round) {
    Sums all;
    for (const Sums& z : sector) all.add(z);
    ShapeVec global = ShapeVec::Zero();
    solve(all, global);
    std::array<ShapeVec, kSectors> shape;
    for (int bin = 0; bin < kSectors; ++bin) {
      shape[bin] = global;
      // A stretch none of whose sectors changed is the same stretch.
      bool stale = false;
      for (int w = -reach[bin]; w <= reach[bin] && !stale; ++w)
        stale = changed[(bin + w + kSectors) % kSectors];
      Sums& z = stretch[bin];
      if (stale) {
        z = sector[bin];
        int w = 1;
        for (; w < kSectors / 2 && (w <= 1 || z.n < kMinProfiles); ++w) {
          z.add(sector[(bin + w) % kSectors]);
          z.add(sector[(bin - w + kSectors) % kSectors]);
        }
        reach[bin] = w - 1;
        has_local[bin] = z.n >= 4 && solve(z, local[bin]);
        if (has_local[bin]) {
          // Residual variance about the local shape.
          const int dof = z.n * (ctx.n_in - 1) - kShape;
          const double rss = std::max(0.0, z.s[ShadeMoments::yy] - z.s.cross(local[bin]));
          local_var[bin] = dof > 0 ? rss / dof : 0;
        }
      }
      // How much better the local shape fits than the global one (a
      // chi-square with kShape degrees of freedom when the shading is the
      // same all round).
      if (has_local[bin] &&
          z.s.gramForm(local[bin] - global) > ctx.local_shape_chi2 * local_var[bin])
        shape[bin] = local[bin];
    }
    bool dropped = false;
    any_root = false;
    changed.fill(false);
    for (Profile& pr : profiles) {
      if (!pr.ok || pr.darker != darker) continue;
      pr.shape = shape[pr.bin];
      any_root |= pr.shape(2) != 0;
      if (round == 1) continue;
      // Drop profiles that do not follow their shape (taken out of their
      // sector's sums); refit if any went.
      const ShapeVec& b = pr.shape;
      const double rss =
          std::max(0.0, pr.mom[ShadeMoments::yy] - 2 * pr.mom.cross(b) + pr.mom.gramForm(b));
      const double rms = std::sqrt(rss / ctx.n_in);
      if (rms > 3.0 * ctx.sigma + 0.03 * (pr.mean_in - pr.out)) {
        pr.ok = false;
        dropped = true;
        sector[pr.bin].s.subtract(pr.mom), --sector[pr.bin].n;
        changed[pr.bin] = true;
      }
    }
    if (!dropped) break;
  }
  return any_root;
}

// The shading of both kinds of limb; whether any took the square root.
bool fitShading(std::vector<Profile>& profiles, const EdgeContext& ctx) {
  const bool brighter = fitShadingOf(profiles, ctx, false);
  const bool any_darker = std::any_of(profiles.begin(), profiles.end(),
                                      [](const Profile& pr) { return pr.ok && pr.darker; });
  return (any_darker && fitShadingOf(profiles, ctx, true)) || brighter;
}

// The edges of screened profiles are solved eight at a time, one profile per
// lane of a single-precision vector (ample: the edge is wanted to 1e-3 px,
// single precision keeps the window's sums, ~1e4, to 1e-3 and the lengths to
// 1e-6 px): per profile, the window's sum S of (p - out), the inside
// samples' mean level above background, the line's geometry and the shape;
// the covered length L is solved for by Newton (below), and what is left per
// profile (its checks) is done one at a time, in double precision.
struct EdgeLanes {
  static constexpr int kLanes = 8;
  float len[kLanes], level[kLanes], sum[kLanes], above[kLanes], in_off[kLanes];
  float g[kLanes], h[kLanes], b0[kLanes], b1[kLanes], b2[kLanes];
  bool ok[kLanes];  // false: Newton's slope was not positive (no edge)
};

// The window [a - 0.5, b + 0.5] holds the whole transition: the sum S of
// (p - out) over it is the integral of D - out over the covered length L
// (the edge at b + 0.5 - L). The level A above background follows from the
// inside samples' mean once their depths (L + j - 1/2 along the line) are
// known, so S = A(L) L + integral of the shape is solved for L by Newton,
// each lane until its step is below 1e-3 px or after `iterations` steps.
// A term of the shape whose coefficient is zero adds exactly nothing; the
// square roots are left out when no lane's shape has that term.
COLLIDE_INLINE_KERNEL void solveCoveredLengths(EdgeLanes& e, int n_in, int iterations, bool root) {
  constexpr int kL = EdgeLanes::kLanes;
  const FLanes g = COLLIDE_LOAD_FLANES(e.g), h = COLLIDE_LOAD_FLANES(e.h);
  const FLanes b0 = COLLIDE_LOAD_FLANES(e.b0), b1 = COLLIDE_LOAD_FLANES(e.b1),
               b2 = COLLIDE_LOAD_FLANES(e.b2);
  const FLanes sum = COLLIDE_LOAD_FLANES(e.sum), above = COLLIDE_LOAD_FLANES(e.above);
  const FLanes in_off = COLLIDE_LOAD_FLANES(e.in_off);
  FLanes len = COLLIDE_LOAD_FLANES(e.len), level{};
  FLanes sg{};
  for (int l = 0; l < kL; ++l) sg[l] = std::sqrt(g[l]);
  const FLanes h5g = h / (5 * g);
  FLaneMask active = len == len, bad = len != len;  // all lanes, none
  const float inv_n = 1.0f / n_in;
  const FLanes tiny = FLanes{} + 1e-6f, one = FLanes{} + 1.0f;
  for (int it = 0; it < iterations; ++it) {
    FLanes f0{}, f1{}, f2{}, d0{}, d1{}, d2{};
    for (int j = 0; j < n_in; ++j) {
      const FLanes along = len + in_off + static_cast<float>(j);
      FLanes dd = g * along - h * along * along;
      dd = dd > 1e-6f ? dd : tiny;
      const FLanes slope = g - 2 * h * along;
      f0 += dd, d0 += slope;
      f1 += dd * dd, d1 += 2 * dd * slope;
      if (root) {
        FLanes sd;
        for (int l = 0; l < kL; ++l) sd[l] = std::sqrt(dd[l]);
        f2 += sd, d2 += 0.5f * slope / sd;
      }
    }
    const FLanes lvl = above - (b0 * (f0 * inv_n) + b1 * (f1 * inv_n) + b2 * (f2 * inv_n));
    const FLanes l2 = len * len, l3 = l2 * len;
    FLanes rl{};
    for (int l = 0; l < kL; ++l) rl[l] = root ? std::sqrt(len[l]) : 0.0f;
    const FLanes i0 = 0.5f * g * l2 - h * l3 / 3;
    const FLanes i1 = g * g * l3 / 3 - 0.5f * g * h * l2 * l2 + h * h * l2 * l3 / 5;
    const FLanes i2 = sg * (2.0f / 3.0f * len * rl - h5g * l2 * rl);
    const FLanes f = lvl * len + (b0 * i0 + b1 * i1 + b2 * i2) - sum;
    FLanes dep = g * len - h * len * len;
    dep = dep > 1e-6f ? dep : tiny;
    FLanes rdep{};
    for (int l = 0; l < kL; ++l) rdep[l] = root ? std::sqrt(dep[l]) : 0.0f;
    const FLanes df = lvl - len * (b0 * (d0 * inv_n) + b1 * (d1 * inv_n) + b2 * (d2 * inv_n)) +
                      (b0 * dep + b1 * (dep * dep) + b2 * rdep);
    bad |= active & ~(df > 0);
    active &= df > 0;
    FLanes step = f / (df > 0 ? df : one);
    step = step < -1.0f ? -one : step;
    step = step > 1.0f ? one : step;
    FLanes next = len - step;
    next = next > 0.05f ? next : FLanes{} + 0.05f;
    len = active ? next : len;
    level = active ? lvl : level;
    active &= (step < 0 ? -step : step) >= 1e-3f;
    bool any = false;
    for (int l = 0; l < kL; ++l) any |= active[l] != 0;
    if (!any) break;
  }
  for (int l = 0; l < kL; ++l) {
    e.len[l] = len[l];
    e.level[l] = level[l];
    e.ok[l] = bad[l] == 0;
  }
}

// One profile's part of a lane: its window sum and levels, its geometry and
// shape.
COLLIDE_INLINE_KERNEL void loadLane(const float* p, const Profile& pr, const EdgeContext& ctx,
                                    EdgeLanes& e, int l) {
  const int a = pr.c - 1 - ctx.hw, b = pr.c + ctx.hw;
  double sum = 0;
  for (int i = a; i <= b; ++i) sum += p[i] - pr.out;
  e.sum[l] = static_cast<float>(sum);
  e.above[l] = static_cast<float>(pr.mean_in - pr.out);
  e.len[l] = static_cast<float>(pr.len0);
  e.in_off[l] = static_cast<float>(pr.in_off);
  e.g[l] = static_cast<float>(pr.g);
  e.h[l] = static_cast<float>(0.5 * (1 - pr.g * pr.g) / ctx.radius);
  e.b0[l] = static_cast<float>(pr.shape(0));
  e.b1[l] = static_cast<float>(ctx.quadratic ? pr.shape(1) : 0.0);
  e.b2[l] = static_cast<float>(pr.shape(2));
}

// The edge of a profile from its lane's solution, in profile coordinates
// (sample i's centre at i); NaN if unusable.
COLLIDE_INLINE_KERNEL double acceptEdge(const Profile& pr, const EdgeContext& ctx,
                                        const EdgeLanes& e, int l, EdgeStats* st) {
  const int a = pr.c - 1 - ctx.hw, b = pr.c + ctx.hw;
  const double len = e.len[l], level = e.level[l];
  if (!e.ok[l] || !(len > 0.05f && len < b - a + 1.0)) return std::nan("");
  // The model's level at the window's inner end must be a sphere's.
  const double dep = depthAlong(len, e.g[l], e.h[l]);
  const double end = level + e.b0[l] * dep + e.b1[l] * dep * dep + e.b2[l] * std::sqrt(dep);
  if (!(end > pr.thr - pr.out)) return std::nan("");
  if (st && !pr.darker) {  // the levels of limbs brighter than the backdrop
    st->sum_out += pr.out;
    st->sum_rim += pr.out + level;  // brightness at the limb
    ++st->accepted;
  }
  return b + 0.5 - len;
}

// The edges of every screened profile into x (NaN for one not screened or
// unusable), `iterations` Newton steps at most; `st` counts the accepted
// ones' levels, in profile order.
COLLIDE_AVX2_CLONES void profileEdges(const std::vector<float>& samples, int len,
                                      const std::vector<Profile>& profiles, const EdgeContext& ctx,
                                      int iterations, EdgeStats* st, std::vector<double>& x) {
  x.assign(profiles.size(), std::nan(""));
  std::size_t k = 0;
  while (k < profiles.size()) {
    EdgeLanes e;
    std::size_t index[EdgeLanes::kLanes];
    int used = 0;
    bool root = false;
    for (; k < profiles.size() && used < EdgeLanes::kLanes; ++k) {
      if (!profiles[k].ok) continue;
      loadLane(samples.data() + k * len, profiles[k], ctx, e, used);
      root |= profiles[k].shape(2) != 0;
      index[used++] = k;
    }
    if (used == 0) break;
    for (int l = used; l < EdgeLanes::kLanes; ++l)  // spare lanes: a copy of the first
      loadLane(samples.data() + index[0] * len, profiles[index[0]], ctx, e, l);
    solveCoveredLengths(e, ctx.n_in, iterations, root);
    for (int l = 0; l < used; ++l) x[index[l]] = acceptEdge(profiles[index[l]], ctx, e, l, st);
  }
}

template <class T>
void edgePoints(const cv::Mat& img, const Circle& c, const EdgeContext& ctx,
                std::vector<CirclePoint>& pts, EdgeStats& st) {
  // The buffers are the thread's own and kept between calls (filled anew
  // each time): allocating and zeroing them per sphere was 2-3 % of the
  // detector's time.
  thread_local std::vector<Profile> profiles;
  thread_local std::vector<float> samples;
  thread_local std::vector<double> edges;
  thread_local std::vector<std::size_t> screened, shifted;
  profiles.clear(), screened.clear(), shifted.clear();
  int len = 0, margin = 0;
  sampleProfiles<T>(img, c, ctx, profiles, samples, len, margin, st);
  for (std::size_t k = 0; k < profiles.size(); ++k) {
    screenProfile(samples.data() + k * len, len, margin, ctx, profiles[k], st);
    if (profiles[k].ok) screened.push_back(k);
  }
  shapeMoments(samples, len, ctx, screened, profiles);
  const bool root = fitShading(profiles, ctx);
  // The shape was read at depths from the level crossing, which a limb
  // much darker than the sphere just inside puts too deep: measure the edge,
  // re-read the depths from it, and fit the shape again. The correction is
  // averaged over a stretch of the outline: one profile's own (noisy) edge
  // would correlate the depths with its samples' noise and bias the shape.
  // (Polynomial shapes do not depend on where the depths start.)
  if (root) {
    std::array<double, 2 * kSectors> shift{};  // brighter limbs' sectors, then darker ones'
    std::array<int, 2 * kSectors> count{};
    profileEdges(samples, len, profiles, ctx, 2, nullptr, edges);
    for (std::size_t k = 0; k < profiles.size(); ++k) {
      const Profile& pr = profiles[k];
      if (!pr.ok) continue;
      const double x = edges[k];
      if (std::isnan(x)) continue;
      const int at = pr.bin + (pr.darker ? kSectors : 0);
      shift[at] += pr.c + ctx.hw + 0.5 - x - pr.len0;
      ++count[at];
    }
    for (std::size_t k = 0; k < profiles.size(); ++k) {
      Profile& pr = profiles[k];
      if (!pr.ok) continue;
      double sum = 0;
      int n = 0;
      for (int w = -1; w <= 1; ++w) {
        const int bin = (pr.bin + w + kSectors) % kSectors + (pr.darker ? kSectors : 0);
        sum += shift[bin], n += count[bin];
      }
      if (n == 0) continue;
      pr.len0 += sum / n;
      shifted.push_back(k);
    }
    shapeMoments(samples, len, ctx, shifted, profiles);
    fitShading(profiles, ctx);
  }
  profileEdges(samples, len, profiles, ctx, 4, &st, edges);
  for (std::size_t k = 0; k < profiles.size(); ++k) {
    const Profile& pr = profiles[k];
    if (!pr.ok) continue;
    const double x = edges[k];
    if (std::isnan(x)) continue;
    // The pixel row averages the limb over its height; on a curved limb that
    // mean lies inside the circle by x''/24 = 1/(24 R g^3): put it back.
    const double strip = 1.0 / (24.0 * c.r * pr.g * pr.g * pr.g);
    const double along = pr.start - pr.side * (x - strip);
    if (pr.axis == 0)
      pts.push_back({along, static_cast<double>(pr.line)});
    else
      pts.push_back({static_cast<double>(pr.line), along});
  }
}

// Spheres up to SphereDetectorSettings::silhouette_fit_max_radius_px across
// are measured again by fitting their whole image (vision/silhouette_fit.hpp);
// the circle from the edge profiles is the start, and stays when that fit
// fails. Spheres cut by the border keep the profiles' circle.
void refineSmallSpheres(const cv::Mat& img, const SphereDetectorSettings& set,
                        std::vector<SphereMeasurement>& spheres) {
  SilhouetteFitSettings fs;
  fs.camera = set.camera;
  std::vector<CircleFit> others;
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    SphereMeasurement& m = spheres[i];
    if (m.cut_by_border || m.circle.radius > set.silhouette_fit_max_radius_px) continue;
    others.clear();
    for (std::size_t j = 0; j < spheres.size(); ++j)
      if (j != i) others.push_back(spheres[j].circle);
    const std::optional<SilhouetteFit> fit = fitSilhouette(img, m.circle, others, fs);
    if (!fit) continue;
    m.circle.u = fit->circle.u, m.circle.v = fit->circle.v, m.circle.radius = fit->circle.radius;
    m.circle.sigma_u = fit->circle.sigma_u, m.circle.sigma_v = fit->circle.sigma_v;
    m.circle.sigma_radius = fit->circle.sigma_radius;
    m.silhouette_fit = true;
  }
}

double maxRadius(const SphereDetectorSettings& set, int w, int h) {
  return set.max_radius_px > 0 ? set.max_radius_px : 0.5 * std::min(w, h);
}
double minRadius(const SphereDetectorSettings& set, int w, int h) {
  return set.min_radius_px > 0 ? set.min_radius_px : std::min(w, h) / 40.0;
}
// The coarse grid's spacing: a third of the smallest radius looked for.
int coarseStep(const SphereDetectorSettings& set, int w, int h) {
  int step = set.coarse_step;
  if (step <= 0) step = std::clamp(static_cast<int>(minRadius(set, w, h) / 3.0), 1, 8);
  if (std::min(w, h) < 4 * step) step = 1;
  return step;
}

// Dark spheres on a bright field: most of the grid above half of full scale,
// and little of it clipped (a white, overexposed frame stays a bright one and
// is reported so).
bool darkSpheres(const Grid& g, int max_value) {
  std::size_t above = 0, clipped = 0;
  for (const std::uint16_t v : g.v) {
    above += 2 * static_cast<int>(v) > max_value;
    clipped += v >= max_value;
  }
  return 2 * above > g.v.size() && 5 * clipped < g.v.size();
}

// The grid of the frame's negative (max_value - level, 0 above full scale),
// as cv::subtract gives it.
Grid negativeGrid(Grid g, int max_value) {
  for (std::uint16_t& v : g.v) v = static_cast<std::uint16_t>(std::max(0, max_value - v));
  return g;
}

// The circle of the edge points, fitted where the outline is one: under a
// pinhole lens a sphere off the optical axis is an ellipse (up to ~1 % longer
// radially at the edge of a 50 mm lens' field, +-0.4 px on a 60 px sphere),
// which a circle fit would take for a pattern of outliers along the outline
// (the robust fit's search for dents would then drop a third of it and move
// the centre by tenths of a pixel). The points are mapped by the inverse of
// the outline's shape about the coarse centre (PinholeCamera::outlineShape),
// fitted, and the circle mapped back: its centre the ellipse's, its radius the
// mean of the ellipse's semi-axes, as a circle fit reports on a whole ellipse.
// `held.first` > 0: the radius is not fitted but held there (the ellipse's
// mean semi-axis with a camera), with standard uncertainty `held.second`.
// `stretches`: stretches of the outline off the circle together are left out
// (fitCircle's leave_out_stretches).
Result<CircleFit> fitOutline(std::vector<CirclePoint>& pts, const Circle& about,
                             const std::optional<PinholeCamera>& camera,
                             std::pair<double, double> held, bool stretches) {
  // Outliers beyond 3.5 robust sigmas and 0.05 px; the points are in order
  // along the outline, so a dent (a run of outliers) is searched for.
  const auto robustFit = [stretches](const std::vector<CirclePoint>& p, double r, double sigma) {
    return fitCircle(p, 3.5, 0.05, true, r, sigma, stretches);
  };
  if (!camera) return robustFit(pts, held.first, held.second);
  const Eigen::Matrix2d shape = camera->outlineShape(about.u, about.v);
  const Eigen::Matrix2d to_circle = shape.inverse();
  if (!to_circle.allFinite()) return robustFit(pts, held.first, held.second);
  const double mean_axis = 0.5 * shape.trace();
  for (CirclePoint& p : pts) {
    const Eigen::Vector2d q = to_circle * Eigen::Vector2d(p.u - about.u, p.v - about.v);
    p = {about.u + q.x(), about.v + q.y()};
  }
  Result<CircleFit> fit = robustFit(pts, held.first / mean_axis, held.second / mean_axis);
  if (!fit) return fit;
  CircleFit& f = *fit;
  const Eigen::Vector2d centre =
      Eigen::Vector2d(about.u, about.v) + shape * Eigen::Vector2d(f.u - about.u, f.v - about.v);
  const double su = f.sigma_u, sv = f.sigma_v;
  f.u = centre.x(), f.v = centre.y();
  f.sigma_u = std::hypot(shape(0, 0) * su, shape(0, 1) * sv);
  f.sigma_v = std::hypot(shape(1, 0) * su, shape(1, 1) * sv);
  f.radius *= mean_axis;
  f.sigma_radius *= mean_axis;
  return fit;
}

// `top_clips`: full scale is where the sensor clipped (false for a backlit
// frame's negative: there full scale is black, no light, the silhouette's
// true level, and the profiles into it are whole).
// The frame's levels into `out`; false (with a note) when no sphere can be
// told from its background: an overexposed frame, or nothing bright in it.
bool levelsAllowSpheres(const Levels& lv, int max_value, FrameSpheres& out) {
  out.background = lv.bg;
  out.bright = lv.bright;
  out.noise_sigma = lv.sigma;
  out.threshold = lv.threshold;
  out.low_threshold = lv.low;
  out.saturated = lv.saturated_fraction > 0.2 || lv.bg > 0.5 * max_value;
  if (lv.bg > 0.5 * max_value) {
    out.notes.emplace_back(
        "the background is brighter than half of full scale (saturated or "
        "overexposed frame): no sphere can be told from it");
    return false;
  }
  if (lv.bright - lv.bg < std::max(12.0 * lv.sigma, 0.04 * max_value)) {
    out.notes.emplace_back("no bright object in the frame (no sphere)");
    return false;
  }
  return true;
}

// What every edge profile of the frame is read against.
EdgeContext frameEdgeContext(const Levels& lv, int clip_value, const SphereDetectorSettings& set) {
  EdgeContext ctx;
  ctx.threshold = lv.threshold;
  ctx.sigma = lv.sigma;
  // Background samples above this belong to something else (the other sphere
  // at contact, glare): the profile is not used.
  ctx.dark_limit = lv.bg + std::max(5.0 * lv.sigma + 1.0, 0.1 * (lv.threshold - lv.bg));
  ctx.dark_limit = std::min(ctx.dark_limit, lv.threshold);
  ctx.min_contrast = 0.01 * (lv.bright - lv.bg);
  ctx.clip_value = clip_value;
  ctx.front_lit = clip_value != std::numeric_limits<int>::max();  // detectTyped's top_clips
  ctx.hw = std::max(1, static_cast<int>(std::ceil(set.edge_half_width_px)));
  return ctx;
}

// A sphere the coarse grid saw: its circle there, and whether it came from a
// blob of two touching spheres split in two.
// With held_radius_px > 0 the radius is held there (a sphere measured again,
// SphereDetector::measureWithRadius).
struct Candidate {
  CircleFit coarse;
  bool touching;
  double held_radius_px = 0, held_radius_sigma_px = 0;
};

// The blobs' coarse circles of a plausible radius: one per round blob, two
// for a blob that splits into a touching pair; the rest counted as ignored.
std::vector<Candidate> coarseCandidates(const std::vector<Blob>& blobs, double min_r, double max_r,
                                        int step, FrameSpheres& out) {
  const double min_cells = 0.15 * 3.14159 * min_r * min_r / (step * step);
  const auto radiusOk = [&](const CircleFit& f) {
    return f.radius >= min_r - step && f.radius <= max_r + step;
  };
  std::vector<Candidate> cands;
  for (const Blob& blob : blobs) {
    if (!blob.seeded) continue;  // a faint patch of noise or glare, nothing bright in it
    if (blob.area < std::max(3.0, min_cells)) {
      if (blob.area * step * step >= 4) ++out.blobs_ignored;
      continue;
    }
    const Result<CircleFit> single = fitCoarse(blob.outline, step);
    if (goodCoarse(single, blob.outline.size(), step) && radiusOk(*single)) {
      cands.push_back({*single, false});
      continue;
    }
    std::array<CircleFit, 2> pair;
    if (splitPair(blob, step, pair) && radiusOk(pair[0]) && radiusOk(pair[1])) {
      cands.push_back({pair[0], true});
      cands.push_back({pair[1], true});
      continue;
    }
    CircleFit part;
    if (partialDisc(blob, step, part) && radiusOk(part)) {
      cands.push_back({part, false});
      continue;
    }
    ++out.blobs_ignored;
  }
  return cands;
}

// Whether the circle reaches beyond the frame.
bool cutByBorder(const CircleFit& f, const cv::Mat& img) {
  const double r = f.radius;
  return f.u - r < -0.5 || f.v - r < -0.5 || f.u + r > img.cols - 0.5 || f.v + r > img.rows - 0.5;
}

// One candidate measured from its edge profiles (step 4 of the method); none
// (counted, with a note when its outline is unclean) when too few clean edge
// points or a radius out of range.
template <class T>
std::optional<SphereMeasurement> measureCandidate(const cv::Mat& img, const Candidate& cand,
                                                  const EdgeContext& ctx, const Levels& lv,
                                                  const SphereDetectorSettings& set, double min_r,
                                                  double max_r, int step, FrameSpheres& out) {
  const bool hold = cand.held_radius_px > 0;
  Circle c{cand.coarse.u, cand.coarse.v, hold ? cand.held_radius_px : cand.coarse.radius};
  EdgeContext local = ctx;
  // The coarse circle is good to about half a grid cell.
  local.search = step / 2 + 3 + (cand.touching ? 4 : 0);
  // Big spheres have edge points to spare: every other line halves the work
  // for a sqrt(2) larger (still tiny) noise.
  local.line_stride = set.line_stride > 0 ? set.line_stride
                                          : std::max(1, static_cast<int>(std::lround(c.r / 30.0)));
  // The limb brightness is read over up to 8 px inside, less on small spheres.
  local.n_in = std::clamp(static_cast<int>(c.r / 7.0), 3, 8);
  static_assert(8 <= kMaxInside, "the depth sums hold at most kMaxInside inside samples");
  local.quadratic = true;
  std::vector<CirclePoint> pts;
  EdgeStats st;
  // The edge points searched for around circle `around`, and the circle
  // fitted to them. The depths below the limb take its radius, as the
  // profiles' slopes across the limb do (sampleProfiles).
  const auto measureAround = [&](const Circle& around) {
    local.radius = around.r;
    pts.clear();
    st = EdgeStats{};
    edgePoints<T>(img, around, local, pts, st);
    // Only on lit spheres, whose lamp makes the terminator (a backlit
    // silhouette has none; there it moved a `collide track` velocity by 0.06 %
    // of the speed). Not on the spheres the whole-image fit measures
    // (refineSmallSpheres), which take this circle as its start only: their
    // stretches hold a handful of points each, and leaving them out made the
    // thesis' e RMS 0.0051 -> 0.0053.
    const bool stretches = local.front_lit && around.r > set.silhouette_fit_max_radius_px;
    return fitOutline(pts, around, set.camera, {cand.held_radius_px, cand.held_radius_sigma_px},
                      stretches);
  };
  Result<CircleFit> fit = measureAround(c);
  // A blob can be only part of its sphere (a limb darker than a grey
  // backdrop is not in it): its circle then sent the search for edges to the
  // wrong places on that side. When the fitted circle lies farther from it
  // than the coarse stage errs, search again around the fitted one (twice
  // at most: the second search starts from a circle fitted on both sides);
  // not for a sphere cut by the border, whose short arc moves a free fit.
  for (int again = 0;
       again < 2 && fit && fit->points >= 12 && !cutByBorder(*fit, img) &&
       std::hypot(fit->u - c.u, fit->v - c.v) + std::abs(fit->radius - c.r) > 0.5 * local.search;
       ++again) {
    c = {fit->u, fit->v, hold ? c.r : fit->radius};
    fit = measureAround(c);
  }
  if (!fit || fit->points < 12) {
    ++out.blobs_ignored;
    out.notes.push_back("a blob near (" + std::to_string(static_cast<int>(c.u)) + ", " +
                        std::to_string(static_cast<int>(c.v)) +
                        ") has too few clean edge points for a circle");
    return std::nullopt;
  }
  SphereMeasurement m;
  m.circle = *fit;
  m.touching = cand.touching;
  m.background = st.accepted ? st.sum_out / st.accepted : lv.bg;
  m.rim_level = st.accepted ? st.sum_rim / st.accepted : lv.threshold;
  m.saturated_pixels = st.saturated;
  m.border_profiles = st.border;
  const double r = fit->radius;
  m.cut_by_border = cutByBorder(*fit, img);
  if (r < min_r || r > max_r) {
    ++out.blobs_ignored;
    return std::nullopt;
  }
  return m;
}

// One sphere found twice (a blob split in two that both refine onto it):
// keep the circle with more edge points.
void dropDuplicates(std::vector<SphereMeasurement>& spheres) {
  for (std::size_t i = 0; i < spheres.size(); ++i)
    for (std::size_t j = i + 1; j < spheres.size();) {
      const CircleFit &a = spheres[i].circle, &b = spheres[j].circle;
      if (std::hypot(a.u - b.u, a.v - b.v) < 0.5 * std::min(a.radius, b.radius)) {
        if (b.points > a.points) spheres[i] = spheres[j];
        spheres.erase(spheres.begin() + static_cast<std::ptrdiff_t>(j));
      } else {
        ++j;
      }
    }
}

// Touching is decided from the final outlines: spheres whose outlines (nearly)
// meet touch even when their blobs were apart on the grid, and a blob split
// in two whose halves both refined onto one sphere (a shaded sphere with dark
// dots can look like two to the coarse fit) leaves a sphere that touches
// nothing.
void markTouching(std::vector<SphereMeasurement>& spheres, int step) {
  for (SphereMeasurement& m : spheres) m.touching = false;
  for (std::size_t i = 0; i < spheres.size(); ++i)
    for (std::size_t j = i + 1; j < spheres.size(); ++j) {
      const CircleFit &a = spheres[i].circle, &b = spheres[j].circle;
      if (std::hypot(a.u - b.u, a.v - b.v) < a.radius + b.radius + std::max(2.0, 1.0 * step))
        spheres[i].touching = spheres[j].touching = true;
    }
}

template <class T>
FrameSpheres detectTyped(const cv::Mat& img, const Grid& grid, int max_value,
                         const SphereDetectorSettings& set, bool top_clips) {
  FrameSpheres out;
  const double max_r = maxRadius(set, img.cols, img.rows);
  const double min_r = minRadius(set, img.cols, img.rows);
  const int step = grid.step;
  const int clip_value = top_clips ? max_value : std::numeric_limits<int>::max();
  const Levels lv = measureLevels(grid, max_value, clip_value);
  if (!levelsAllowSpheres(lv, max_value, out)) return out;
  const EdgeContext ctx = frameEdgeContext(lv, clip_value, set);
  const std::vector<Blob> blobs = findBlobs(grid, lv.low, lv.threshold);
  for (const Candidate& cand : coarseCandidates(blobs, min_r, max_r, step, out))
    if (auto m = measureCandidate<T>(img, cand, ctx, lv, set, min_r, max_r, step, out))
      out.spheres.push_back(*m);
  dropDuplicates(out.spheres);
  markTouching(out.spheres, step);
  refineSmallSpheres(img, set, out.spheres);
  std::sort(out.spheres.begin(), out.spheres.end(),
            [](const SphereMeasurement& a, const SphereMeasurement& b) {
              return a.circle.u < b.circle.u;
            });
  return out;
}

}  // namespace

namespace {

// Residuals of every point from circle c; returns the robust (MAD) standard
// deviation of those in use. A point out of use is given an infinite |residual|
// for the median: the median of the m in use is then the (m/2)-th smallest of
// all n, and the loop has no branch (built for AVX2 too: four square roots at
// once).
// (`scratch` two buffers of kthSmallest's.)
COLLIDE_AVX2_CLONES double residuals(const PointArrays& p, const Circle& c,
                                     std::vector<double>& res,
                                     std::array<std::vector<double>, 2>& scratch) {
  const std::size_t n = p.size();
  std::vector<double>& absr = scratch[0];
  absr.resize(n);
  const double* __restrict pu = p.u.data();
  const double* __restrict pv = p.v.data();
  const double* __restrict pw = p.w.data();
  double* __restrict out = res.data();
  double* __restrict a = absr.data();
  constexpr double kOut = std::numeric_limits<double>::infinity();
  std::size_t used = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = pu[i] - c.u, dy = pv[i] - c.v;
    const double r = std::sqrt(dx * dx + dy * dy) - c.r;
    out[i] = r;
    a[i] = pw[i] > 0 ? std::abs(r) : kOut;
    used += pw[i] > 0;
  }
  if (used == 0) return 0;
  return 1.4826 * kthSmallest(a, n, used / 2, scratch[1]);
}

// The circle through three points; false if they are (nearly) collinear.
bool circleThrough(const CirclePoint& a, const CirclePoint& b, const CirclePoint& c, Circle& out) {
  const double bx = b.u - a.u, by = b.v - a.v, cx = c.u - a.u, cy = c.v - a.v;
  const double d = 2.0 * (bx * cy - by * cx);
  if (std::abs(d) < 1e-9 * (bx * bx + by * by + cx * cx + cy * cy)) return false;
  const double b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
  const double ux = (cy * b2 - by * c2) / d, uy = (bx * c2 - cx * b2) / d;
  out = {a.u + ux, a.v + uy, std::sqrt(ux * ux + uy * uy)};
  return std::isfinite(out.r);
}

// The residuals' robust spread between neighbours along an ordered outline
// (median |res[i] - res[i-1]| as a sigma of one residual).
double neighbourSpread(const std::vector<double>& res,
                       std::array<std::vector<double>, 2>& scratch) {
  std::vector<double>& diff = scratch[0];
  diff.clear();
  for (std::size_t i = 1; i < res.size(); ++i) diff.push_back(std::abs(res[i] - res[i - 1]));
  return 1.4826 * kthSmallest(diff.data(), diff.size(), diff.size() / 2, scratch[1]) /
         std::sqrt(2.0);
}

// RANSAC: of 40 circles through triples of ordered points about a third of
// the outline apart (a fixed seed), the one most points lie within `band` of
// (`start` if none); `best` how many.
Circle bestTripleCircle(const std::vector<CirclePoint>& points, const PointArrays& pa, double band,
                        const Circle& start, int& best) {
  const std::size_t n = points.size();
  std::uint64_t state = 0x9e3779b97f4a7c15ULL ^ n;
  const auto next = [&state]() {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<std::size_t>(state >> 33);
  };
  Circle best_c = start;
  for (int trial = 0; trial < 40; ++trial) {
    const std::size_t i = next() % n;
    const std::size_t j = (i + n / 3 + next() % (n / 6 + 1)) % n;
    const std::size_t k = (i + 2 * n / 3 + next() % (n / 6 + 1)) % n;
    Circle t;
    if (!circleThrough(points[i], points[j], points[k], t)) continue;
    int count = 0;
    for (std::size_t m = 0; m < n; ++m) {
      const double dx = pa.u[m] - t.u, dy = pa.v[m] - t.v;
      count += std::abs(std::sqrt(dx * dx + dy * dy) - t.r) <= band;
    }
    if (count > best) best = count, best_c = t;
  }
  return best_c;
}

// A stretch of the outline (one of 16 sectors around the centre) whose points
// lie off the circle together, by more than 0.1 px and 4 standard errors
// (the residuals' robust spread over the root of its count), is not where the
// sphere's edge is: near the terminator, where the shadow line runs a few px
// inside the limb, a profile is a step, a plateau and a rise, which the
// shading model takes for a limb further in (0.5-5 px on sim-lab's imaging
// once the sensor's noise hides the plateau; noise-free, the shading misfit
// drops those profiles). Such stretches are left out, the worst first, the
// circle refitted after each, four at most, while half the points remain.
// `res` and `spread` are the residuals about c and their robust spread when
// `fresh`. Returns whether any was left out (res then stale).
bool dropStretchesOffTheCircle(PointArrays& pa, Circle& c, Eigen::Matrix3d& jtj, bool hold,
                               std::vector<double>& res,
                               std::array<std::vector<double>, 2>& scratch, int& kept,
                               double spread, bool fresh) {
  constexpr int kStretches = 16, kMostDropped = 4;
  constexpr double kOffPx = 0.1, kSigmas = 4.0, kSpreadFloorPx = 0.05;
  const std::size_t n = pa.size();
  std::vector<int> stretch(n);
  bool dropped = false;
  for (int round = 0; round < kMostDropped; ++round) {
    if (round > 0 || !fresh) spread = residuals(pa, c, res, scratch);
    std::array<double, kStretches> sum{};
    std::array<int, kStretches> count{};
    for (std::size_t i = 0; i < n; ++i) {
      stretch[i] = angleBin(pa.u[i] - c.u, pa.v[i] - c.v) * kStretches / kSectors;
      if (pa.w[i] > 0) sum[stretch[i]] += res[i], ++count[stretch[i]];
    }
    int worst = -1;
    double worst_z = 0;
    for (int k = 0; k < kStretches; ++k) {
      if (count[k] < 4) continue;
      const double off = std::abs(sum[k] / count[k]);
      const double z = off / (std::max(spread, kSpreadFloorPx) / std::sqrt(count[k]));
      if (off > kOffPx && z > kSigmas && z > worst_z) worst = k, worst_z = z;
    }
    if (worst < 0) break;
    int left = 0;
    for (std::size_t i = 0; i < n; ++i) left += pa.w[i] > 0 && stretch[i] != worst;
    if (2 * left < static_cast<int>(n)) break;
    const std::vector<double> w_before = pa.w;
    const Circle c_before = c;
    const Eigen::Matrix3d jtj_before = jtj;
    for (std::size_t i = 0; i < n; ++i)
      if (stretch[i] == worst) pa.w[i] = 0;
    if (!geometricFit(pa, c, jtj, hold)) {  // keep the circle before this stretch went
      pa.w = w_before, c = c_before, jtj = jtj_before;
      break;
    }
    kept = left;
    dropped = true;
  }
  return dropped;
}

// The fit's result: the circle, the points kept, their residual RMS and the
// parameters' sigmas from the Gauss-Newton normal matrix scaled by chi^2.
// With a held radius, its standard uncertainty `held_sigma` moves the centre
// by (dc/dr) sigma: added to the centre's covariance.
CircleFit fittedCircle(const PointArrays& pa, const Circle& c, const std::vector<double>& res,
                       const Eigen::Matrix3d& jtj, int kept, bool hold_radius, double held_sigma) {
  const std::size_t n = res.size();
  double ss = 0;
  for (std::size_t i = 0; i < n; ++i) ss += pa.w[i] * res[i] * res[i];
  CircleFit f;
  f.u = c.u;
  f.v = c.v;
  f.radius = c.r;
  f.points = kept;
  f.rejected = static_cast<int>(n) - kept;
  f.residual_rms = std::sqrt(ss / kept);
  const int free = hold_radius ? 2 : 3;
  const double s2 = kept > free ? ss / (kept - free) : 0.0;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  if (hold_radius) {
    const Eigen::Matrix2d a_inv = jtj.topLeftCorner<2, 2>().inverse();
    const Eigen::Vector2d dc_dr = a_inv * jtj.block<2, 1>(0, 2);
    cov.topLeftCorner<2, 2>() = a_inv * s2 + dc_dr * dc_dr.transpose() * (held_sigma * held_sigma);
    cov(2, 2) = held_sigma * held_sigma;
  } else
    cov = jtj.inverse() * s2;
  f.sigma_u = std::sqrt(std::max(0.0, cov(0, 0)));
  f.sigma_v = std::sqrt(std::max(0.0, cov(1, 1)));
  f.sigma_radius = std::sqrt(std::max(0.0, cov(2, 2)));
  return f;
}

}  // namespace

Result<CircleFit> fitCircle(const std::vector<CirclePoint>& points, double reject_sigmas,
                            double min_reject_px, bool ordered, double held_radius_px,
                            double held_radius_sigma_px, bool leave_out_stretches) {
  const std::size_t n = points.size();
  if (n < 5) return fail("circle fit: " + std::to_string(n) + " edge points; need at least 5");
  PointArrays pa(points);  // pa.w: 1 for the points in use
  Circle c;
  if (!kasaFit(pa, c)) return fail("circle fit: the edge points lie on a line");
  const bool hold = held_radius_px > 0;
  if (hold) c.r = held_radius_px;
  Eigen::Matrix3d jtj;
  if (!geometricFit(pa, c, jtj, hold)) return fail("circle fit: did not converge");
  std::vector<double> res(n);
  std::array<std::vector<double>, 2> scratch;
  scratch[0].reserve(n), scratch[1].reserve(n);
  int kept = static_cast<int>(n);
  // Drops points beyond the rejection limit and refits until nothing changes.
  double spread = 0;   // robust sigma of the residuals
  bool fresh = false;  // res and spread belong to the current circle
  const auto trim = [&]() -> Status {
    fresh = false;
    for (int round = 0; round < 4; ++round) {
      const double robust = residuals(pa, c, res, scratch);
      spread = robust;
      const double limit = std::max(reject_sigmas * robust, min_reject_px);
      bool changed = false;
      kept = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const bool keep = std::abs(res[i]) <= limit;
        changed |= keep != (pa.w[i] > 0);
        pa.w[i] = keep ? 1.0 : 0.0;
        kept += keep;
      }
      if (kept < 5) return fail("circle fit: too many outlying edge points");
      if (!changed) {
        fresh = true;
        break;
      }
      if (!geometricFit(pa, c, jtj, hold)) return fail("circle fit: did not converge");
    }
    return Ok{};
  };
  if (Status st = trim(); !st) return st.error();

  // When many points are off in one direction (dots denting a long stretch of
  // the limb), the least-squares start is pulled and trimming keeps the wrong
  // points. Points in outline order show it: neighbours agree with each other
  // far better than with the circle. Then search circles through triples of
  // points (RANSAC) for the one most points lie on, and trim from there.
  if (ordered && n >= 30) {
    if (!fresh) spread = residuals(pa, c, res, scratch);
    const double local = neighbourSpread(res, scratch);
    if (spread > 2.5 * local + 0.25 * min_reject_px) {
      const double band = std::max(3.0 * local, min_reject_px);
      int best = -1;
      const Circle best_c = bestTripleCircle(points, pa, band, c, best);
      int now = 0;
      for (std::size_t m = 0; m < n; ++m) now += std::abs(res[m]) <= band;
      if (best > now) {
        c = best_c;
        if (hold) c.r = held_radius_px;
        for (std::size_t m = 0; m < n; ++m) {
          const double dx = pa.u[m] - c.u, dy = pa.v[m] - c.v;
          pa.w[m] = std::abs(std::sqrt(dx * dx + dy * dy) - c.r) <= band ? 1.0 : 0.0;
        }
        if (!geometricFit(pa, c, jtj, hold)) return fail("circle fit: did not converge");
        if (Status st = trim(); !st) return st.error();
      }
    }
  }

  if (leave_out_stretches &&
      dropStretchesOffTheCircle(pa, c, jtj, hold, res, scratch, kept, spread, fresh))
    fresh = false;
  if (!fresh) residuals(pa, c, res, scratch);
  return fittedCircle(pa, c, res, jtj, kept, hold, held_radius_sigma_px);
}

SphereDetector::SphereDetector(SphereDetectorSettings settings) : settings_(settings) {}

namespace {

bool usableImage(const cv::Mat& image) {
  return !image.empty() && image.channels() == 1 &&
         (image.depth() == CV_8U || image.depth() == CV_16U);
}

// A backlit frame as measured: full scale less each level, saturating
// (levels above full scale give 0).
cv::Mat negativeOf(const cv::Mat& image, int max_value) {
  cv::Mat negative;
  cv::subtract(cv::Scalar(max_value), image, negative);
  return negative;
}

// The frame's levels back from what detect reported (in the frame's own grey
// levels) to those its spheres were measured against.
Levels levelsOf(const FrameSpheres& frame, int max_value) {
  Levels lv;
  const auto measured = [&](double level) {
    return frame.dark_spheres ? max_value - level : level;
  };
  lv.bg = measured(frame.background);
  lv.sigma = frame.noise_sigma;
  lv.bright = measured(frame.bright);
  lv.threshold = measured(frame.threshold);
  lv.low = measured(frame.low_threshold);
  return lv;
}

}  // namespace

FrameSpheres SphereDetector::detect(const cv::Mat& image, int max_value) const {
  if (!usableImage(image)) {
    FrameSpheres out;
    out.notes.push_back("not a one-channel 8- or 16-bit image");
    return out;
  }
  using Polarity = SphereDetectorSettings::Polarity;
  const bool bytes = image.depth() == CV_8U;
  const int step = coarseStep(settings_, image.cols, image.rows);
  const Grid grid =
      bytes ? sampleGrid<std::uint8_t>(image, step) : sampleGrid<std::uint16_t>(image, step);
  // The polarity from the grid the coarse stage reads anyway (one pass over
  // the frame's memory, not two).
  const bool dark =
      settings_.polarity == Polarity::Dark ||
      (settings_.polarity == Polarity::Auto && max_value > 0 && darkSpheres(grid, max_value));
  if (!dark) {
    if (bytes) return detectTyped<std::uint8_t>(image, grid, max_value, settings_, true);
    return detectTyped<std::uint16_t>(image, grid, max_value, settings_, true);
  }
  const cv::Mat negative = negativeOf(image, max_value);
  const Grid negative_grid = negativeGrid(grid, max_value);
  FrameSpheres out =
      bytes ? detectTyped<std::uint8_t>(negative, negative_grid, max_value, settings_, false)
            : detectTyped<std::uint16_t>(negative, negative_grid, max_value, settings_, false);
  out.dark_spheres = true;
  out.background = max_value - out.background;
  out.bright = max_value - out.bright;
  out.threshold = max_value - out.threshold;
  out.low_threshold = max_value - out.low_threshold;
  for (SphereMeasurement& m : out.spheres) {
    m.background = max_value - m.background;
    m.rim_level = max_value - m.rim_level;
  }
  return out;
}

std::optional<SphereMeasurement> SphereDetector::measureWithRadius(
    const cv::Mat& image, int max_value, const FrameSpheres& frame, const SphereMeasurement& m,
    double radius_px, double radius_sigma_px) const {
  if (!usableImage(image) || !(radius_px > 0)) return std::nullopt;
  // Against the levels detect found in this frame (not measured again).
  const Levels lv = levelsOf(frame, max_value);
  const bool dark = frame.dark_spheres;
  const cv::Mat img = dark ? negativeOf(image, max_value) : image;
  const int clip_value = dark ? std::numeric_limits<int>::max() : max_value;
  const EdgeContext ctx = frameEdgeContext(lv, clip_value, settings_);
  const Candidate again{m.circle, m.touching, radius_px, std::max(0.0, radius_sigma_px)};
  const double min_r = minRadius(settings_, img.cols, img.rows);
  const double max_r = maxRadius(settings_, img.cols, img.rows);
  const int step = coarseStep(settings_, img.cols, img.rows);
  FrameSpheres unused;  // where a rejected outline's note would go
  std::optional<SphereMeasurement> out =
      img.depth() == CV_8U ? measureCandidate<std::uint8_t>(img, again, ctx, lv, settings_, min_r,
                                                            max_r, step, unused)
                           : measureCandidate<std::uint16_t>(img, again, ctx, lv, settings_, min_r,
                                                             max_r, step, unused);
  if (!out) return std::nullopt;
  out->radius_held = true;
  if (dark) {
    out->background = max_value - out->background;
    out->rim_level = max_value - out->rim_level;
  }
  return out;
}

#undef COLLIDE_LOAD_LANES
#undef COLLIDE_TOTAL
#undef COLLIDE_LOAD_FLANES

}  // namespace collide::vision
