#include "vision/render.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>
#include <string>

#include "vision/random.hpp"

namespace collide::vision {
namespace {

using detail::splitmix64;
using detail::uniform01;

// Unit Gaussian samples; each row of a frame reads a run of them from a random
// offset. 2^18 samples (1 MiB) keep rows that share a run rare (~0.5 % of row
// pairs) while the table stays small enough to live in cache.
constexpr int kNoiseTableSize = 1 << 18;

// Edge pixels are integrated exactly along u and with this many sub-rows along
// v (midpoint rule); the disc's area per edge pixel is then good to ~1e-3 px^2
// and the centroid of a whole sphere to ~1e-3 px.
constexpr int kEdgeSubrows = 16;

// Automatic motion blur: one time sample per this much motion of the fastest
// surface point, so the smear is a near-continuous band, not visible copies.
constexpr double kBlurStepPx = 0.25;
constexpr int kMaxBlurSamples = 256;

// A visible dot of one sphere at one time sample: world-frame centre c on the
// unit sphere, the cap's extent in unit y, and the pixels its projection can touch.
struct DotInstance {
  double cx, cy, cz;
  double h2, inv_h2;  // cx^2 + cz^2 and its inverse
  double y_lo, y_hi;
  int v0, v1;  // rows its projection can touch
};

// One sphere at one time sample of the exposure.
struct SphereInstance {
  double cu, cv, radius;
  int sample;  // index of the time sample
  int v0, v1;  // rows it may touch, clipped to the frame
  int u0, u1;  // columns it may touch, clipped to the frame
  int first_dot, dot_count;
};

// floor/ceil results as pixel indices, clamped so that the cast is defined
// even for spheres far outside the frame or non-finite input.
int toIndex(double x) {
  if (!(x > -1e9)) return -1000000000;
  if (x > 1e9) return 1000000000;
  return static_cast<int>(x);
}

// Per-sub-row values of one pixel row (see drawSphereRow).
using Sub = Eigen::Array<float, kEdgeSubrows, 1>;

// (j + 0.5) / kEdgeSubrows: sub-row centres below the top edge of a pixel row.
const Sub& subrowOffsets() {
  static const Sub offsets = (Sub::LinSpaced(0.0f, kEdgeSubrows - 1.0f) + 0.5f) / kEdgeSubrows;
  return offsets;
}

// Brightness of the lit sphere at (x, y) pixels from its centre:
//   b = rim + (centre - rim) * cos^2(theta) = rim + k (1 - (x^2 + y^2) / R^2),
// theta the angle between the surface normal and the line of sight. It falls
// smoothly from the centre to a darker limb like a front-lit matte sphere, and,
// being a polynomial in x and y, its integral over any pixel or part of a pixel
// has a closed form: no sampling error, so the intensity centroid is exact.
struct Shading {
  float rim, k;
};

// Writes grey levels for columns [u0, u1] of one row:
//   round(clamp(base + sigma*noise[u] + full*signal[u], 0, full)),
// signal == nullptr meaning background only. Plain loops the compiler vectorises.
template <class T>
void writeRow(T* out, int u0, int u1, const float* noise, float sigma, float base, float full,
              const float* signal) {
  if (signal == nullptr) {
    for (int u = u0; u <= u1; ++u) {
      const float x = std::min(std::max(base + sigma * noise[u], 0.0f), full);
      out[u] = static_cast<T>(static_cast<int>(x + 0.5f));
    }
  } else {
    for (int u = u0; u <= u1; ++u) {
      const float x = std::min(std::max(base + sigma * noise[u] + full * signal[u], 0.0f), full);
      out[u] = static_cast<T>(static_cast<int>(x + 0.5f));
    }
  }
}

// The runs of the visible sub-row at height y (unit sphere, y up, half-width
// rho = sqrt(1 - y^2)) that lie in the cap around unit vector c:
// {x : f(x) = x cx + z cz >= q}, z = sqrt(rho^2 - x^2) >= 0, q = cos_a - y cy.
// Writes up to two runs as [x0, x1, x2, x3] and returns their number.
// f = q where (q - x cx)^2 = cz^2 (rho^2 - x^2), a quadratic whose roots on the
// front branch (z >= 0) are the run ends; f - q changes sign at each, so the
// runs follow from f's value at x = -rho. Degenerate cases (tangent, cz = 0)
// are caught by checking the parity against f(rho) and decided by testing
// each piece's midpoint instead, so caps over the limb come out right too.
int capRuns(const DotInstance& c, double cos_a, double y, double rho, double* out) {
  if (y < c.y_lo || y > c.y_hi) return 0;
  const double q = cos_a - y * c.cy;
  const double disc = c.h2 * rho * rho - q * q;
  if (disc <= 0) {  // |f| <= rho h never reaches q: all painted or none
    if (q > 0) return 0;
    out[0] = -rho;
    out[1] = rho;
    return 1;
  }
  const double spread = std::sqrt(disc) * std::abs(c.cz);
  double cut[4];
  int n = 0;
  cut[n++] = -rho;
  for (const double x : {(q * c.cx - spread) * c.inv_h2, (q * c.cx + spread) * c.inv_h2})
    if (x > -rho && x < rho && (q - x * c.cx) * c.cz >= 0) cut[n++] = x;
  cut[n++] = rho;

  bool in_first = -rho * c.cx >= q;  // f(-rho) = -rho cx: z = 0 at the limb
  const bool in_last = rho * c.cx >= q;
  const bool parity_ok = (in_first != in_last) == ((n - 2) % 2 == 1);
  int runs = 0;
  bool in = in_first;
  for (int i = 0; i + 1 < n; ++i, in = !in) {
    if (!parity_ok) {
      const double x = 0.5 * (cut[i] + cut[i + 1]);
      in = x * c.cx + std::sqrt(std::max(0.0, rho * rho - x * x)) * c.cz >= q;
    }
    if (!in || cut[i + 1] <= cut[i]) continue;
    if (runs > 0 && out[2 * runs - 1] == cut[i]) {
      out[2 * runs - 1] = cut[i + 1];  // continues the previous run
    } else {
      out[2 * runs] = cut[i];
      out[2 * runs + 1] = cut[i + 1];
      ++runs;
    }
  }
  return runs;
}

// One sphere instance's row, as drawSphereRow's stages share it: the sub-rows'
// heights y and half-chords w from the centre, the lit level at the chord's
// centre and the columns [t0, t1] the row touches.
struct RowGeometry {
  Sub y, w, level;
  float kr3;  // k / (3 R^2): the shading's cubic term
  double r, cu;
  int t0, t1;
};

// Paints one dot (cap) into one row: exactly along each sub-row, where the cap
// covers one or two runs, and by the sub-rows across. Painting replaces the
// lit brightness b by `dot` over those runs (sig is lowered, cov unchanged).
void paintDotRow(const DotInstance& di, double cos_dot, const RowGeometry& g, float dot, float* sig,
                 const float* cov) {
  const double r = g.r;
  const Sub& y = g.y;
  const Sub& w = g.w;
  const float kr3 = g.kr3;
  const int t0 = g.t0, t1 = g.t1;
  const Sub paint_level = g.level - dot;
  Sub a0 = Sub::Zero(), b0 = Sub::Zero(), a1 = Sub::Zero(), b1 = Sub::Zero();
  double hull_a = r, hull_b = -r;    // union of all runs in the row
  double inner_a = -r, inner_b = r;  // common part of all runs: pixels fully painted
  for (int j = 0; j < kEdgeSubrows; ++j) {
    double x[4];
    const int runs = w[j] > 0 ? capRuns(di, cos_dot, -y[j] / r, w[j] / r, x) : 0;
    if (runs == 1) {
      inner_a = std::max(inner_a, x[0] * r);
      inner_b = std::min(inner_b, x[1] * r);
    } else {
      inner_a = r, inner_b = -r;
    }
    if (runs == 0) continue;
    hull_a = std::min(hull_a, x[0] * r);
    hull_b = std::max(hull_b, x[2 * runs - 1] * r);
    a0[j] = static_cast<float>(x[0] * r);
    b0[j] = static_cast<float>(x[1] * r);
    if (runs == 2) {
      a1[j] = static_cast<float>(x[2] * r);
      b1[j] = static_cast<float>(x[3] * r);
    }
  }
  if (hull_a >= hull_b) return;
  const bool two_runs = (a1 != b1).any();
  const int u_lo = std::max(t0, toIndex(std::floor(g.cu + hull_a + 0.5)));
  const int u_hi = std::min(t1, toIndex(std::ceil(g.cu + hull_b - 0.5)));
  for (int u = u_lo; u <= u_hi; ++u) {
    const float xl = static_cast<float>(u - 0.5 - g.cu);
    if (cov[u] >= 1.0f && xl >= inner_a && xl + 1.0f <= inner_b) {
      sig[u] = dot;  // wholly painted, wholly on the disc
      continue;
    }
    Sub xa = a0.max(xl), xb = b0.min(xl + 1.0f).max(xa);
    float paint = ((xb - xa) * paint_level - kr3 * (xb.cube() - xa.cube())).sum();
    if (two_runs) {
      xa = a1.max(xl);
      xb = b1.min(xl + 1.0f).max(xa);
      paint += ((xb - xa) * paint_level - kr3 * (xb.cube() - xa.cube())).sum();
    }
    sig[u] -= paint * (1.0f / kEdgeSubrows);
  }
}

// Draws one row of one sphere instance into sig/cov for the columns it touches
// and returns them as [lo, hi] (lo > hi: none). cov[u] is the fraction of pixel
// u covered by the disc; sig[u] the integral of brightness over the covered
// part divided by the pixel area (so a pixel's value is bg*(1-cov) + sig).
void drawSphereRow(const SphereInstance& s, const DotInstance* dots, int v, const Shading& shade,
                   float dot_level, double cos_dot, int width, float* sig, float* cov, int& lo,
                   int& hi) {
  lo = 1;
  hi = 0;
  const double r = s.radius;
  const double r2 = r * r;
  const double dy0 = v - 0.5 - s.cv;  // top and bottom of the pixel row, from the centre
  const double dy1 = v + 0.5 - s.cv;
  if (dy0 >= r || dy1 <= -r) return;
  const double min_abs = (dy0 <= 0 && dy1 >= 0) ? 0.0 : std::min(std::abs(dy0), std::abs(dy1));
  const double max_abs = std::max(std::abs(dy0), std::abs(dy1));
  const double w_hi = std::sqrt(r2 - min_abs * min_abs);  // widest chord within the row

  // Columns touched: pixel [u-0.5, u+0.5] meets (cu - w_hi, cu + w_hi).
  const int t0 = std::max(0, toIndex(std::floor(s.cu - w_hi - 0.5)) + 1);
  const int t1 = std::min(width - 1, toIndex(std::ceil(s.cu + w_hi + 0.5)) - 1);
  if (t0 > t1) return;
  lo = t0;
  hi = t1;

  // Columns fully inside: the pixel's corners farthest from the centre lie
  // within the narrowest chord of the row.
  int i0 = t1 + 1, i1 = t1;
  if (max_abs < r) {
    const double w_lo = std::sqrt(r2 - max_abs * max_abs);
    i0 = std::max(t0, toIndex(std::ceil(s.cu - w_lo + 0.5)));
    i1 = std::min(t1, toIndex(std::floor(s.cu + w_lo - 0.5)));
    if (i0 > i1) i0 = t1 + 1, i1 = t1;
  }

  const float inv_r2 = static_cast<float>(1.0 / r2);
  const float rim = shade.rim, k = shade.k;

  // Interior: exact pixel average of b, using mean(x^2) over a pixel = x_c^2 + 1/12.
  if (i0 <= i1) {
    const float dy = static_cast<float>(v - s.cv);
    const float a = rim + k * (1.0f - (dy * dy + 1.0f / 6.0f) * inv_r2);
    const float kr = k * inv_r2;
    const float dx0 = static_cast<float>(i0 - s.cu);
    const int n = i1 - i0 + 1;
    float* sg = sig + i0;
    float* cv = cov + i0;
    for (int i = 0; i < n; ++i) {
      const float dx = dx0 + static_cast<float>(i);
      sg[i] = a - kr * dx * dx;
      cv[i] = 1.0f;
    }
  }

  // Edge pixels: per sub-row, the covered run [xa, xb] is exact and the
  // integral of b along it is a cubic. Sub-rows are held in fixed-size Eigen
  // arrays so the sums vectorise; an empty sub-row or run is [0, 0], which
  // clamps to zero length for any pixel.
  // y_j: sub-row centres from the sphere's centre. w^2 = (R - y)(R + y) keeps
  // the tangent sub-rows accurate in float.
  const Sub y = static_cast<float>(dy0) + subrowOffsets();
  const float rf = static_cast<float>(r);
  const Sub w = ((rf - y) * (rf + y)).max(0.0f).sqrt();
  const Sub level = rim + k * (1.0f - y.square() * inv_r2);  // rim + k (1 - y_j^2 / R^2)
  const Sub neg_w = -w;
  const float kr3 = k * inv_r2 / 3.0f;
  const auto edge = [&](int u) {
    const float xl = static_cast<float>(u - 0.5 - s.cu);
    const Sub xa = neg_w.max(xl);
    const Sub xb = w.min(xl + 1.0f).max(xa);
    const Sub len = xb - xa;
    cov[u] = len.sum() * (1.0f / kEdgeSubrows);
    sig[u] = (len * level - kr3 * (xb.cube() - xa.cube())).sum() * (1.0f / kEdgeSubrows);
  };
  if (i0 > i1) {
    for (int u = t0; u <= t1; ++u) edge(u);
  } else {
    for (int u = t0; u < i0; ++u) edge(u);
    for (int u = i1 + 1; u <= t1; ++u) edge(u);
  }

  // Dots, integrated like the disc edge; painting replaces the lit brightness.
  const RowGeometry g{y, w, level, kr3, r, s.cu, t0, t1};
  for (int d = 0; d < s.dot_count; ++d) {
    const DotInstance& di = dots[s.first_dot + d];
    if (v >= di.v0 && v <= di.v1) paintDotRow(di, cos_dot, g, dot_level, sig, cov);
  }
}

// Time samples over the exposure: one per kBlurStepPx of the fastest surface
// point's motion (or RenderSettings::blur_samples), 1 without exposure.
int blurSamples(const RenderSettings& st, const std::vector<SphereView>& spheres) {
  if (!(st.exposure_s > 0)) return 1;
  if (st.blur_samples > 0) return st.blur_samples;
  double fastest_px = 0;
  for (const SphereView& sv : spheres)
    fastest_px =
        std::max(fastest_px,
                 (sv.velocity_px_s.norm() + sv.spin_rad_s.norm() * sv.radius_px) * st.exposure_s);
  if (!(fastest_px >= 0)) return 1;  // NaN motion: draw it still
  return static_cast<int>(
      std::clamp(std::ceil(fastest_px / kBlurStepPx), 1.0, double{kMaxBlurSamples}));
}

// Appends the visible dots of sphere `sv` at time t (s from mid-exposure),
// drawn as instance `si`; returns cos of the dots' angular radius (1: none).
double appendDotInstances(const SphereView& sv, const SphereInstance& si, double t,
                          std::vector<DotInstance>& dots) {
  if (sv.dots == nullptr || sv.dots->centres.empty()) return 1.0;
  const double r = si.radius;
  const double alpha = sv.dots->angular_radius_rad;
  const double sin_a = std::sin(alpha);
  Eigen::Matrix3d rot = sv.orientation.normalized().toRotationMatrix();
  const double spin = sv.spin_rad_s.norm();
  if (spin > 0 && t != 0)
    rot = Eigen::AngleAxisd(spin * t, sv.spin_rad_s / spin).toRotationMatrix() * rot;
  for (const Vec3& cb : sv.dots->centres) {
    const Vec3 c = rot * cb.normalized();
    if (c.z() <= -sin_a) continue;  // cap entirely on the far hemisphere
    // The cap spans polar angles phi -+ a from world +y, phi = acos(c_y),
    // clipped at the poles (a cap may contain one).
    const double phi = std::acos(std::clamp(c.y(), -1.0, 1.0));
    DotInstance d{};
    d.cx = c.x();
    d.cy = c.y();
    d.cz = c.z();
    d.h2 = c.x() * c.x() + c.z() * c.z();
    d.inv_h2 = d.h2 > 0 ? 1.0 / d.h2 : 0.0;
    d.y_lo = std::cos(std::min(phi + alpha, std::numbers::pi));
    d.y_hi = std::cos(std::max(phi - alpha, 0.0));
    // Rows whose pixels meet the cap's box; runs are exact, so no margin.
    d.v0 = toIndex(std::floor(si.cv - r * d.y_hi - 0.5)) + 1;
    d.v1 = toIndex(std::ceil(si.cv - r * d.y_lo + 0.5)) - 1;
    dots.push_back(d);
  }
  return std::cos(alpha);
}

// Every sphere at every time sample (symmetric about mid-exposure, t = 0, so
// the blurred image's centroid is the mid-exposure position), with its dots.
struct Instances {
  std::vector<SphereInstance> inst;
  std::vector<DotInstance> dots;
  std::vector<double> cos_dot;  // cos(dot angular radius), per instance
};

Instances layOutInstances(const std::vector<SphereView>& spheres, int samples,
                          const RenderSettings& st) {
  Instances out;
  out.inst.reserve(static_cast<std::size_t>(samples) * spheres.size());
  for (int j = 0; j < samples; ++j) {
    const double t = samples == 1 ? 0.0 : st.exposure_s * ((j + 0.5) / samples - 0.5);
    for (const SphereView& sv : spheres) {
      SphereInstance si{};
      si.radius = sv.radius_px;
      si.sample = j;
      si.cu = sv.centre_px.x() + sv.velocity_px_s.x() * t;
      si.cv = sv.centre_px.y() + sv.velocity_px_s.y() * t;
      si.first_dot = static_cast<int>(out.dots.size());
      const double r = si.radius;
      if (!(r > 0) || !std::isfinite(r) || !std::isfinite(si.cu) || !std::isfinite(si.cv))
        continue;  // nothing to draw
      si.v0 = std::max(0, toIndex(std::floor(si.cv - r - 0.5)) + 1);
      si.v1 = std::min(st.height - 1, toIndex(std::ceil(si.cv + r + 0.5)) - 1);
      si.u0 = std::max(0, toIndex(std::floor(si.cu - r - 0.5)) + 1);
      si.u1 = std::min(st.width - 1, toIndex(std::ceil(si.cu + r + 0.5)) - 1);
      if (si.v0 > si.v1 || si.u0 > si.u1) continue;  // wholly outside the frame
      const double cosd = appendDotInstances(sv, si, t, out.dots);
      si.dot_count = static_cast<int>(out.dots.size()) - si.first_dot;
      out.inst.push_back(si);
      out.cos_dot.push_back(cosd);
    }
  }
  return out;
}

// Adds one row's sphere instances (`active`, indices into in.inst, grouped by
// time sample) into acc = buf[0, width): the mean over samples of
// (pixel - background). buf holds 4 rows of width floats; the other three are
// scratch.
struct RowCompositor {
  const Instances& in;
  Shading shade;
  float dot_level, bg, weight;
  int width;

