// Renderer with RenderSettings::imaging: every sphere is ray-cast in 3-D
// through the lens (orthographic or pinhole with distortion), shaded by the
// lamps from its true normal, averaged over n x n samples per pixel and over
// the exposure's time samples (translation and rotation), then passed through
// the sensor: vignetting, flicker, fixed patterns, shot and read noise, ADC.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <type_traits>

#include "vision/random.hpp"
#include "vision/render.hpp"
#include "vision/render_trace.hpp"

namespace collide::vision {

using namespace raycast;  // the tracing's types (render_trace.hpp)
using detail::splitmix64;
using detail::uniform01;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kNoiseTableSize = 1 << 18;
// Automatic motion blur: one time sample per this much motion of the fastest
// surface point (ray-casting costs more per sample than the analytic path).
constexpr double kBlurStepPx = 0.5;
constexpr int kMaxBlurSamples = 128;
double gaussian(std::uint64_t& state) {
  const double u1 = 1.0 - uniform01(state);
  const double u2 = uniform01(state);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

int clampIndex(double x, int lo, int hi) {
  if (!(x > lo)) return lo;
  if (x > hi) return hi;
  return static_cast<int>(x);
}

// sin(pi x) / (pi x): the mean of cos over a window of x periods.
double sinc(double x) {
  return std::abs(x) < 1e-9 ? 1.0 : std::sin(kPi * x) / (kPi * x);
}

// The ideal normalised (x, y) at image position (u + fu - 0.5, v + fv - 0.5),
// fu, fv in [0, 1], from a distorted lens' table (ImagingTables::ray_xy):
// bilinear between the pixel's corners.
Eigen::Vector2d lensTableXy(const std::vector<float>& ray_xy, int width, int u, int v, double fu,
                            double fv) {
  const std::size_t stride = static_cast<std::size_t>(width + 1) * 2;
  const float* c = ray_xy.data() + static_cast<std::size_t>(v) * stride + u * 2;
  const auto lerp = [&](int k) {
    return (1 - fv) * ((1 - fu) * c[k] + fu * c[k + 2]) +
           fv * ((1 - fu) * c[stride + k] + fu * c[stride + k + 2]);
  };
  return {lerp(0), lerp(1)};
}

}  // namespace

namespace raycast {

Ray rayAt(const RenderSettings& st, const std::vector<float>& ray_xy, int u, int v, double fu,
          double fv) {
  const Optics& o = st.imaging->optics;
  const double pu = u + fu - 0.5, pv = v + fv - 0.5;
  Ray ray;
  if (!o.perspective) {
    ray.origin =
        Vec3((pu - o.origin_u_px) * o.pixel_size_m, (o.origin_v_px - pv) * o.pixel_size_m, 0);
    ray.dir = -Vec3::UnitZ();
    return ray;
  }
  double x, y;
  if (ray_xy.empty()) {
    x = (pu - o.principal_u_px) / o.focal_px;
    y = (pv - o.principal_v_px) / o.focal_px;
  } else {
    const Eigen::Vector2d xy = lensTableXy(ray_xy, st.width, u, v, fu, fv);
    x = xy.x();
    y = xy.y();
  }
  ray.origin = o.centre_m;
  ray.dir = Vec3(x, -y, -1.0) * (1.0 / std::sqrt(x * x + y * y + 1.0));
  return ray;
}

}  // namespace raycast

// ---- optics -----------------------------------------------------------------

// The perspective part is analysis/camera_model.hpp's camera (one model for
// drawing and for measuring).
PinholeCamera Optics::pinhole() const {
  PinholeCamera c;
  c.focal_px = focal_px;
  c.principal_u_px = principal_u_px, c.principal_v_px = principal_v_px;
  c.centre_m = centre_m;
  c.k1 = k1, c.k2 = k2, c.p1 = p1, c.p2 = p2;
  return c;
}

Eigen::Vector2d Optics::distort(const Eigen::Vector2d& xy) const {
  return pinhole().distort(xy);
}

Eigen::Vector2d Optics::undistort(const Eigen::Vector2d& xy_distorted) const {
  return pinhole().undistort(xy_distorted);
}

Eigen::Vector2d Optics::project(const Vec3& w) const {
  if (!perspective) return {origin_u_px + w.x() / pixel_size_m, origin_v_px - w.y() / pixel_size_m};
  return pinhole().project(w);
}

// ---- per-renderer tables ------------------------------------------------------

struct Renderer::ImagingTables {
  int ss = 1;
  // Distorted lens: the ideal normalised (x, y) of every pixel corner,
  // index ((v (width + 1) + u) * 2 for the corner at (u - 0.5, v - 0.5);
  // samples inside a pixel interpolate bilinearly (the map is smooth: the
  // error is ~1e-4 px). Empty otherwise.
  std::vector<float> ray_xy;
  // Perspective: the unit direction of every pixel centre's ray, as three
  // planes (x, then y, then z, each width x height). Empty otherwise.
  std::vector<float> centre_dirs;
  std::vector<float> gain;    // per pixel: vignetting x (1 + prnu)
  std::vector<float> offset;  // per pixel: dsnu + hot pixels, fraction of full scale
  std::vector<float> noise;   // unit Gaussians, read in runs from random offsets
};

std::shared_ptr<const Renderer::ImagingTables> Renderer::makeImagingTables(
    const RenderSettings& s) {
  const Imaging& im = *s.imaging;
  const Optics& o = im.optics;
  const Sensor& se = im.sensor;
  const Lighting& l = im.lighting;
  if (im.samples_per_pixel < 1 || im.samples_per_pixel > 16 || !(o.pixel_size_m > 0) ||
      !(o.focal_px > 0) || !(l.lamp_direction.norm() > 0) || !(l.ambient >= 0 && l.ambient <= 1) ||
      !(se.gain > 0) || !(se.full_well_e >= 0) || !(se.read_noise_e >= 0) || !(se.prnu >= 0) ||
      !(se.dsnu >= 0) || !(se.hot_pixel_fraction >= 0) ||
      (se.adc_bits != 0 && (se.adc_bits < 1 || se.adc_bits > bitDepth(s.format))))
    throw std::invalid_argument("Renderer: imaging settings out of range");
  auto t = std::make_shared<ImagingTables>();
  const int w = s.width, h = s.height, ss = im.samples_per_pixel;
  t->ss = ss;
  if (o.distorted()) {
    t->ray_xy.resize(static_cast<std::size_t>(w + 1) * (h + 1) * 2);
    for (int v = 0; v <= h; ++v)
      for (int u = 0; u <= w; ++u) {
        const Eigen::Vector2d xy = o.undistort(
            {(u - 0.5 - o.principal_u_px) / o.focal_px, (v - 0.5 - o.principal_v_px) / o.focal_px});
        const std::size_t i = (static_cast<std::size_t>(v) * (w + 1) + u) * 2;
        t->ray_xy[i] = static_cast<float>(xy.x());
        t->ray_xy[i + 1] = static_cast<float>(xy.y());
      }
  }
  if (o.perspective) {
    const std::size_t plane = static_cast<std::size_t>(w) * h;
    t->centre_dirs.resize(3 * plane);
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        const Ray ray = rayAt(s, t->ray_xy, u, v, 0.5, 0.5);
        const std::size_t i = static_cast<std::size_t>(v) * w + u;
        for (int c = 0; c < 3; ++c) t->centre_dirs[c * plane + i] = static_cast<float>(ray.dir[c]);
      }
  }
  // Vignetting and fixed patterns, reproducible from the noise seed.
  t->gain.assign(static_cast<std::size_t>(w) * h, 1.0f);
  t->offset.assign(static_cast<std::size_t>(w) * h, 0.0f);
  const double cu = o.perspective ? o.principal_u_px : 0.5 * (w - 1);
  const double cv = o.perspective ? o.principal_v_px : 0.5 * (h - 1);
  double r_corner2 = 0;
  for (const double u : {0.0, w - 1.0})
    for (const double v : {0.0, h - 1.0})
      r_corner2 = std::max(r_corner2, (u - cu) * (u - cu) + (v - cv) * (v - cv));
  std::uint64_t state = s.noise_seed ^ 0x5851f42d4c957f2dULL;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      double g = 1.0;
      if (se.vignetting_cos4 && o.perspective) {
        // The pixel centre's ideal (x, y): from the lens table when distorted
        // (interpolated, ~1e-4 px off: nothing at cos^4's scale).
        const Eigen::Vector2d xy = o.distorted()
                                       ? lensTableXy(t->ray_xy, w, u, v, 0.5, 0.5)
                                       : Eigen::Vector2d((u - o.principal_u_px) / o.focal_px,
                                                         (v - o.principal_v_px) / o.focal_px);
        const double q = 1.0 + xy.squaredNorm();  // 1 / cos^2 of the field angle
        g /= q * q;
      }
      if (se.vignetting_falloff > 0 && r_corner2 > 0)
        g *= 1.0 - se.vignetting_falloff * ((u - cu) * (u - cu) + (v - cv) * (v - cv)) / r_corner2;
      if (se.prnu > 0) g *= 1.0 + se.prnu * gaussian(state);
      double off = 0.0;
      if (se.dsnu > 0) off += se.dsnu * gaussian(state);
      if (se.hot_pixel_fraction > 0 && uniform01(state) < se.hot_pixel_fraction)
        off += se.hot_pixel_level;
      const std::size_t i = static_cast<std::size_t>(v) * w + u;
      t->gain[i] = static_cast<float>(std::max(0.0, g));
      t->offset[i] = static_cast<float>(off);
    }
  std::uint64_t nstate = s.noise_seed ^ 0x9e6c63d0676a9a99ULL;
  t->noise.resize(static_cast<std::size_t>(kNoiseTableSize) + w);
  for (float& n : t->noise) n = static_cast<float>(gaussian(nstate));
  return t;
}

