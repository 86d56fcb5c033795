#include "vision/shot_tracking.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "vision/frame_parallel.hpp"

namespace collide::vision {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Where a track is expected in the next frame: on the line through its last
// two points (constant velocity in the image). The points are the walk's,
// latest first, then (walking back from the seed after walking forward) those
// beyond the seed, nearest first. While the track's last two whole outlines
// are recent (kWholeFrames steps) the line goes through them, passing over
// outlines cut by the border: a cut outline's centre can be tens of px off
// (noise at the border), and one such point as the last of two would send
// the prediction, and the track, astray. Older whole outlines would carry a
// velocity from before a collision the cut sphere has since had. The gate
// near contact counts from the last point of any kind.
struct Prediction {
  bool have = false;
  Eigen::Vector2d at{0, 0};        ///< px, at the frame's time
  Eigen::Vector2d last{0, 0};      ///< px, the last point seen
  Eigen::Vector2d velocity{0, 0};  ///< px/s (zero from a single point)
  double t_last = 0;               ///< s, when it was last seen
};

constexpr int kWholeFrames = 8;

Prediction predict(const std::vector<FrameData>& frames, const std::vector<int>& order, int upto,
                   int dir, int track, double t) {
  struct Point {
    Eigen::Vector2d at;
    double t;
  };
  // The track's last two points, and its last two whole ones within
  // kWholeFrames steps.
  std::vector<Point> any, whole;
  const int n = static_cast<int>(frames.size());
  for (int i = upto;; --i) {
    const int step = upto + 1 - i;
    if (any.size() == 2 && (whole.size() == 2 || step > kWholeFrames)) break;
    const int k = i >= 0 ? order[i] : order[0] + i * dir;  // beyond the seed when i < 0
    if (k < 0 || k >= n) break;
    const SphereMeasurement* m = trackAt(frames[k], track);
    if (!m) continue;
    const Point p{{m->circle.u, m->circle.v}, frames[k].t};
    if (any.size() < 2) any.push_back(p);
    if (!m->cut_by_border && whole.size() < 2 && step <= kWholeFrames) whole.push_back(p);
  }
  Prediction out;
  if (any.empty()) return out;
  out.have = true;
  out.last = any[0].at;
  out.t_last = any[0].t;
  const std::vector<Point>& pair = whole.size() == 2 ? whole : any;
  if (pair.size() == 2 && pair[0].t != pair[1].t)
    out.velocity = (pair[0].at - pair[1].at) / (pair[0].t - pair[1].t);
  out.at = pair[0].at + out.velocity * (t - pair[0].t);
  return out;
}

// How far from its prediction each track's sphere may be found. At contact
// the velocities change by up to (1 + e) |v_rel| <= 2 |v_rel| (the relative
// velocity of the centres), so a track last seen touching the other one may
// be that much further off per second since; elsewhere `gate`.
std::array<double, 2> gates(const std::array<Prediction, 2>& p, double t, double gate,
                            double contact_px) {
  std::array<double, 2> g{gate, gate};
  if (!p[0].have || !p[1].have || contact_px <= 0) return g;
  if ((p[0].last - p[1].last).norm() > 1.2 * contact_px) return g;
  const double dv = (p[0].velocity - p[1].velocity).norm();
  for (int k = 0; k < 2; ++k) g[k] += 2 * dv * std::max(0.0, t - p[k].t_last);
  return g;
}

// Assigns each frame's candidates to the two tracks, walking away from the
// seed frame in the given direction.
void track(std::vector<FrameData>& frames, int seed, int dir, double gate, double contact_px) {
  std::vector<int> order;  // frames in walking order, seed first
  for (int i = seed; i >= 0 && i < static_cast<int>(frames.size()); i += dir) order.push_back(i);
  for (std::size_t o = 1; o < order.size(); ++o) {
    FrameData& f = frames[order[o]];
    const int upto = static_cast<int>(o) - 1;
    const std::array<Prediction, 2> pred{predict(frames, order, upto, dir, 0, f.t),
                                         predict(frames, order, upto, dir, 1, f.t)};
    const std::array<double, 2> g = gates(pred, f.t, gate, contact_px);
    // Best assignment of up to one candidate per track (cost: distance to the
    // prediction; leaving a track empty costs its gate).
    double best = g[0] + g[1] + 1;
    std::array<int, 2> pick{-1, -1};
    const int n = static_cast<int>(f.candidates.size());
    for (int a = -1; a < n; ++a)
      for (int b = -1; b < n; ++b) {
        if (a >= 0 && a == b) continue;
        double cost = 0;
        bool ok = true;
        for (int k = 0; k < 2; ++k) {
          const int c = k == 0 ? a : b;
          if (c < 0) {
            cost += g[k];
            continue;
          }
          if (!pred[k].have) {
            ok = false;
            break;
          }
          const CircleFit& cf = f.found.spheres[f.candidates[c]].circle;
          const double d = (Eigen::Vector2d(cf.u, cf.v) - pred[k].at).norm();
          if (d > g[k]) {
            ok = false;
            break;
          }
          cost += d;
        }
        if (ok && cost < best) best = cost, pick = {a, b};
      }
    for (int k = 0; k < 2; ++k) f.assigned[k] = pick[k] >= 0 ? f.candidates[pick[k]] : -1;
  }
}

}  // namespace

