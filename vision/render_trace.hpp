#pragma once
// The ray-cast renderer's tracing, one image row at a time (render_trace.cpp);
// render_raycast.cpp builds a frame's sphere instances and its tables, calls
// traceRow() for each row and passes the light through the sensor. Internal
// to vision/: not an interface of the library.
//
// The rays of one image row (or the sub-pixel rays of its rough pixels) are
// traced together, one stage at a time over arrays of floats, so that each
// stage's loop runs as vector code: the nearest sphere along each ray, its
// surface there, the dots, the shading. A stage that depends on which sphere
// a ray hit runs once per sphere over the rays in that sphere's columns,
// keeping those that hit it (a row meets one or two spheres). Floats place a silhouette to
// ~1e-4 px and a level to ~1e-6 of full scale: the perpendicular distance
// from a sphere's centre to a ray is taken from a cross product, not as the
// difference of two squares near 0.3 m^2.

#include <Eigen/Dense>
#include <algorithm>
#include <utility>
#include <vector>

#include "vision/render.hpp"

// The tracing stages (here) and the sensor's loop (render_raycast.cpp) are
// built twice, for AVX2 (8 floats a vector) and for the baseline (SSE2, 4),
// and the loader picks the one the processor runs. Without FMA both give the
// same bits: each element sees the same operations in the same order.
// (COLLIDE_NO_CLONES: baseline only, as vision/avx2_clones.hpp says.)
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(COLLIDE_NO_CLONES)
#define COLLIDE_SIMD_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define COLLIDE_SIMD_CLONES
#endif

namespace collide::vision::raycast {

// Pixels this far from every silhouette edge may be sampled once (see
// traceRow()): a pixel reaches 0.71 px from its centre, the silhouette's
// curvature (radius >= ~10 px) adds < 0.03 px over a pixel, and the angular
// bound used under perspective (edgeThresholds) errs on the safe side.
constexpr double kSmoothMarginPx = 1.0;

// The dots of one sphere at one time sample that the camera may see: their
// centres in the world frame as three arrays of floats, so that the dot tests
// below run as vector code (a float places a dot's rim to ~1e-6 rad).
struct DotSet {
  std::vector<float> x, y, z;
  // The pixels (inclusive ranges) each dot's image may touch, with a margin
  // that holds every pixel reaching its rim (dotBoxes()).
  std::vector<int> u0, u1, v0, v1;
};

// One sphere at one time sample of the exposure.
struct Instance {
  Vec3 centre;
  double radius = 0;
  double inv_radius = 0;
  const DotSet* dots = nullptr;  // world frame
  double cos_dot = 1;
  double sin_dot = 0;
  // Silhouette thresholds for the smoothness test (edgesClear()): a ray is
  // kSmoothMarginPx inside the silhouette when it heads towards the sphere
  // and passes its centre closer than sqrt(in_thr) (m), outside when it
  // passes further than sqrt(out_thr) or heads away (if behind_clear).
  float in_thr = -1, out_thr = 0;
  int behind_clear = 1;
  // Perspective: the centre from the optical centre.
  Vec3 rel = Vec3::Zero();
  int sample = 0;
  int u0 = 0, u1 = -1, v0 = 0, v1 = -1;  // pixels it may touch, clipped to the frame
};

// The ray through one sample position.
struct Ray {
  Vec3 origin;  // perspective: the optical centre; orthographic: (x, y, 0)
  Vec3 dir;     // unit
};

// The ray through image position (u + fu - 0.5, v + fv - 0.5) of pixel
// (u, v), fu, fv in [0, 1]; ray_xy is the distorted lens' corner table
// (render_raycast.cpp, ImagingTables::ray_xy), empty without distortion.
Ray rayAt(const RenderSettings& st, const std::vector<float>& ray_xy, int u, int v, double fu,
          double fv);

// Constants for a frame: what shading needs besides the hit, and the focal
// length the smoothness test converts distances with.
struct Shading {
  const Lighting* lighting = nullptr;
  float nh_min = 2;        // the highlight's cut-off (above)
  int int_exponent = -1;   // the highlight's exponent when a whole number up to 1024, else -1
  float spot_cos = 1;      // backlit: the spot's rim, as n.view
  float inv_focal_px = 0;  // perspective: 1 / focal length in pixels
};

Shading shadingFor(const Lighting& l, const Optics& o);

// Structure of arrays: ray i belongs to pixel column col[i]; perspective rays
// start at the optical centre with unit direction (x, y, z), orthographic ones
// at (x, y, 0) with direction -z.
struct RayBatch {
  std::vector<int> col;
  std::vector<float> x, y, z;
  // Filled by trace(): the nearest instance (index into the group, -1 none)
  // and the distance along the ray to it; the surface normal there; the
  // level; whether the pixel's centre ray stands for the pixel (smooth).
  std::vector<int> best;
  std::vector<float> t, nx, ny, nz, nv, level;
  std::vector<int> smooth, on_dot, near_rim;
  std::vector<float> far, near, scratch;  // per ray: a dot rim band; powers

  int v = 0;  // the image row all the rays are in
  // After the nearest sphere is found: the rays outside [lo, hi) hit none
  // (and are smooth), so the stages after it leave them out.
  int lo = 0, hi = 0;
  int size() const { return static_cast<int>(col.size()); }
  // The rays [first, second) in [lo, hi) whose columns are in [u0, u1] (col
  // ascends).
  std::pair<int, int> columns(int u0, int u1) const {
    const auto first = std::lower_bound(col.begin() + lo, col.begin() + hi, u0);
    const auto last = std::upper_bound(first, col.begin() + hi, u1);
    return {static_cast<int>(first - col.begin()), static_cast<int>(last - col.begin())};
  }
  void clear() { col.clear(), x.clear(), y.clear(), z.clear(); }
  void resize(int n) { col.resize(n), x.resize(n), y.resize(n), z.resize(n); }
  void push(int c, float a, float b, float d) {
    col.push_back(c), x.push_back(a), y.push_back(b), z.push_back(d);
  }
  void prepare() {
    const std::size_t n = col.size();
    t.resize(n), nx.resize(n), ny.resize(n), nz.resize(n), nv.resize(n), level.resize(n);
    far.resize(n), near.resize(n), scratch.resize(n);
    best.resize(n), smooth.resize(n), on_dot.resize(n), near_rim.resize(n);
    lo = 0, hi = static_cast<int>(n);
  }
};

// What tracing needs for a frame.
struct Tracer {
  const RenderSettings& st;
  const std::vector<float>& ray_xy;       // ImagingTables::ray_xy
  const std::vector<float>& centre_dirs;  // ImagingTables::centre_dirs
  Shading sh;
  bool persp = false;
  int ss = 1;
  float backdrop = 0;
};

// Scratch for one frame's rows.
struct RowScratch {
  RayBatch centres, subs;
  std::vector<int> rough;  // the centre rays (indices, column u0 + i) that were not smooth
};

// The mean level over each pixel u0..u1 of row v (into out[u - u0]) for one
// time sample's instances: the centre ray where the pixel is smooth (at least
// kSmoothMarginPx from every silhouette edge and clear of the surface's
// features, see surface()): the shading's curvature over a pixel is then
// ~1e-4 of full scale. Otherwise the mean of ss x ss rays.
void traceRow(const Tracer& tr, const std::vector<const Instance*>& group, int v, int u0, int u1,
              RowScratch& s, float* out);

}  // namespace collide::vision::raycast