  void compose(const std::vector<int>& active, int v, float* buf) const {
    float* acc = buf;
    float* tmp = acc + width;  // one sample's (pixel - background), when spheres overlap
    float* sig = tmp + width;  // one sphere instance's row, see drawSphereRow
    float* cov = sig + width;
    // Within a sample spheres that share columns are composited front-to-back
    // in list order (later in front), otherwise their contributions simply add.
    std::size_t a = 0;
    while (a < active.size()) {
      const int sample = in.inst[active[a]].sample;
      std::size_t b = a;
      int lo = width, hi = -1;
      bool overlap = false;
      while (b < active.size() && in.inst[active[b]].sample == sample) {
        const SphereInstance& s = in.inst[active[b]];
        if (s.u0 <= hi && s.u1 >= lo) overlap = true;
        lo = std::min(lo, s.u0);
        hi = std::max(hi, s.u1);
        ++b;
      }
      if (overlap) std::fill(tmp + lo, tmp + hi + 1, 0.0f);
      for (std::size_t i = a; i < b; ++i) {
        const SphereInstance& s = in.inst[active[i]];
        int r0, r1;
        drawSphereRow(s, in.dots.data(), v, shade, dot_level, in.cos_dot[active[i]], width, sig,
                      cov, r0, r1);
        if (overlap) {
          for (int u = r0; u <= r1; ++u) tmp[u] = tmp[u] * (1.0f - cov[u]) + sig[u] - cov[u] * bg;
        } else {
          for (int u = r0; u <= r1; ++u) acc[u] += weight * (sig[u] - cov[u] * bg);
        }
      }
      if (overlap)
        for (int u = lo; u <= hi; ++u) acc[u] += weight * tmp[u];
      a = b;
    }
  }
};

}  // namespace

DotPattern DotPattern::random(std::uint64_t seed, double dot_diameter_fraction, double coverage) {
  if (!(dot_diameter_fraction > 0 && dot_diameter_fraction < 1) || !(coverage > 0 && coverage < 1))
    throw std::invalid_argument(
        "DotPattern::random: need 0 < dot_diameter_fraction < 1 and "
        "0 < coverage < 1");
  DotPattern p;
  // A dot of diameter d seen face-on is the cap whose rim circle has diameter
  // d: sin(alpha) = d / D.
  const double alpha = std::asin(dot_diameter_fraction);
  p.angular_radius_rad = alpha;
  const double cap_area_fraction = 0.5 * (1.0 - std::cos(alpha));
  const int count =
      static_cast<int>(std::clamp(std::round(coverage / cap_area_fraction), 1.0, 10000.0));
  // At least one dot radius of bare paint between neighbours, so dots stay
  // separate blobs in the image even somewhat foreshortened.
  const double min_separation_cos = std::cos(std::min(3.0 * alpha, std::numbers::pi));

  std::uint64_t state = seed ^ 0x2545f4914f6cdd1dULL;
  // Random sequential placement; dense requests (which cannot all fit) stop
  // after a bounded number of tries with as many dots as were placed.
  const int max_tries = 100 * count + 10000;
  for (int t = 0; t < max_tries && static_cast<int>(p.centres.size()) < count; ++t) {
    const double z = 2.0 * uniform01(state) - 1.0;  // uniform z and azimuth: uniform on the sphere
    const double phi = 2.0 * std::numbers::pi * uniform01(state);
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Vec3 c(rho * std::cos(phi), rho * std::sin(phi), z);
    const bool apart = std::all_of(p.centres.begin(), p.centres.end(),
                                   [&](const Vec3& o) { return c.dot(o) < min_separation_cos; });
    if (apart) p.centres.push_back(c);
  }
  return p;
}

Renderer::Renderer(RenderSettings settings) : settings_(settings) {
  const RenderSettings& s = settings_;
  if (s.width <= 0 || s.height <= 0 || !(s.exposure_s >= 0) || s.blur_samples < 0 ||
      !(s.noise_grey >= 0))
    throw std::invalid_argument(
        "Renderer: need width, height > 0 and exposure_s, blur_samples, "
        "noise_grey >= 0");
  if (s.noise_grey > 0) {
    // Box-Muller from splitmix64, so a seed gives the same noise everywhere.
    noise_table_.resize(static_cast<std::size_t>(kNoiseTableSize) + s.width);
    std::uint64_t state = s.noise_seed;
    for (std::size_t i = 0; i < noise_table_.size(); i += 2) {
      const double u1 = 1.0 - uniform01(state);  // (0, 1]: log stays finite
      const double u2 = uniform01(state);
      const double m = std::sqrt(-2.0 * std::log(u1));
      noise_table_[i] = static_cast<float>(m * std::cos(2.0 * std::numbers::pi * u2));
      if (i + 1 < noise_table_.size())
        noise_table_[i + 1] = static_cast<float>(m * std::sin(2.0 * std::numbers::pi * u2));
    }
  } else {
    noise_table_.assign(static_cast<std::size_t>(s.width), 0.0f);  // one row, read at offset 0
  }
  // The same rounding as writeRow, so background pixels are identical whether
  // copied from here or computed next to a sphere.
  const float full = static_cast<float>(maxValue(s.format));
  const float base = static_cast<float>(s.background_level) * full;
  const float sigma = static_cast<float>(s.noise_grey);
  const int n = static_cast<int>(noise_table_.size());
  if (s.format == PixelFormat::Mono8) {
    background_table_.resize(n);
    writeRow(background_table_.data(), 0, n - 1, noise_table_.data(), sigma, base, full, nullptr);
  } else {
    std::vector<std::uint16_t> words(n);
    writeRow(words.data(), 0, n - 1, noise_table_.data(), sigma, base, full, nullptr);
    background_table_.resize(2 * static_cast<std::size_t>(n));
    std::memcpy(background_table_.data(), words.data(), background_table_.size());
  }
  if (settings_.imaging) {
    settings_.imaging->lighting.lamp_direction.normalize();
    imaging_ = makeImagingTables(settings_);
  }
}

cv::Mat Renderer::render(const std::vector<SphereView>& spheres, std::uint64_t frame_index,
                         double time_s) const {
  if (settings_.imaging) return renderImaging(spheres, frame_index, time_s);
  const RenderSettings& st = settings_;
  const int width = st.width, height = st.height;
  const float full = static_cast<float>(maxValue(st.format));
  const int samples = blurSamples(st, spheres);
  const Instances in = layOutInstances(spheres, samples, st);
  const RowCompositor comp{
      in,
      Shading{static_cast<float>(st.rim_level), static_cast<float>(st.sphere_level - st.rim_level)},
      static_cast<float>(st.dot_level),
      static_cast<float>(st.background_level),
      1.0f / static_cast<float>(samples),
      width};

  cv::Mat image(height, width, cvType(st.format));
  std::vector<float> buf(4 * static_cast<std::size_t>(width), 0.0f);
  const float base = comp.bg * full;
  const bool noisy = st.noise_grey > 0;
  const float sigma = static_cast<float>(st.noise_grey);

  // Per-frame stream of row offsets into the noise table, from (seed, frame).
  std::uint64_t rng = st.noise_seed ^ (frame_index * 0xd1b54a32d192ed03ULL) ^ 0x8bb84b93962eacc9ULL;
  splitmix64(rng);
  std::vector<int> active;
  active.reserve(in.inst.size());

  const std::size_t pixel_bytes = image.elemSize();
  for (int v = 0; v < height; ++v) {
    std::size_t offset = 0;
    if (noisy) offset = splitmix64(rng) % kNoiseTableSize;
    const float* noise = noise_table_.data() + offset;

    active.clear();
    int span0 = width, span1 = -1;
    for (int i = 0; i < static_cast<int>(in.inst.size()); ++i) {
      if (v < in.inst[i].v0 || v > in.inst[i].v1) continue;
      active.push_back(i);
      span0 = std::min(span0, in.inst[i].u0);
      span1 = std::max(span1, in.inst[i].u1);
    }
    float* acc = buf.data();  // mean over samples of (pixel - background)
    if (!active.empty()) {
      std::fill(acc + span0, acc + span1 + 1, 0.0f);
      comp.compose(active, v, buf.data());
    }

    // Plain background from the table, then the columns near spheres on top.
    std::memcpy(image.ptr(v), background_table_.data() + offset * pixel_bytes,
                static_cast<std::size_t>(width) * pixel_bytes);
    if (!active.empty()) {
      if (st.format == PixelFormat::Mono8)
        writeRow(image.ptr<std::uint8_t>(v), span0, span1, noise, sigma, base, full, acc);
      else
        writeRow(image.ptr<std::uint16_t>(v), span0, span1, noise, sigma, base, full, acc);
    }
  }
  return image;
}

}  // namespace collide::vision