std::string fmt(const char* spec, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, spec, v);
  return buf;
}

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

Result<BurstFrames> prepareFrames(const Burst& burst, double fps_setting) {
  BurstFrames bf;
  std::vector<std::size_t>& good = bf.good;
  for (std::size_t i = 0; i < burst.frames.size(); ++i)
    if (burst.frames[i].good()) good.push_back(i);
  if (good.empty())
    return fail("no usable frame in the burst (" + std::to_string(burst.frames.size()) +
                " frames, none complete): nothing to analyse; record the shot again");
  const cv::Mat& first = burst.frames[good.front()].image;
  bf.max_value = maxValue(burst.format);
  for (const std::size_t i : good) {
    const cv::Mat& img = burst.frames[i].image;
    if (img.size() != first.size() || img.type() != first.type())
      return fail("frames of different sizes or pixel types: frame " +
                  std::to_string(burst.frames[good.front()].id) + " is " +
                  std::to_string(first.cols) + "x" + std::to_string(first.rows) + ", frame " +
                  std::to_string(burst.frames[i].id) + " is " + std::to_string(img.cols) + "x" +
                  std::to_string(img.rows) + "; analyse frames of one recording only");
    if (img.channels() != 1 || (img.depth() != CV_8U && img.depth() != CV_16U))
      return fail("frame " + std::to_string(burst.frames[i].id) +
                  " is not a one-channel 8- or 16-bit image");
  }
  if (first.depth() != (burst.format == PixelFormat::Mono8 ? CV_8U : CV_16U))
    return fail(std::string("the burst says ") + toString(burst.format) + " but its frames hold " +
                (first.depth() == CV_8U ? "8" : "16") + "-bit pixels");
  const double fps = fps_setting > 0 ? fps_setting : burst.fps;
  bool stamps_ok = true;
  for (std::size_t k = 1; k < good.size(); ++k)
    if (burst.frames[good[k]].timestamp_ns <= burst.frames[good[k - 1]].timestamp_ns)
      stamps_ok = false;
  if (good.size() > 1 && !stamps_ok && !(fps > 0))
    return fail(
        "the frames carry no increasing timestamps and no frame rate is known: give "
        "the frame rate (--fps)");
  std::vector<FrameData>& data = bf.data;
  data.resize(good.size());
  for (std::size_t k = 0; k < good.size(); ++k) {
    const Frame& f = burst.frames[good[k]];
    data[k].index = good[k];
    data[k].t = stamps_ok ? (f.timestamp_ns - burst.frames[good.front()].timestamp_ns) * 1e-9
                          : (f.id - burst.frames[good.front()].id) / fps;
  }
  bf.frame_dt =
      good.size() > 1
          ? (data.back().t - data.front().t) /
                std::max<double>(1, burst.frames[good.back()].id - burst.frames[good.front()].id)
          : (fps > 0 ? 1 / fps : 1e-3);
  return bf;
}