// ---- rendering --------------------------------------------------------------

namespace {

// Pixels per metre at the sphere's distance (for the number of blur samples).
double pixelsPerMetre(const Optics& o, const Vec3& c) {
  if (!o.perspective) return 1.0 / o.pixel_size_m;
  const double depth = o.centre_m.z() - c.z();
  return depth > 0 ? o.focal_px / depth : 0.0;
}

int timeSamples(const RenderSettings& st, const std::vector<SphereView>& spheres) {
  if (!(st.exposure_s > 0)) return 1;
  if (st.blur_samples > 0) return st.blur_samples;
  double fastest_px = 0;
  for (const SphereView& sv : spheres)
    fastest_px =
        std::max(fastest_px, (sv.velocity_m_s.norm() + sv.spin_rad_s.norm() * sv.radius_m) *
                                 pixelsPerMetre(st.imaging->optics, sv.centre_m) * st.exposure_s);
  if (!(fastest_px >= 0)) return 1;
  return static_cast<int>(
      std::clamp(std::ceil(fastest_px / kBlurStepPx), 1.0, 1.0 * kMaxBlurSamples));
}

// The pixels a sphere's image may touch: its bounding cube's corners through
// the lens (a convex body's image lies in the hull of its hull's images), the
// box's edges sampled through the distortion, plus a pixel of margin.
bool pixelBox(const Optics& o, const Vec3& c, double r, int width, int height, Instance& in) {
  double u_lo, u_hi, v_lo, v_hi;
  if (!o.perspective) {
    const Eigen::Vector2d p = o.project(c);
    const double rp = r / o.pixel_size_m;
    u_lo = p.x() - rp, u_hi = p.x() + rp, v_lo = p.y() - rp, v_hi = p.y() + rp;
  } else {
    double x_lo = 1e300, x_hi = -1e300, y_lo = 1e300, y_hi = -1e300;
    for (int k = 0; k < 8; ++k) {
      const Vec3 q = c + r * Vec3(k & 1 ? 1 : -1, k & 2 ? 1 : -1, k & 4 ? 1 : -1);
      const double depth = o.centre_m.z() - q.z();
      if (!(depth > 1e-9)) return false;  // reaches behind the lens: not drawn
      const double x = (q.x() - o.centre_m.x()) / depth, y = -(q.y() - o.centre_m.y()) / depth;
      x_lo = std::min(x_lo, x), x_hi = std::max(x_hi, x);
      y_lo = std::min(y_lo, y), y_hi = std::max(y_hi, y);
    }
    u_lo = v_lo = 1e300, u_hi = v_hi = -1e300;
    constexpr int kEdge = 8;
    for (int e = 0; e <= kEdge; ++e) {
      const double f = static_cast<double>(e) / kEdge;
      for (const Eigen::Vector2d& xy : {Eigen::Vector2d(x_lo + f * (x_hi - x_lo), y_lo),
                                        Eigen::Vector2d(x_lo + f * (x_hi - x_lo), y_hi),
                                        Eigen::Vector2d(x_lo, y_lo + f * (y_hi - y_lo)),
                                        Eigen::Vector2d(x_hi, y_lo + f * (y_hi - y_lo))}) {
        const Eigen::Vector2d d = o.distort(xy);
        const double u = o.focal_px * d.x() + o.principal_u_px;
        const double v = o.focal_px * d.y() + o.principal_v_px;
        u_lo = std::min(u_lo, u), u_hi = std::max(u_hi, u);
        v_lo = std::min(v_lo, v), v_hi = std::max(v_hi, v);
      }
    }
    const double margin = o.distorted() ? 2.0 : 0.0;
    u_lo -= margin, v_lo -= margin, u_hi += margin, v_hi += margin;
  }
  if (!std::isfinite(u_lo + u_hi + v_lo + v_hi)) return false;
  in.u0 = clampIndex(std::floor(u_lo - 0.5) + 1, 0, width - 1);
  in.u1 = clampIndex(std::ceil(u_hi + 0.5) - 1, -1, width - 1);
  in.v0 = clampIndex(std::floor(v_lo - 0.5) + 1, 0, height - 1);
  in.v1 = clampIndex(std::ceil(v_hi + 0.5) - 1, -1, height - 1);
  if (u_hi < -0.5 || v_hi < -0.5 || u_lo > width - 0.5 || v_lo > height - 0.5) return false;
  return in.u0 <= in.u1 && in.v0 <= in.v1;
}

void edgeThresholds(const Optics& o, Instance& in) {
  if (!o.perspective) {
    const double inner = std::max(0.0, in.radius - kSmoothMarginPx * o.pixel_size_m);
    const double outer = in.radius + kSmoothMarginPx * o.pixel_size_m;
    in.in_thr = inner > 0 ? static_cast<float>(inner * inner) : -1.0f;
    in.out_thr = static_cast<float>(outer * outer);
    return;
  }
  // Under perspective: the angle between the ray and the centre's direction
  // against alpha -+ margin / f (the tangent cone's half-angle alpha), which
  // off-axis (pixels subtend less there) and with mild distortion still
  // bounds the distance in pixels; as the perpendicular distance dist sin().
  const double dist = (in.centre - o.centre_m).norm();
  const double alpha = std::asin(std::min(1.0, in.radius / dist));
  const double margin = kSmoothMarginPx / o.focal_px;
  const auto perp2 = [&](double angle) {
    const double p = dist * std::sin(angle);
    return static_cast<float>(p * p);
  };
  in.in_thr = alpha > margin ? perp2(alpha - margin) : -1.0f;  // -1: never inside
  const bool outside_possible = alpha + margin < 0.5 * kPi;
  in.out_thr = outside_possible ? perp2(alpha + margin) : std::numeric_limits<float>::infinity();
  in.behind_clear = outside_possible;
}

// The dots of `pattern` turned by `body_to_world` that may show: a dot is left
// out when its whole cap, widened by the largest rim margin a smooth pixel
// uses (delta in surface(), at the limb's nv = 0.05), faces away from
// `towards_camera` (unit, from the sphere's centre).
void visibleDots(const DotPattern& pattern, const Eigen::Matrix3d& body_to_world,
                 const Vec3& towards_camera, double max_delta, DotSet& out) {
  const double reach = pattern.angular_radius_rad + max_delta;
  const double hidden_below = reach < 0.5 * kPi ? -std::sin(reach) : -2.0;
  for (const Vec3& c : pattern.centres) {
    const Vec3 w = body_to_world * c;
    if (w.dot(towards_camera) <= hidden_below) continue;
    out.x.push_back(static_cast<float>(w.x()));
    out.y.push_back(static_cast<float>(w.y()));
    out.z.push_back(static_cast<float>(w.z()));
  }
}

// Each dot's pixel box: the image of the part of its cap the camera sees,
// bounded by the images of its rim (a circle on the sphere, kRimSamples
// points) and, where the cap reaches over the limb, of the limb's arc inside
// it (kLimbSamples points round the limb, each taken when within one sample's
// spacing of the cap, so that the arc's ends are covered); widened by
// kDotBoxMarginPx, which covers the chords between samples and every pixel
// that reaches the rim (a pixel reaches 0.71 px from its centre). A cap wholly
// behind the limb gets an empty box.
constexpr int kRimSamples = 24;
constexpr int kLimbSamples = 96;
constexpr double kDotBoxMarginPx = 2.0;

void dotBoxes(const Optics& o, const Instance& in, const Vec3& towards, double dot_radius_rad,
              DotSet& d) {
  // The camera sees the cap of the sphere within `limit` of `towards`.
  const double limit = o.perspective
                           ? std::acos(std::min(1.0, in.radius / (in.centre - o.centre_m).norm()))
                           : 0.5 * kPi;
  const double cos_r = std::cos(dot_radius_rad), sin_r = std::sin(dot_radius_rad);
  const double limb_step = 2.0 * kPi / kLimbSamples;
  const Vec3 t1 = towards.unitOrthogonal(), t2 = towards.cross(t1);
  const std::size_t n = d.x.size();
  d.u0.assign(n, 1), d.u1.assign(n, 0), d.v0.assign(n, 1), d.v1.assign(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    const Vec3 c = Vec3(d.x[j], d.y[j], d.z[j]).normalized();
    const double from_axis = std::acos(std::clamp(c.dot(towards), -1.0, 1.0));
    if (from_axis - dot_radius_rad > limit) continue;  // wholly hidden
    double u_lo = 1e300, u_hi = -1e300, v_lo = 1e300, v_hi = -1e300;
    const auto take = [&](const Vec3& unit) {
      const Eigen::Vector2d uv = o.project(in.centre + in.radius * unit);
      u_lo = std::min(u_lo, uv.x()), u_hi = std::max(u_hi, uv.x());
      v_lo = std::min(v_lo, uv.y()), v_hi = std::max(v_hi, uv.y());
    };
    // Two unit vectors normal to the dot's centre span its rim.
    const Vec3 e1 = c.unitOrthogonal(), e2 = c.cross(e1);
    for (int k = 0; k < kRimSamples; ++k) {
      const double a = 2.0 * kPi * k / kRimSamples;
      take(cos_r * c + sin_r * (std::cos(a) * e1 + std::sin(a) * e2));
    }
    if (from_axis + dot_radius_rad >= limit - limb_step) {
      const double cos_reach = std::cos(dot_radius_rad + limb_step);
      for (int k = 0; k < kLimbSamples; ++k) {
        const double a = limb_step * k;
        const Vec3 p =
            std::cos(limit) * towards + std::sin(limit) * (std::cos(a) * t1 + std::sin(a) * t2);
        if (p.dot(c) >= cos_reach) take(p);
      }
    }
    if (!std::isfinite(u_lo + u_hi + v_lo + v_hi)) {  // through the lens' edge: no bound
      d.u0[j] = in.u0, d.u1[j] = in.u1, d.v0[j] = in.v0, d.v1[j] = in.v1;
      continue;
    }
    d.u0[j] = std::max(in.u0, static_cast<int>(std::floor(u_lo - kDotBoxMarginPx)));
    d.u1[j] = std::min(in.u1, static_cast<int>(std::ceil(u_hi + kDotBoxMarginPx)));
    d.v0[j] = std::max(in.v0, static_cast<int>(std::floor(v_lo - kDotBoxMarginPx)));
    d.v1[j] = std::min(in.v1, static_cast<int>(std::ceil(v_hi + kDotBoxMarginPx)));
  }
}

// The largest rim margin surface() gives a smooth pixel on this sphere
// (its delta at nv = 0.05, the visible surface being nearer than the centre).
double maxRimDelta(const Optics& o, const Instance& in) {
  const double lateral_m =
      o.perspective ? (in.centre - o.centre_m).norm() / o.focal_px : o.pixel_size_m;
  return lateral_m / (in.radius * 0.05);
}

// The instances of every sphere at every time sample, grouped by sample; the
// dots each may show in `dot_sets`.
std::vector<Instance> instances(const RenderSettings& st, const std::vector<SphereView>& spheres,
                                int samples, std::vector<DotSet>& dot_sets) {
  const Optics& o = st.imaging->optics;
  dot_sets.clear();
  dot_sets.reserve(spheres.size() * samples);  // no reallocation: instances point into it
  std::vector<Instance> out;
  for (int j = 0; j < samples; ++j) {
    const double t = samples == 1 ? 0.0 : st.exposure_s * ((j + 0.5) / samples - 0.5);
    for (const SphereView& sv : spheres) {
      Instance in;
      in.centre = sv.centre_m + sv.velocity_m_s * t;
      in.radius = sv.radius_m;
      in.sample = j;
      if (!(in.radius > 0) || !in.centre.allFinite()) continue;
      if (!pixelBox(o, in.centre, in.radius, st.width, st.height, in)) continue;
      edgeThresholds(o, in);
      in.inv_radius = 1.0 / in.radius;
      in.rel = in.centre - o.centre_m;
      Eigen::Matrix3d rot = sv.orientation.normalized().toRotationMatrix();
      const double spin = sv.spin_rad_s.norm();
      if (spin > 0 && t != 0)
        rot = Eigen::AngleAxisd(spin * t, sv.spin_rad_s / spin).toRotationMatrix() * rot;
      if (sv.dots != nullptr && !sv.dots->centres.empty()) {
        const Vec3 towards = o.perspective ? Vec3(-in.rel.normalized()) : Vec3::UnitZ();
        DotSet& d = dot_sets.emplace_back();
        visibleDots(*sv.dots, rot, towards, maxRimDelta(o, in), d);
        dotBoxes(o, in, towards, sv.dots->angular_radius_rad, d);
        in.dots = &d;
        in.cos_dot = std::cos(sv.dots->angular_radius_rad);
        in.sin_dot = std::sin(sv.dots->angular_radius_rad);
      }
      out.push_back(in);
    }
  }
  return out;
}

// Light -> grey levels for one row: gain map, flicker, shot and read noise (or
// plain additive noise), fixed offsets, ADC bits, the format's words. Shot and
// read noise are independent Gaussians (Poisson at these counts), so their sum
// is one Gaussian of variance e + read^2: one unit Gaussian `g` per pixel.
// Written to vectorise (the vision library is built with -fno-math-errno so
// that the square root does too).
template <class T>
COLLIDE_SIMD_CLONES void sensorRow(const RenderSettings& st, const float* gain, const float* offset,
                                   const float* g, double flicker, const float* light, T* out) {
  const Sensor& se = st.imaging->sensor;
  const int w = st.width;
  const int fmt_bits = bitDepth(st.format);
  const int bits = se.adc_bits > 0 ? se.adc_bits : fmt_bits;
  const float adc_max = static_cast<float>((1 << bits) - 1);
  const int shift = fmt_bits - bits;
  const float fl = static_cast<float>(flicker);
  if (se.full_well_e > 0) {
    const float full_well = static_cast<float>(se.full_well_e);
    const float read2 = static_cast<float>(se.read_noise_e * se.read_noise_e);
    const float scale = static_cast<float>(se.gain / se.full_well_e) * adc_max;
    for (int u = 0; u < w; ++u) {
      const float e = std::max(0.0f, light[u] * fl * gain[u] * full_well);
      const float x = (e + std::sqrt(e + read2) * g[u]) * scale + offset[u] * adc_max;
      out[u] =
          static_cast<T>(static_cast<int>(std::min(std::max(x, 0.0f), adc_max) + 0.5f) << shift);
    }
  } else {
    const float gn = static_cast<float>(se.gain);
    const float grey_sigma = static_cast<float>(st.noise_grey / maxValue(st.format));
    for (int u = 0; u < w; ++u) {
      const float x = (gn * light[u] * fl * gain[u] + grey_sigma * g[u] + offset[u]) * adc_max;
      out[u] =
          static_cast<T>(static_cast<int>(std::min(std::max(x, 0.0f), adc_max) + 0.5f) << shift);
    }
  }
}

// One row of light through the sensor into `image`'s row `v`: a run of the
// noise table at an offset drawn from `rng`, then sensorRow in the format's words.
void exposeRow(const RenderSettings& st, const std::vector<float>& noise,
               const std::vector<float>& gain, const std::vector<float>& offset, double flicker,
               const float* light, int v, std::uint64_t& rng, cv::Mat& image) {
  const float* g = noise.data() + splitmix64(rng) % kNoiseTableSize;
  const std::size_t row = static_cast<std::size_t>(v) * st.width;
  if (st.format == PixelFormat::Mono8)
    sensorRow(st, gain.data() + row, offset.data() + row, g, flicker, light,
              image.ptr<std::uint8_t>(v));
  else
    sensorRow(st, gain.data() + row, offset.data() + row, g, flicker, light,
              image.ptr<std::uint16_t>(v));
}

}  // namespace

