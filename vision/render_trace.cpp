// The ray-cast renderer's tracing stages (render_trace.hpp): the nearest
// sphere along each ray of a batch, the edges' clearance, the surface, the
// dots, the shading; and one row's centre and sub-pixel rays through them.
#include "vision/render_trace.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <type_traits>

namespace collide::vision::raycast {

namespace {

// Brightness (fraction of full scale, before the sensor) of a sphere's
// surface point, Lambert plus Blinn-Phong, or the backlit silhouette.
// Highlights fainter than this (fraction of full scale, a 15th of a 16-bit
// grey level) are not computed: n.h below the matching cosine skips pow().
constexpr double kFaintestHighlight = 1e-6;

}  // namespace

Shading shadingFor(const Lighting& l, const Optics& o) {
  Shading s;
  s.inv_focal_px = static_cast<float>(1.0 / o.focal_px);
  s.lighting = &l;
  s.nh_min = static_cast<float>(
      l.specular_strength > 0
          ? std::pow(kFaintestHighlight / l.specular_strength, 1.0 / l.specular_exponent)
          : 2.0);
  if (l.specular_exponent >= 1 && l.specular_exponent <= 1024 &&
      l.specular_exponent == std::floor(l.specular_exponent))
    s.int_exponent = static_cast<int>(l.specular_exponent);
  s.spot_cos =
      static_cast<float>(std::sqrt(std::max(0.0, 1.0 - l.spot_fraction * l.spot_fraction)));
  return s;
}

namespace {

// The stages' loops are written without branches (bitwise & and |, selects)
// so that they vectorise; Persp picks the camera model at compile time.

// A sphere's centre in the terms the rays use: perspective, from the optical
// centre (Instance::rel); orthographic, in the world.
struct CentreF {
  float x, y, z;
};

CentreF centreFor(const Tracer& tr, const Instance& in) {
  const Vec3& c = tr.persp ? in.rel : in.centre;
  return {static_cast<float>(c.x()), static_cast<float>(c.y()), static_cast<float>(c.z())};
}

// The arrays a loop reads and writes are distinct (RayBatch's members): tells
// the vectoriser, which otherwise gives up checking that many pairs at run time.
#if defined(__clang__) && (__has_feature(address_sanitizer) || __has_feature(thread_sanitizer))
// Instrumented loads and stores do not vectorise: asking would only make
// clang report every loop it could not.
#define COLLIDE_INDEPENDENT_ITERATIONS
#elif defined(__clang__)
#define COLLIDE_INDEPENDENT_ITERATIONS _Pragma("clang loop vectorize(assume_safety)")
#else
#define COLLIDE_INDEPENDENT_ITERATIONS _Pragma("GCC ivdep")
#endif

// max(x, 0) by value: std::max returns a reference, whose select the
// vectoriser cannot if-convert.
inline float positive(float x) {
  return x > 0.0f ? x : 0.0f;
}

// Stage 1: the nearest sphere along each ray (best, t).
template <bool Persp>
COLLIDE_SIMD_CLONES void nearestHits(const Tracer& tr, const std::vector<const Instance*>& group,
                                     RayBatch& b) {
  const int n = b.size();
  const int* col = b.col.data();
  const float *x = b.x.data(), *y = b.y.data(), *z = b.z.data();
  int* best = b.best.data();
  float* t = b.t.data();
  COLLIDE_INDEPENDENT_ITERATIONS
  for (int i = 0; i < n; ++i) best[i] = -1, t[i] = std::numeric_limits<float>::infinity();
  for (int k = 0; k < static_cast<int>(group.size()); ++k) {
    const Instance& in = *group[k];
    const int u0 = in.u0, u1 = in.u1;
    const float r2 = static_cast<float>(in.radius * in.radius);
    const CentreF c = centreFor(tr, in);
    const auto [lo, hi] = b.columns(u0, u1);
    COLLIDE_INDEPENDENT_ITERATIONS
    for (int i = lo; i < hi; ++i) {
      float perp2, tk;
      int front = 1;
      if constexpr (Persp) {
        const float px = y[i] * c.z - z[i] * c.y, py = z[i] * c.x - x[i] * c.z,
                    pz = x[i] * c.y - y[i] * c.x;
        perp2 = px * px + py * py + pz * pz;
        const float along = x[i] * c.x + y[i] * c.y + z[i] * c.z;
        front = along > 0;
        tk = along - std::sqrt(positive(r2 - perp2));
      } else {
        const float dx = x[i] - c.x, dy = y[i] - c.y;
        perp2 = dx * dx + dy * dy;
        tk = -(c.z + std::sqrt(positive(r2 - perp2)));
      }
      const int take = (col[i] >= u0) & (col[i] <= u1) & front & (perp2 < r2) & (tk < t[i]);
      t[i] = take ? tk : t[i];
      best[i] = take ? k : best[i];
    }
  }
}

// Stage 1b: whether each ray is kSmoothMarginPx clear of every silhouette
// edge (inside the nearest sphere, outside the others), into smooth.
template <bool Persp>
COLLIDE_SIMD_CLONES void edgesClear(const Tracer& tr, const std::vector<const Instance*>& group,
                                    RayBatch& b) {
  const int n = b.size();
  const int* col = b.col.data();
  const float *x = b.x.data(), *y = b.y.data(), *z = b.z.data();
  const int* best = b.best.data();
  int* smooth = b.smooth.data();
  COLLIDE_INDEPENDENT_ITERATIONS
  for (int i = 0; i < n; ++i) smooth[i] = 1;
  for (int k = 0; k < static_cast<int>(group.size()); ++k) {
    const Instance& in = *group[k];
    const int u0 = in.u0, u1 = in.u1;
    const float in_thr = in.in_thr, out_thr = in.out_thr;
    const int behind_clear = in.behind_clear;
    const CentreF c = centreFor(tr, in);
    const auto [lo, hi] = b.columns(u0, u1);
    COLLIDE_INDEPENDENT_ITERATIONS
    for (int i = lo; i < hi; ++i) {
      float perp2;
      int front = 1;
      if constexpr (Persp) {
        const float px = y[i] * c.z - z[i] * c.y, py = z[i] * c.x - x[i] * c.z,
                    pz = x[i] * c.y - y[i] * c.x;
        perp2 = px * px + py * py + pz * pz;
        front = x[i] * c.x + y[i] * c.y + z[i] * c.z > 0;
      } else {
        const float dx = x[i] - c.x, dy = y[i] - c.y;
        perp2 = dx * dx + dy * dy;
      }
      const int inside = front & (perp2 < in_thr);
      const int outside = (perp2 > out_thr) | ((front ^ 1) & behind_clear);
      const int clear = best[i] == k ? inside : outside;
      const int outbox = (col[i] < u0) | (col[i] > u1);
      smooth[i] &= outbox | clear;
    }
  }
}

// Stage 2: the surface where each ray hits (normal, n.view); with
// `smooth_test`, clears smooth where the surface's features make the pixel
// rough: within the surface angle a pixel spans (delta) of the terminator or
// a backlit spot's rim, or at the limb. A pixel's corners are 0.71 px from
// its centre: on the surface, at most 0.71 lateral / (R cos(view angle)) rad,
// lateral the size a pixel spans across the line of sight there. Written as
// products: |x| < delta <=> |x| R nv < lateral. Bounds on cos and sin make
// each band at least as wide as the exact one. Sets the dot rim band (far,
// near: cos(dot radius -+ delta), bounded by cos d >= 1 - d^2/2, sin d <= d;
// empty without the smoothness test) for stage 3.
template <bool Persp>
COLLIDE_SIMD_CLONES void surface(const Tracer& tr, const std::vector<const Instance*>& group,
                                 RayBatch& b, bool smooth_test) {
  const int lo = b.lo, hi = b.hi;
  const Lighting& l = *tr.sh.lighting;
  const float lx = static_cast<float>(l.lamp_direction.x()),
              ly = static_cast<float>(l.lamp_direction.y()),
              lz = static_cast<float>(l.lamp_direction.z());
  // Written without branches (integer & and |, blends) so that it vectorises.
  const int terminator = smooth_test && l.mode == Lighting::Mode::Front;
  const int spot_rim = smooth_test && l.mode == Lighting::Mode::Back && l.spot_level > 0;
  const float spot_sin = static_cast<float>(l.spot_fraction);
  const float inv_f = tr.sh.inv_focal_px;
  const float pixel_m = static_cast<float>(tr.st.imaging->optics.pixel_size_m);
  const float *x = b.x.data(), *y = b.y.data(), *z = b.z.data(), *t = b.t.data();
  const int* best = b.best.data();
  float *nx = b.nx.data(), *ny = b.ny.data(), *nz = b.nz.data(), *nv = b.nv.data(),
        *far = b.far.data(), *near = b.near.data();
  int* smooth = b.smooth.data();
  COLLIDE_INDEPENDENT_ITERATIONS
  for (int i = lo; i < hi; ++i) nx[i] = ny[i] = nz[i] = nv[i] = far[i] = near[i] = 0.0f;
  // Only an instance's own rays take its values: blends by m = 0 or 1, exact
  // for finite values (a select would be a conditional store, which does not
  // vectorise).
  for (int k = 0; k < static_cast<int>(group.size()); ++k) {
    const Instance& in = *group[k];
    const float inv_r = static_cast<float>(in.inv_radius), r = static_cast<float>(in.radius);
    const float r2 = r * r;
    const CentreF c = centreFor(tr, in);
    const auto [first, last] = b.columns(in.u0, in.u1);
    COLLIDE_INDEPENDENT_ITERATIONS
    for (int i = first; i < last; ++i) {
      float ax, ay, az, anv;
      if constexpr (Persp) {
        // The hit from the centre, t d - rel = -(c1 x d) - s d with c1 = d x
        // rel and s = sqrt(r^2 - |c1|^2): every term is of the sphere's size,
        // so floats keep the normal to ~1e-7 (t d - rel itself would lose
        // three digits to cancellation).
        const float c1x = y[i] * c.z - z[i] * c.y, c1y = z[i] * c.x - x[i] * c.z,
                    c1z = x[i] * c.y - y[i] * c.x;
        const float s = std::sqrt(positive(r2 - (c1x * c1x + c1y * c1y + c1z * c1z)));
        ax = -(c1y * z[i] - c1z * y[i] + s * x[i]) * inv_r;
        ay = -(c1z * x[i] - c1x * z[i] + s * y[i]) * inv_r;
        az = -(c1x * y[i] - c1y * x[i] + s * z[i]) * inv_r;
        anv = -(ax * x[i] + ay * y[i] + az * z[i]);
      } else {
        ax = (x[i] - c.x) * inv_r, ay = (y[i] - c.y) * inv_r;
        az = std::sqrt(positive(1.0f - ax * ax - ay * ay));
        anv = az;
      }
      const float m = static_cast<float>(best[i] == k), o = 1.0f - m;
      nx[i] = m * ax + o * nx[i], ny[i] = m * ay + o * ny[i], nz[i] = m * az + o * nz[i];
      nv[i] = m * anv + o * nv[i];
    }
  }
  if (!smooth_test) return;
  for (int k = 0; k < static_cast<int>(group.size()); ++k) {
    const Instance& in = *group[k];
    const float r = static_cast<float>(in.radius);
    const float dots = in.dots != nullptr ? 1.0f : 0.0f;
    const float cos_dot = static_cast<float>(in.cos_dot), sin_dot = static_cast<float>(in.sin_dot);
    const auto [first, last] = b.columns(in.u0, in.u1);
    COLLIDE_INDEPENDENT_ITERATIONS
    for (int i = first; i < last; ++i) {
      const float lateral = Persp ? t[i] * inv_f : pixel_m;
      const float r_nv = r * nv[i];
      const float ndl = nx[i] * lx + ny[i] * ly + nz[i] * lz;
      const int rough = (nv[i] < 0.05f) | (terminator & (std::abs(ndl) * r_nv < lateral));
      // (delta beyond 4 rad: every rim is near; kept finite for the blend.)
      const float ratio = lateral / (r_nv > 1e-30f ? r_nv : 1e-30f);
      const float reach = dots * (ratio < 4.0f ? ratio : 4.0f);
      const int mine = best[i] == k;
      const float m = static_cast<float>(mine), o = 1.0f - m;
      smooth[i] &= (mine & rough) ^ 1;
      far[i] = m * (cos_dot * (1.0f - 0.5f * reach * reach) - sin_dot * reach) + o * far[i];
      near[i] = m * (cos_dot + sin_dot * reach) + o * near[i];
    }
    if (!spot_rim) continue;
    COLLIDE_INDEPENDENT_ITERATIONS
    for (int i = first; i < last; ++i) {
      const float lateral = Persp ? t[i] * inv_f : pixel_m;
      const float sin_view = std::sqrt(positive(1.0f - nv[i] * nv[i]));
      const int rough = std::abs(sin_view - spot_sin) * r * nv[i] < lateral;
      smooth[i] &= ((best[i] == k) & rough) ^ 1;
    }
  }
}

// Stage 3: on a dot, and (through the band from stage 2) near a dot's rim.
COLLIDE_SIMD_CLONES
void dotCover(const std::vector<const Instance*>& group, RayBatch& b) {
  const int n = b.size();
  const int* best = b.best.data();
  const float *nx = b.nx.data(), *ny = b.ny.data(), *nz = b.nz.data(), *far = b.far.data(),
              *near = b.near.data();
  int *on = b.on_dot.data(), *rim = b.near_rim.data();
  COLLIDE_INDEPENDENT_ITERATIONS
  for (int i = 0; i < n; ++i) on[i] = 0, rim[i] = 0;
  for (int k = 0; k < static_cast<int>(group.size()); ++k) {
    const Instance& in = *group[k];
    if (in.dots == nullptr) continue;
    const float cos_dot = static_cast<float>(in.cos_dot);
    const DotSet& d = *in.dots;
    for (std::size_t j = 0; j < d.x.size(); ++j) {
      // Only the rays in the dot's pixel box can be on it or near its rim.
      if (b.v < d.v0[j] || b.v > d.v1[j]) continue;
      const auto [lo, hi] = b.columns(d.u0[j], d.u1[j]);
      const float dx = d.x[j], dy = d.y[j], dz = d.z[j];
      COLLIDE_INDEPENDENT_ITERATIONS
      for (int i = lo; i < hi; ++i) {
        const float cd = dx * nx[i] + dy * ny[i] + dz * nz[i];
        const int mine = best[i] == k;
        on[i] |= mine & (cd >= cos_dot);
        rim[i] |= mine & (cd > far[i]) & (cd < near[i]);
      }
    }
  }
}

// Stage 4: the level along each ray: Lambert plus Blinn-Phong (front light)
// or the backlit silhouette and its spot on the sphere it hit, the backdrop
// where it hit none.
template <bool Persp>
COLLIDE_SIMD_CLONES void shade(const Tracer& tr, RayBatch& b) {
  const int n = b.size(), lo = b.lo, hi = b.hi;
  const Lighting& l = *tr.sh.lighting;
  const float amb = static_cast<float>(l.ambient);
  const float dot_albedo = static_cast<float>(l.dot_albedo);
  const float sphere_albedo = static_cast<float>(l.sphere_albedo);
  const float backdrop = tr.backdrop;
  const int *best = b.best.data(), *on = b.on_dot.data();
  const float *nx = b.nx.data(), *ny = b.ny.data(), *nz = b.nz.data(), *nv = b.nv.data(),
              *x = b.x.data(), *y = b.y.data(), *z = b.z.data();
  float* level = b.level.data();
  std::fill(level, level + lo, backdrop);
  std::fill(level + hi, level + n, backdrop);
  if (l.mode == Lighting::Mode::Back) {
    const float spot = l.spot_level > 0 ? static_cast<float>(l.spot_level) : 0.0f;
    const float spot_cos = tr.sh.spot_cos;
    COLLIDE_INDEPENDENT_ITERATIONS
    for (int i = lo; i < hi; ++i) {
      const float lv =
          (on[i] ? dot_albedo : sphere_albedo) * amb + (nv[i] >= spot_cos ? spot : 0.0f);
      level[i] = best[i] >= 0 ? lv : backdrop;
    }
    return;
  }
  const float lx = static_cast<float>(l.lamp_direction.x()),
              ly = static_cast<float>(l.lamp_direction.y()),
              lz = static_cast<float>(l.lamp_direction.z());
  float* nh = b.scratch.data();  // n.h where the highlight shows, else 0
  const float nh_min = tr.sh.nh_min;
  const int highlight = l.specular_strength > 0;
  COLLIDE_INDEPENDENT_ITERATIONS
  for (int i = lo; i < hi; ++i) {
    const float ndl = nx[i] * lx + ny[i] * ly + nz[i] * lz;
    level[i] = (on[i] ? dot_albedo : sphere_albedo) * (amb + (1.0f - amb) * positive(ndl));
    // The half vector between the lamp and the view (towards the camera).
    float hx = lx, hy = ly, hz = lz + 1.0f;
    if constexpr (Persp) hx = lx - x[i], hy = ly - y[i], hz = lz - z[i];
    const float c = (nx[i] * hx + ny[i] * hy + nz[i] * hz) / std::sqrt(hx * hx + hy * hy + hz * hz);
    nh[i] = (highlight & (ndl > 0) & (c > nh_min)) ? c : 0.0f;
  }
  if (highlight) {
    // nh^exponent: by repeated squaring over the whole batch, or pow().
    float* p = b.far.data();  // free after stage 3
    const float strength = static_cast<float>(l.specular_strength);
    if (tr.sh.int_exponent > 0) {
      // By repeated squaring over the exponent's bits (up to 1024: 11), the
      // bit a uniform select, so that the loop stays vector code.
      const int e = tr.sh.int_exponent;
      COLLIDE_INDEPENDENT_ITERATIONS
      for (int i = lo; i < hi; ++i) {
        float x = nh[i], power = 1.0f;
#pragma GCC unroll 11
        for (int bit = 0; bit < 11; ++bit) {
          power *= ((e >> bit) & 1) ? x : 1.0f;
          x *= x;
        }
        p[i] = power;
      }
    } else {
      const float ex = static_cast<float>(l.specular_exponent);
      COLLIDE_INDEPENDENT_ITERATIONS
      for (int i = lo; i < hi; ++i) p[i] = nh[i] > 0 ? std::pow(nh[i], ex) : 0.0f;
    }
    COLLIDE_INDEPENDENT_ITERATIONS
    for (int i = lo; i < hi; ++i) level[i] += strength * p[i];
  }
  COLLIDE_INDEPENDENT_ITERATIONS
  for (int i = lo; i < hi; ++i) level[i] = best[i] >= 0 ? level[i] : backdrop;
}

// Every stage over a batch. With `smooth_test`, smooth[i] says whether ray
// i's level stands for its whole pixel.
void trace(const Tracer& tr, const std::vector<const Instance*>& group, RayBatch& b,
           bool smooth_test) {
  b.prepare();
  if (tr.persp) {
    nearestHits<true>(tr, group, b);
    if (smooth_test) edgesClear<true>(tr, group, b);
  } else {
    nearestHits<false>(tr, group, b);
    if (smooth_test) edgesClear<false>(tr, group, b);
  }
  // The rays at either end that hit nothing and are smooth (the corners of
  // the spheres' boxes) see the backdrop: the later stages skip them.
  const auto done = [&](int i) { return b.best[i] < 0 && (!smooth_test || b.smooth[i]); };
  while (b.lo < b.hi && done(b.lo)) ++b.lo;
  while (b.hi > b.lo && done(b.hi - 1)) --b.hi;
  if (tr.persp)
    surface<true>(tr, group, b, smooth_test);
  else
    surface<false>(tr, group, b, smooth_test);
  dotCover(group, b);
  if (smooth_test) {
    int* smooth = b.smooth.data();
    const int* rim = b.near_rim.data();
    for (int i = 0; i < b.size(); ++i) smooth[i] &= rim[i] ^ 1;
  }
  if (tr.persp)
    shade<true>(tr, b);
  else
    shade<false>(tr, b);
}

// Adds the ray through (u + fu - 0.5, v + fv - 0.5) of pixel column u.
void pushRay(const Tracer& tr, int u, int v, double fu, double fv, RayBatch& b) {
  const Ray ray = rayAt(tr.st, tr.ray_xy, u, v, fu, fv);
  if (tr.persp)
    b.push(u, static_cast<float>(ray.dir.x()), static_cast<float>(ray.dir.y()),
           static_cast<float>(ray.dir.z()));
  else
    b.push(u, static_cast<float>(ray.origin.x()), static_cast<float>(ray.origin.y()), 0.0f);
}

// The ss x ss rays of each pixel u0 + i, i in `pixels` (ascending), into `b`
// (pixel by pixel, row-major within a pixel). Through a distorted lens the
// rays come from the corner table in floats (as rayAt(), whose doubles add
// nothing at the table's precision); otherwise from rayAt().
void subRays(const Tracer& tr, const std::vector<int>& pixels, int u0, int v, RayBatch& b) {
  const int ss = tr.ss, per = ss * ss;
  if (!tr.persp || tr.ray_xy.empty()) {
    b.clear();
    for (const int i : pixels)
      for (int j = 0; j < ss; ++j)
        for (int q = 0; q < ss; ++q) pushRay(tr, u0 + i, v, (q + 0.5) / ss, (j + 0.5) / ss, b);
    return;
  }
  b.resize(static_cast<int>(pixels.size()) * per);
  // Each sub-ray's bilinear weights of its pixel's corners (u, v), (u + 1, v),
  // (u, v + 1), (u + 1, v + 1).
  std::array<std::array<float, 4>, 16 * 16> w;  // the first `per` are used
  for (int j = 0; j < ss; ++j)
    for (int q = 0; q < ss; ++q) {
      const float fu = (q + 0.5f) / ss, fv = (j + 0.5f) / ss;
      w[j * ss + q] = {(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv};
    }
  const std::size_t stride = static_cast<std::size_t>(tr.st.width + 1) * 2;
  const float* row = tr.ray_xy.data() + static_cast<std::size_t>(v) * stride;
  const auto fill = [&](auto per_pixel) {
    const int count = decltype(per_pixel)::value > 0 ? decltype(per_pixel)::value : per;
    int* col = b.col.data();
    float *xs = b.x.data(), *ys = b.y.data();
    int r = 0;
    for (const int i : pixels) {
      const int u = u0 + i;
      const float* c = row + u * 2;
      const float x00 = c[0], y00 = c[1], x01 = c[2], y01 = c[3];
      const float x10 = c[stride], y10 = c[stride + 1], x11 = c[stride + 2], y11 = c[stride + 3];
      for (int q = 0; q < count; ++q) {
        const std::array<float, 4>& a = w[q];
        col[r + q] = u;
        xs[r + q] = a[0] * x00 + a[1] * x01 + a[2] * x10 + a[3] * x11;
        ys[r + q] = a[0] * y00 + a[1] * y01 + a[2] * y10 + a[3] * y11;
      }
      r += count;
    }
    return r;
  };
  // 2 x 2 (the profiles' choice) with the count known, so that a pixel's four
  // rays are one vector.
  const int r =
      ss == 2 ? fill(std::integral_constant<int, 4>{}) : fill(std::integral_constant<int, 0>{});
  // The ideal (x, y) -> the unit direction (x, -y, -1) / |.|, as vector code.
  float *x = b.x.data(), *y = b.y.data(), *z = b.z.data();
  for (int i = 0; i < r; ++i) {
    const float inv = 1.0f / std::sqrt(x[i] * x[i] + y[i] * y[i] + 1.0f);
    x[i] *= inv, y[i] *= -inv, z[i] = -inv;
  }
}

}  // namespace

// The mean level over each pixel u0..u1 of row v (into out[u - u0]) for one
// time sample's instances: the centre ray where the pixel is smooth (at least
// kSmoothMarginPx from every silhouette edge and clear of the surface's
// features, see surface()): the shading's curvature over a pixel is then
// ~1e-4 of full scale. Otherwise the mean of ss x ss rays.
void traceRow(const Tracer& tr, const std::vector<const Instance*>& group, int v, int u0, int u1,
              RowScratch& s, float* out) {
  RayBatch& c = s.centres;
  c.v = v;
  const std::vector<float>& dirs = tr.centre_dirs;
  if (tr.persp && !dirs.empty()) {
    const int n = u1 - u0 + 1;
    c.resize(n);
    const std::size_t w = static_cast<std::size_t>(tr.st.width);
    const std::size_t plane = w * static_cast<std::size_t>(tr.st.height);
    const float* row = dirs.data() + static_cast<std::size_t>(v) * w + u0;
    for (int i = 0; i < n; ++i) c.col[i] = u0 + i;
    std::copy(row, row + n, c.x.begin());
    std::copy(row + plane, row + plane + n, c.y.begin());
    std::copy(row + 2 * plane, row + 2 * plane + n, c.z.begin());
  } else {
    c.clear();
    for (int u = u0; u <= u1; ++u) pushRay(tr, u, v, 0.5, 0.5, c);
  }
  const bool smooth_test = tr.ss > 1;
  trace(tr, group, c, smooth_test);
  std::copy(c.level.begin(), c.level.end(), out);
  if (!smooth_test) return;
  // The rough pixels' indices, without a branch per pixel.
  s.rough.resize(c.size());
  int* rough = s.rough.data();
  const int* smooth = c.smooth.data();
  int m = 0;
  for (int i = 0; i < c.size(); ++i) {
    rough[m] = i;
    m += smooth[i] ^ 1;
  }
  s.rough.resize(m);
  if (m == 0) return;
  RayBatch& sub = s.subs;
  sub.v = v;
  subRays(tr, s.rough, u0, v, sub);
  trace(tr, group, sub, false);
  const int per = tr.ss * tr.ss;
  for (std::size_t r = 0; r < s.rough.size(); ++r) {
    float sum = 0;
    for (int q = 0; q < per; ++q) sum += sub.level[r * per + q];
    out[s.rough[r]] = sum / per;
  }
}

}  // namespace collide::vision::raycast