namespace {

SphereDetector shotDetector(const std::array<double, 2>& diam, double pixel_size_m,
                            SphereDetectorSettings::Polarity polarity,
                            const std::optional<PinholeCamera>& camera) {
  SphereDetectorSettings ds;
  ds.polarity = polarity;
  ds.camera = camera;
  if (pixel_size_m > 0) {
    // Generous bounds: a wrong diameter must still be measured, to be reported.
    ds.min_radius_px = 0.15 * std::min(diam[0], diam[1]) / pixel_size_m;
    ds.max_radius_px = 1.5 * std::max(diam[0], diam[1]) / pixel_size_m;
  }
  return SphereDetector(ds);
}

// Through a lens an outline's mean semi-axis grows off the optical axis
// (PinholeCamera::outlineShape): its factor at the circle's place, 1 without
// a camera.
double offAxisStretch(const std::optional<PinholeCamera>& camera, const CircleFit& c) {
  return camera ? 0.5 * camera->outlineShape(c.u, c.v).trace() : 1.0;
}

// The radius track s has at frame k by its whole (uncut) outlines, px, with
// its standard uncertainty: a straight line against time through the radii
// of the (up to) kRadiusFrames whole frames nearest to k (under perspective
// the size follows the depth), its prediction's standard error from their
// scatter about it. Their mean when they span no time or are too few for a
// line; {NaN, NaN} when the track has none. Through a lens the radii are
// taken without their off-axis stretch, which is then put back at frame k.
constexpr std::size_t kRadiusFrames = 40;

std::pair<double, double> wholeOutlineRadius(const std::vector<FrameData>& data, int k, int s,
                                             const std::optional<PinholeCamera>& camera) {
  std::vector<std::pair<int, int>> near;  // (distance in frames, frame)
  for (int j = 0; j < static_cast<int>(data.size()); ++j)
    if (const SphereMeasurement* m = trackAt(data[j], s); m && !m->cut_by_border)
      near.emplace_back(std::abs(j - k), j);
  if (near.empty()) return {kNaN, kNaN};
  const std::size_t n = std::min(near.size(), kRadiusFrames);
  std::partial_sort(near.begin(), near.begin() + n, near.end());
  Eigen::VectorXd t(n), r(n);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = data[near[i].second].t - data[k].t;  // so the prediction is the intercept
    const CircleFit& c = trackAt(data[near[i].second], s)->circle;
    r[i] = c.radius / offAxisStretch(camera, c);
  }
  const double stretch = offAxisStretch(camera, trackAt(data[k], s)->circle);
  const double t_mean = t.mean(), r_mean = r.mean();
  const double stt = (t.array() - t_mean).square().sum();
  if (n < 5 || !(stt > 0)) {
    const double spread = n > 1 ? std::sqrt((r.array() - r_mean).square().sum() / (n - 1)) : kNaN;
    return {stretch * r_mean, stretch * spread / std::sqrt(static_cast<double>(n))};
  }
  const double slope = ((t.array() - t_mean) * (r.array() - r_mean)).sum() / stt;
  const double at_k = r_mean - slope * t_mean;
  const double s2 = (r.array() - r_mean - slope * (t.array() - t_mean)).square().sum() / (n - 2);
  return {stretch * at_k, stretch * std::sqrt(s2 * (1.0 / n + t_mean * t_mean / stt))};
}

}  // namespace

int detectSpheres(const Burst& burst, std::vector<FrameData>& data,
                  const std::array<double, 2>& diam, double pixel_size_m, int max_value,
                  const std::function<void(int, int)>& progress,
                  SphereDetectorSettings::Polarity polarity,
                  const std::optional<PinholeCamera>& camera) {
  const SphereDetector detector = shotDetector(diam, pixel_size_m, polarity, camera);
  forEachFrame(
      data.size(),
      [&](std::size_t k) {
        data[k].found = detector.detect(burst.frames[data[k].index].image, max_value);
      },
      progress);
  int saturated = 0;
  for (const FrameData& f : data) saturated += f.found.saturated;
  return saturated;
}