cv::Mat Renderer::renderImaging(const std::vector<SphereView>& spheres, std::uint64_t frame_index,
                                double time_s) const {
  const RenderSettings& st = settings_;
  const Imaging& im = *st.imaging;
  const ImagingTables& tab = *imaging_;
  const int width = st.width, height = st.height;
  const int samples = timeSamples(st, spheres);
  std::vector<DotSet> dot_sets;
  const std::vector<Instance> inst = instances(st, spheres, samples, dot_sets);
  const Shading sh = shadingFor(im.lighting, im.optics);

  // Lamp intensity averaged over the exposure.
  const Sensor& se = im.sensor;
  const double flicker = se.flicker_hz > 0
                             ? 1.0 + se.flicker_amplitude * sinc(se.flicker_hz * st.exposure_s) *
                                         std::cos(2.0 * kPi * se.flicker_hz * time_s)
                             : 1.0;

  const Tracer tr{st,
                  tab.ray_xy,
                  tab.centre_dirs,
                  sh,
                  im.optics.perspective,
                  im.samples_per_pixel,
                  static_cast<float>(im.lighting.backdrop_level)};
  cv::Mat image(height, width, cvType(st.format));
  std::vector<float> light(static_cast<std::size_t>(width));
  std::vector<float> levels(static_cast<std::size_t>(width));
  std::vector<float> sum(static_cast<std::size_t>(width));  // over time samples, less the backdrop
  std::vector<const Instance*> group;
  RowScratch scratch;
  std::uint64_t rng = st.noise_seed ^ (frame_index * 0xd1b54a32d192ed03ULL) ^ 0x2f8ad3c4e1b7a965ULL;
  splitmix64(rng);
  // `light` holds the backdrop outside the columns a row's instances touch;
  // those are put back after each row.
  std::fill(light.begin(), light.end(), tr.backdrop);
  for (int v = 0; v < height; ++v) {
    int row0 = width, row1 = -1;  // the columns any instance may touch
    for (const Instance& in : inst)
      if (v >= in.v0 && v <= in.v1) row0 = std::min(row0, in.u0), row1 = std::max(row1, in.u1);
    if (samples > 1 && row0 <= row1) std::fill(sum.begin() + row0, sum.begin() + row1 + 1, 0.0f);
    // Instances come grouped by time sample: each group is traced over the
    // columns its instances may touch; a pixel's level is the mean over the
    // time samples, the backdrop where a sample has nothing near it.
    for (std::size_t a = 0; a < inst.size() && row0 <= row1;) {
      std::size_t b = a;
      group.clear();
      int span0 = width, span1 = -1;
      for (; b < inst.size() && inst[b].sample == inst[a].sample; ++b) {
        if (v < inst[b].v0 || v > inst[b].v1) continue;
        group.push_back(&inst[b]);
        span0 = std::min(span0, inst[b].u0);
        span1 = std::max(span1, inst[b].u1);
      }
      a = b;
      if (group.empty()) continue;
      if (samples == 1) {
        traceRow(tr, group, v, span0, span1, scratch, light.data() + span0);
        continue;
      }
      traceRow(tr, group, v, span0, span1, scratch, levels.data());
      for (int u = span0; u <= span1; ++u) sum[u] += levels[u - span0] - tr.backdrop;
    }
    if (samples > 1)
      for (int u = row0; u <= row1; ++u) light[u] = tr.backdrop + sum[u] / samples;
    exposeRow(st, tab.noise, tab.gain, tab.offset, flicker, light.data(), v, rng, image);
    if (row0 <= row1) std::fill(light.begin() + row0, light.begin() + row1 + 1, tr.backdrop);
  }
  return image;
}

}  // namespace collide::vision