Result<SphereBlobs> selectSphereBlobs(std::vector<FrameData>& data,
                                      const std::array<double, 2>& diam, double pixel_size_m) {
  SphereBlobs out;
  std::vector<double> radii;
  for (const FrameData& f : data)
    for (const SphereMeasurement& m : f.found.spheres)
      if (!m.cut_by_border) radii.push_back(m.circle.radius);
  if (radii.empty())
    return fail(
        "no sphere found in any of the " + std::to_string(data.size()) + " frames (" +
        (data.front().found.notes.empty() ? std::string("no bright round blob")
                                          : data.front().found.notes[0]) +
        "); check the exposure, that the spheres are in view, and the polarity (--polarity "
        "dark for silhouettes on a backlight, bright for lit spheres on a dark background)");
  const double ratio = diam[1] / diam[0];
  std::array<double, 2>& r_expect = out.r_expect_px;
  if (std::abs(ratio - 1) < 0.02) {
    r_expect[0] = r_expect[1] = median(radii);
  } else {
    // Two sizes: split the radii at the geometric mean of their extremes.
    std::sort(radii.begin(), radii.end());
    const double cut = std::sqrt(radii.front() * radii.back());
    std::vector<double> lo, hi;
    for (const double r : radii) (r < cut ? lo : hi).push_back(r);
    const double rl = lo.empty() ? kNaN : median(lo), rh = hi.empty() ? kNaN : median(hi);
    r_expect = ratio > 1 ? std::array<double, 2>{rl, rh} : std::array<double, 2>{rh, rl};
    if (!std::isfinite(rl) || !std::isfinite(rh))
      return fail("the diameters given differ (" + fmt("%.4g", diam[0] * 1e3) + " and " +
                  fmt("%.4g", diam[1] * 1e3) + " mm) but all spheres found measure about " +
                  fmt("%.1f", 2 * median(radii)) + " px across: check --diameter2-mm");
  }
  if (pixel_size_m > 0)
    for (int s = 0; s < 2; ++s) {
      const double d_img = 2 * r_expect[s] * pixel_size_m;
      if (std::abs(d_img / diam[s] - 1) > 0.05)
        return fail("sphere " + std::to_string(s + 1) + " measures " +
                    fmt("%.2f", 2 * r_expect[s]) + " px across, which at a pixel size of " +
                    fmt("%.5g", pixel_size_m * 1e3) + " mm is " + fmt("%.2f", d_img * 1e3) +
                    " mm, but its diameter is given as " + fmt("%.2f", diam[s] * 1e3) +
                    " mm: check the diameter (--diameter-mm) or the pixel size");
    }
  for (FrameData& f : data) {
    for (int i = 0; i < static_cast<int>(f.found.spheres.size()); ++i) {
      const double r = f.found.spheres[i].circle.radius;
      const bool fits =
          std::abs(r / r_expect[0] - 1) < 0.15 || std::abs(r / r_expect[1] - 1) < 0.15;
      if (fits) {
        f.candidates.push_back(i);
      } else if (f.found.spheres[i].cut_by_border) {
        // A sliver at the frame's edge (a sphere entering or leaving) measures
        // a poor radius: left out, nothing to report.
        f.found.notes.push_back("a blob cut by the frame's edge measures " + fmt("%.1f", r) +
                                " px in radius: left out");
      }  // a whole one is counted (or not) once the tracks are known
    }
  }
  return out;
}

namespace {

// The seed: the first frame with two separate spheres whose outlines are
// whole, else (no such frame) whose outlines may be cut by the border. An
// outline cut by the border measures a poor centre (a sphere entering through
// a noisy border can give two cut circles, one of them wrong), and the first
// steps from the seed set the track's velocity. -1: none.
int seedFrame(const std::vector<FrameData>& data) {
  for (const bool whole : {true, false})
    for (int k = 0; k < static_cast<int>(data.size()); ++k) {
      const FrameData& f = data[k];
      if (f.candidates.size() != 2) continue;
      const SphereMeasurement &a = f.found.spheres[f.candidates[0]],
                              &b = f.found.spheres[f.candidates[1]];
      if (a.touching || b.touching) continue;
      if (whole && (a.cut_by_border || b.cut_by_border)) continue;
      return k;
    }
  return -1;
}

// Where track s is in frame k: its own point there, else the line through
// its two whole outlines nearest to k on one side (a sphere entering or
// leaving through the border is whole only on one side of its cut frames),
// else its one whole outline; nullopt: the track has none.
std::optional<Eigen::Vector2d> trackPosition(const std::vector<FrameData>& data, int k, int s) {
  if (const SphereMeasurement* m = trackAt(data[k], s))
    return Eigen::Vector2d(m->circle.u, m->circle.v);
  const int n = static_cast<int>(data.size());
  auto wholeFrom = [&](int from, int dir) {
    for (int j = from; j >= 0 && j < n; j += dir)
      if (const SphereMeasurement* m = trackAt(data[j], s); m && !m->cut_by_border) return j;
    return -1;
  };
  int best[2] = {-1, -1};
  for (const int dir : {-1, +1}) {
    const int j1 = wholeFrom(k + dir, dir);
    if (j1 < 0 || (best[0] >= 0 && std::abs(j1 - k) >= std::abs(best[0] - k))) continue;
    best[0] = j1;
    best[1] = wholeFrom(j1 + dir, dir);
  }
  if (best[0] < 0) return std::nullopt;
  const CircleFit& a = trackAt(data[best[0]], s)->circle;
  Eigen::Vector2d at(a.u, a.v);
  if (best[1] >= 0 && data[best[1]].t != data[best[0]].t) {
    const CircleFit& b = trackAt(data[best[1]], s)->circle;
    at += (at - Eigen::Vector2d(b.u, b.v)) * (data[k].t - data[best[0]].t) /
          (data[best[0]].t - data[best[1]].t);
  }
  return at;
}

// The track (0, 1) whose sphere covers (u, v) in frame k (trackPosition);
// -1: neither. A blob centred on a tracked sphere is that sphere read a
// second time (a cut outline read twice through noise at the border), not
// another object.
int coveringTrack(const std::vector<FrameData>& data, int k, double u, double v,
                  const std::array<double, 2>& r_px) {
  for (int s = 0; s < 2; ++s)
    if (const auto at = trackPosition(data, k, s);
        at && (*at - Eigen::Vector2d(u, v)).norm() < r_px[s])
      return s;
  return -1;
}

// Blobs on neither track: a sliver cut by the border of the wrong size is
// left out (noted by selectSphereBlobs); one centred on a tracked sphere is
// noted as a second reading of it; any other is counted into third_blobs.
void countThirdBlobs(std::vector<FrameData>& data, SphereBlobs& blobs) {
  for (int k = 0; k < static_cast<int>(data.size()); ++k) {
    FrameData& f = data[k];
    for (int i = 0; i < static_cast<int>(f.found.spheres.size()); ++i) {
      if (i == f.assigned[0] || i == f.assigned[1]) continue;
      const SphereMeasurement& m = f.found.spheres[i];
      const bool candidate =
          std::find(f.candidates.begin(), f.candidates.end(), i) != f.candidates.end();
      if (!candidate && m.cut_by_border) continue;
      const int s = coveringTrack(data, k, m.circle.u, m.circle.v, blobs.r_expect_px);
      if (s >= 0) {
        f.found.notes.push_back("a round blob of radius " + fmt("%.1f", m.circle.radius) +
                                " px centred on sphere " + std::to_string(s + 1) +
                                " is a second reading of it: ignored");
        continue;
      }
      ++blobs.third_blobs;
      f.found.notes.push_back(candidate
                                  ? std::string("a sphere-sized blob off both tracks: ignored")
                                  : "a round blob of radius " + fmt("%.1f", m.circle.radius) +
                                        " px is not a sphere of this shot (expected " +
                                        fmt("%.1f", blobs.r_expect_px[0]) + " px): ignored");
    }
  }
}

}  // namespace