namespace collide::vision {
namespace {

// Light from the board along `ray`: its square's level, or the backdrop.
double boardLevel(const Imaging& im, const ChessboardTarget& b, const Vec3& normal, double lit,
                  const Ray& ray) {
  const double along = ray.dir.dot(normal);
  if (std::abs(along) < 1e-12) return im.lighting.backdrop_level;
  const double t = (b.origin_m - ray.origin).dot(normal) / along;
  if (!(t > 0)) return im.lighting.backdrop_level;
  const Vec3 p = ray.origin + t * ray.dir - b.origin_m;
  const double a = p.dot(b.x_axis) / b.square_m, c = p.dot(b.y_axis) / b.square_m;
  if (!(a > -1.6 && a < b.inner_cols + 0.6 && c > -1.6 && c < b.inner_rows + 0.6))
    return im.lighting.backdrop_level;
  double albedo = b.light_albedo;  // the margin
  if (a > -1 && a < b.inner_cols && c > -1 && c < b.inner_rows)
    albedo = (static_cast<long>(std::floor(a) + std::floor(c)) % 2 == 0) ? b.dark_albedo
                                                                         : b.light_albedo;
  return albedo * lit;
}

}  // namespace

cv::Mat Renderer::renderChessboard(const ChessboardTarget& board, std::uint64_t frame_index) const {
  if (!settings_.imaging || !imaging_)
    throw std::invalid_argument("Renderer::renderChessboard needs RenderSettings::imaging");
  const RenderSettings& st = settings_;
  const Imaging& im = *st.imaging;
  const ImagingTables& tab = *imaging_;
  const Vec3 normal = board.x_axis.cross(board.y_axis).normalized();
  const Lighting& l = im.lighting;
  const double lit =
      l.ambient + (1 - l.ambient) * std::abs(normal.dot(l.lamp_direction.normalized()));
  const Sensor& se = im.sensor;
  const double flicker =
      se.flicker_hz > 0 ? 1.0 + se.flicker_amplitude * sinc(se.flicker_hz * st.exposure_s) : 1.0;
  const int ss = im.samples_per_pixel;
  cv::Mat image(st.height, st.width, cvType(st.format));
  std::vector<float> light(static_cast<std::size_t>(st.width));
  std::uint64_t rng = st.noise_seed ^ (frame_index * 0xd1b54a32d192ed03ULL) ^ 0x6a09e667f3bcc909ULL;
  splitmix64(rng);
  for (int v = 0; v < st.height; ++v) {
    for (int u = 0; u < st.width; ++u) {
      // Each ray in its own column and row of an ss^2 x ss^2 grid (a
      // multi-jittered pattern without the jitter): a square's edge along
      // the pixel grid then covers a pixel to 1/ss^2, not 1/ss as on a
      // regular ss x ss grid, whose steps moved the corners by up to 1/(2 ss)
      // px with where they fell on the grid (and biased the calibration's k1;
      // docs/benchmarks.md, "Camera calibration").
      double sum = 0;
      for (int j = 0; j < ss; ++j)
        for (int i = 0; i < ss; ++i)
          sum += boardLevel(
              im, board, normal, lit,
              rayAt(st, tab.ray_xy, u, v, (i + (j + 0.5) / ss) / ss, (j + (i + 0.5) / ss) / ss));
      light[u] = static_cast<float>(sum / (ss * ss));
    }
    exposeRow(st, tab.noise, tab.gain, tab.offset, flicker, light.data(), v, rng, image);
  }
  return image;
}

}  // namespace collide::vision