Status trackSpheres(std::vector<FrameData>& data, SphereBlobs& blobs,
                    const std::array<double, 2>& diam) {
  const int seed = seedFrame(data);
  if (seed < 0) {
    int one = 0;
    for (const FrameData& f : data) one += !f.candidates.empty();
    return fail("never two separate spheres in one frame (" + std::to_string(one) + " of " +
                std::to_string(data.size()) +
                " frames show one sphere): a collision needs both spheres in view before impact");
  }
  {
    FrameData& f = data[seed];
    // Candidates are sorted by u: the left one is sphere 1.
    f.assigned = {f.candidates[0], f.candidates[1]};
    const double gate = 0.5 * std::min(blobs.r_expect_px[0], blobs.r_expect_px[1]);
    const double contact_px = blobs.r_expect_px[0] + blobs.r_expect_px[1];
    track(data, seed, +1, gate, contact_px);
    track(data, seed, -1, gate, contact_px);
  }
  if (std::abs(diam[1] / diam[0] - 1) >= 0.02) {
    // Two sizes: sphere 1 (left) must be the one whose diameter came first.
    const SphereMeasurement &a = *trackAt(data[seed], 0), &b = *trackAt(data[seed], 1);
    if ((a.circle.radius < b.circle.radius) != (diam[0] < diam[1]))
      return fail("the left sphere measures " + fmt("%.1f", 2 * a.circle.radius) +
                  " px across and the right one " + fmt("%.1f", 2 * b.circle.radius) +
                  " px, but the diameters given say the opposite: give the left sphere's "
                  "diameter first");
  }
  countThirdBlobs(data, blobs);
  return Ok{};
}

int remeasureCutOutlines(const Burst& burst, std::vector<FrameData>& data,
                         const std::array<double, 2>& diam, double pixel_size_m, int max_value,
                         SphereDetectorSettings::Polarity polarity,
                         const std::optional<PinholeCamera>& camera) {
  const SphereDetector detector = shotDetector(diam, pixel_size_m, polarity, camera);
  std::vector<std::pair<int, int>> cut;  // (frame, track)
  for (int k = 0; k < static_cast<int>(data.size()); ++k)
    for (int s = 0; s < 2; ++s)
      if (const SphereMeasurement* m = trackAt(data[k], s); m && m->cut_by_border)
        cut.emplace_back(k, s);
  std::vector<std::pair<double, double>> held(cut.size());  // radius, sigma
  for (std::size_t i = 0; i < cut.size(); ++i)
    held[i] = wholeOutlineRadius(data, cut[i].first, cut[i].second, camera);
  std::vector<std::optional<SphereMeasurement>> again(cut.size());
  forEachFrame(cut.size(), [&](std::size_t i) {
    const auto [k, s] = cut[i];
    const auto [r, sigma] = held[i];
    if (!std::isfinite(r)) return;
    again[i] =
        detector.measureWithRadius(burst.frames[data[k].index].image, max_value, data[k].found,
                                   *trackAt(data[k], s), r, std::isfinite(sigma) ? sigma : 0.0);
  });
  int done = 0;
  for (std::size_t i = 0; i < cut.size(); ++i) {
    if (!again[i]) continue;
    const auto [k, s] = cut[i];
    data[k].found.spheres[data[k].assigned[s]] = *again[i];
    ++done;
  }
  return done;
}

std::array<double, 2> trackRadii(const std::vector<FrameData>& data) {
  std::array<double, 2> r_med;
  for (int s = 0; s < 2; ++s) {
    std::vector<double> r;
    for (const FrameData& f : data)
      if (const SphereMeasurement* m = trackAt(f, s); m && !m->cut_by_border)
        r.push_back(m->circle.radius);
    if (r.empty())
      for (const FrameData& f : data)
        if (const SphereMeasurement* m = trackAt(f, s)) r.push_back(m->circle.radius);
    r_med[s] = median(r);
  }
  return r_med;
}

}  // namespace collide::vision
