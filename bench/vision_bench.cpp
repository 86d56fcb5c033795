// Speed of the vision core on one core (the *AllCores case and the whole
// shots on every core the process may use), with its accuracy as counters,
// and OpenCV's HoughCircles tuned for the same frames as the baseline (issue 4
// §4, issue 12).
//
//   build/bench/vision_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only
//
// Frames: 640 x 480 Mono8, two dotted 120 px spheres at random places, front-lit
// rim, 200 us of motion blur at ~2 m/s, noise 2 grey levels (what config/sim.toml's
// camera draws); the *Lab cases: sim-lab's imaging (labFrames, simLabImaging in
// tests/vision/shot_fixture.hpp; Shot200Lab a whole 200-frame shot drawn so). Counters: fps (frames
// per second), centre_err_px (RMS per axis over every sphere of the frame set), found (fraction of
// spheres found).
#include <benchmark/benchmark.h>
#include <malloc.h>

#include <cmath>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <tuple>
#include <vector>

#include "../tests/vision/shot_fixture.hpp"
#include "vision/dot_detector.hpp"
#include "vision/frame_parallel.hpp"
#include "vision/render.hpp"
#include "vision/shot_analysis.hpp"
#include "vision/sphere_detector.hpp"

using namespace collide;
using namespace collide::vision;

namespace {

struct FrameSet {
  std::vector<cv::Mat> images;
  std::vector<std::array<Eigen::Vector2d, 2>> centres;
  double radius = 0;
  std::vector<DotPattern> dots;
};

// 32 frames of two dotted spheres, apart, fully in view.
const FrameSet& frames(int width, int height, double radius, double noise) {
  static std::map<std::tuple<int, int, double>, FrameSet> cache;
  FrameSet& fs = cache[{width, height, radius}];
  if (!fs.images.empty()) return fs;
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<double> uni(0, 1);
  std::normal_distribution<double> nd;
  RenderSettings rs;
  rs.width = width;
  rs.height = height;
  rs.noise_grey = noise;
  rs.exposure_s = 200e-6;
  const Renderer renderer(rs);
  fs.radius = radius;
  fs.dots.reserve(64);
  const double px_per_m = radius / 0.0127;
  for (int f = 0; f < 32; ++f) {
    std::vector<SphereView> views;
    std::array<Eigen::Vector2d, 2> c;
    for (int k = 0; k < 2; ++k) {
      fs.dots.push_back(DotPattern::random(rng()));
      SphereView v;
      v.radius_px = radius;
      for (;;) {
        v.centre_px = {radius + 4 + uni(rng) * (width - 2 * radius - 8),
                       radius + 4 + uni(rng) * (height - 2 * radius - 8)};
        if (k == 0 || (v.centre_px - c[0]).norm() > 2 * radius + 6) break;
      }
      v.orientation = Quat(nd(rng), nd(rng), nd(rng), nd(rng)).normalized();
      v.velocity_px_s = {(k == 0 ? 2.0 : -2.0) * px_per_m, 0.2 * px_per_m};
      v.spin_rad_s = Vec3(nd(rng), nd(rng), nd(rng)) * 20;
      v.dots = &fs.dots.back();
      c[k] = v.centre_px;
      views.push_back(v);
    }
    fs.images.push_back(renderer.render(views, f));
    fs.centres.push_back(c);
  }
  return fs;
}

// 32 frames as config/sim-lab.toml's camera records them (issue 12): 640 x 480
// Mono12 with 10-bit data, one lamp from the upper left (ambient 0.12, dark
// right limbs), a glossy highlight, shot/read noise, fixed-pattern noise, hot
// pixels, 150 us of exposure at ~2 m/s; two dotted 120 px spheres, ray-cast
// orthographically so the true centres are exact.

const FrameSet& labFrames() {
  static FrameSet fs;
  if (!fs.images.empty()) return fs;
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> uni(0, 1);
  std::normal_distribution<double> nd;
  RenderSettings rs;
  rs.format = PixelFormat::Mono12;
  rs.exposure_s = 150e-6;
  const double pixel = 2.1167e-4, radius_m = 0.0127;
  rs.imaging = testing::simLabImaging();
  const Renderer renderer(rs);
  fs.radius = radius_m / pixel;
  fs.dots.reserve(64);
  for (int f = 0; f < 32; ++f) {
    std::vector<SphereView> views;
    std::array<Eigen::Vector2d, 2> c;
    for (int k = 0; k < 2; ++k) {
      fs.dots.push_back(DotPattern::random(rng()));
      SphereView v;
      for (;;) {
        c[k] = {fs.radius + 4 + uni(rng) * (640 - 2 * fs.radius - 8),
                fs.radius + 4 + uni(rng) * (480 - 2 * fs.radius - 8)};
        if (k == 0 || (c[1] - c[0]).norm() > 2 * fs.radius + 6) break;
      }
      v.radius_m = radius_m;
      v.centre_m = Vec3((c[k].x() - 319.5) * pixel, (239.5 - c[k].y()) * pixel, 0);
      v.velocity_m_s = Vec3(k == 0 ? 2.0 : -2.0, 0.2, 0);
      v.orientation = Quat(nd(rng), nd(rng), nd(rng), nd(rng)).normalized();
      v.spin_rad_s = Vec3(nd(rng), nd(rng), nd(rng)) * 20;
      v.dots = &fs.dots.back();
      views.push_back(v);
    }
    fs.images.push_back(renderer.render(views, f));
    fs.centres.push_back(c);
  }
  return fs;
}

// Errors of a list of circles (u, v) against the frame's two true centres.
void score(const std::vector<Eigen::Vector2d>& found, const std::array<Eigen::Vector2d, 2>& truth,
           double radius, double& sum2, int& matched) {
  for (const Eigen::Vector2d& t : truth) {
    double best = 1e9;
    for (const Eigen::Vector2d& f : found) best = std::min(best, (f - t).norm());
    if (best < 0.5 * radius) {
      sum2 += 0.5 * best * best;  // per axis
      ++matched;
    }
  }
}

void setCounters(benchmark::State& state, double sum2, int matched, int total) {
  state.SetItemsProcessed(state.iterations());
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["centre_err_px"] = matched ? std::sqrt(sum2 / matched) : NAN;
  state.counters["found"] = static_cast<double>(matched) / total;
}

// The detector as the lab cases run it: the radius range given, as the
// analysis gives it from the spheres' diameters and the pixel size.
SphereDetector labDetector(const FrameSet& fs) {
  SphereDetectorSettings ds;
  ds.min_radius_px = 0.6 * fs.radius;
  ds.max_radius_px = 3 * fs.radius;
  return SphereDetector(ds);
}

void BM_SphereDetector(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const FrameSet& fs = frames(w, h, static_cast<double>(state.range(2)) / 2, 2.0);
  // The radius range analyzeBurst sets when the pixel size is known.
  SphereDetectorSettings ds;
  ds.min_radius_px = 0.6 * fs.radius;
  ds.max_radius_px = 3 * fs.radius;
  const SphereDetector det(ds);
  std::size_t i = 0;
  for (auto _ : state) {
    FrameSpheres f = det.detect(fs.images[i++ % fs.images.size()], 255);
    benchmark::DoNotOptimize(f);
  }
  double sum2 = 0;
  int matched = 0;
  for (std::size_t k = 0; k < fs.images.size(); ++k) {
    std::vector<Eigen::Vector2d> c;
    for (const auto& s : det.detect(fs.images[k], 255).spheres)
      c.emplace_back(s.circle.u, s.circle.v);
    score(c, fs.centres[k], fs.radius, sum2, matched);
  }
  setCounters(state, sum2, matched, 2 * static_cast<int>(fs.images.size()));
}

// The detector on sim-lab's imaging (labFrames).
void BM_SphereDetectorLab(benchmark::State& state) {
  const FrameSet& fs = labFrames();
  const SphereDetector det = labDetector(fs);
  std::size_t i = 0;
  for (auto _ : state) {
    FrameSpheres f = det.detect(fs.images[i++ % fs.images.size()], 4095);
    benchmark::DoNotOptimize(f);
  }
  double sum2 = 0;
  int matched = 0;
  for (std::size_t k = 0; k < fs.images.size(); ++k) {
    std::vector<Eigen::Vector2d> c;
    for (const auto& s : det.detect(fs.images[k], 4095).spheres)
      c.emplace_back(s.circle.u, s.circle.v);
    score(c, fs.centres[k], fs.radius, sum2, matched);
  }
  setCounters(state, sum2, matched, 2 * static_cast<int>(fs.images.size()));
}

// HoughCircles on the same lab frames (scaled to 8 bit first, which it needs;
// the scaling is timed with it).
void BM_HoughCirclesLab(benchmark::State& state) {
  cv::setNumThreads(1);
  const FrameSet& fs = labFrames();
  const int r = static_cast<int>(fs.radius);
  const auto hough = [&](const cv::Mat& img) {
    cv::Mat img8, blurred;
    img.convertTo(img8, CV_8U, 255.0 / 4095.0);
    cv::GaussianBlur(img8, blurred, cv::Size(5, 5), 1.2);
    std::vector<cv::Vec3f> circles;
    cv::HoughCircles(blurred, circles, cv::HOUGH_GRADIENT, 1, 1.5 * r, 60, 20, r - r / 8,
                     r + r / 8);
    return circles;
  };
  std::size_t i = 0;
  for (auto _ : state) {
    auto c = hough(fs.images[i++ % fs.images.size()]);
    benchmark::DoNotOptimize(c);
  }
  double sum2 = 0;
  int matched = 0;
  for (std::size_t k = 0; k < fs.images.size(); ++k) {
    std::vector<Eigen::Vector2d> c;
    for (const cv::Vec3f& v : hough(fs.images[k])) c.emplace_back(v[0], v[1]);
    score(c, fs.centres[k], fs.radius, sum2, matched);
  }
  setCounters(state, sum2, matched, 2 * static_cast<int>(fs.images.size()));
}

// OpenCV's Hough transform, tuned on these frames: a light blur first (it
// needs one with noise and dots), the accumulator at full resolution, the
// radius range known, two circles at least a diameter apart.
void BM_HoughCircles(benchmark::State& state) {
  cv::setNumThreads(1);
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const FrameSet& fs = frames(w, h, static_cast<double>(state.range(2)) / 2, 2.0);
  const bool alt = state.range(3) != 0;
  const int r = static_cast<int>(fs.radius);
  const auto hough = [&](const cv::Mat& img) {
    cv::Mat blurred;
    cv::GaussianBlur(img, blurred, cv::Size(5, 5), 1.2);
    std::vector<cv::Vec3f> circles;
    if (alt)
      cv::HoughCircles(blurred, circles, cv::HOUGH_GRADIENT_ALT, 1.5, 1.5 * r, 150, 0.8, r - r / 8,
                       r + r / 8);
    else
      cv::HoughCircles(blurred, circles, cv::HOUGH_GRADIENT, 1, 1.5 * r, 100, 30, r - r / 8,
                       r + r / 8);
    return circles;
  };
  std::size_t i = 0;
  for (auto _ : state) {
    auto c = hough(fs.images[i++ % fs.images.size()]);
    benchmark::DoNotOptimize(c);
  }
  double sum2 = 0;
  int matched = 0;
  for (std::size_t k = 0; k < fs.images.size(); ++k) {
    std::vector<Eigen::Vector2d> c;
    for (const cv::Vec3f& v : hough(fs.images[k])) c.emplace_back(v[0], v[1]);
    score(c, fs.centres[k], fs.radius, sum2, matched);
  }
  setCounters(state, sum2, matched, 2 * static_cast<int>(fs.images.size()));
}

// The whole per-frame work of analyzeBurst: both spheres, then the dots on each.
void BM_FramePipeline(benchmark::State& state) {
  const FrameSet& fs = frames(640, 480, 60, 2.0);
  const SphereDetector det;
  std::size_t i = 0;
  int dots = 0;
  for (auto _ : state) {
    const cv::Mat& img = fs.images[i++ % fs.images.size()];
    const FrameSpheres f = det.detect(img, 255);
    for (const SphereMeasurement& s : f.spheres)
      dots += static_cast<int>(findDots(img, s, 255).dots.size());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["dots_per_frame"] = static_cast<double>(dots) / state.iterations();
}

// One lab frame's per-frame work: both spheres, then the dots on each; the
// number of dots found.
int labFrameWork(const SphereDetector& det, const cv::Mat& img) {
  int n = 0;
  for (const SphereMeasurement& s : det.detect(img, 4095).spheres)
    n += static_cast<int>(findDots(img, s, 4095).dots.size());
  return n;
}

// The whole per-frame work on sim-lab's imaging (the imaging issue 12's
// speed targets name), on one core.
void BM_FramePipelineLab(benchmark::State& state) {
  const FrameSet& fs = labFrames();
  const SphereDetector det = labDetector(fs);
  std::size_t i = 0;
  int dots = 0;
  for (auto _ : state) dots += labFrameWork(det, fs.images[i++ % fs.images.size()]);
  state.SetItemsProcessed(state.iterations());
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["dots_per_frame"] = static_cast<double>(dots) / state.iterations();
}

// The same over a 200-frame burst as analyzeBurst runs it: the frames spread
// over the cores this process may use (forEachFrame), wall time. fps is the
// throughput on this machine, `threads` the threads it used.
void BM_FramePipelineLabAllCores(benchmark::State& state) {
  const FrameSet& fs = labFrames();
  const SphereDetector det = labDetector(fs);
  constexpr std::size_t kFrames = 200;
  std::vector<int> dots(kFrames);
  for (auto _ : state) {
    forEachFrame(kFrames, [&](std::size_t k) {
      dots[k] = labFrameWork(det, fs.images[k % fs.images.size()]);
    });
    benchmark::DoNotOptimize(dots.data());
  }
  const double frames_done = static_cast<double>(state.iterations()) * kFrames;
  state.SetItemsProcessed(static_cast<std::int64_t>(frames_done));
  state.counters["fps"] = benchmark::Counter(frames_done, benchmark::Counter::kIsRate);
  state.counters["threads"] = frameThreads();
  double sum = 0;
  for (const int n : dots) sum += n;
  state.counters["dots_per_frame"] = sum / kFrames;
}

// A 200-frame shot (100 before, 100 after the impact): slow enough for both
// spheres to stay in view ~100 frames.
testing::ShotSpec shot200Spec() {
  testing::ShotSpec spec;
  spec.seed = 77;
  spec.frames_before = 100;
  spec.frames_after = 100;
  spec.speed1_m_s = 0.5;
  spec.speed2_m_s = 0.5;
  spec.spin_max_rad_s = 40;
  return spec;
}

// One simulated shot analysed end to end, again and again.
void analyseShot(benchmark::State& state, const testing::SimulatedShot& shot) {
  double e_err = 0;
  for (auto _ : state) {
    auto r = analyzeBurst(shot.burst, shot.settings);
    if (!r) {
      state.SkipWithError(r.error().message.c_str());
      return;
    }
    e_err = r->collision.e.value - shot.truth.e;
  }
  state.counters["frames"] = static_cast<double>(shot.burst.frames.size());
  state.counters["e_err"] = e_err;
  state.counters["shots_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_Shot200(benchmark::State& state) {
  static const testing::SimulatedShot shot = testing::simulateShot(shot200Spec());
  analyseShot(state, shot);
}

// The same shot drawn with sim-lab's lamp and sensor (simLabImaging: one-sided
// light with a highlight, 10 bits in Mono12, shot, read and fixed-pattern
// noise, hot pixels, 150 us exposure): the imaging issue 12's speed targets
// name.
void BM_Shot200Lab(benchmark::State& state) {
  static const testing::SimulatedShot shot = [] {
    testing::ShotSpec spec = shot200Spec();
    spec.format = PixelFormat::Mono12;
    spec.exposure_us = 150;
    spec.imaging = testing::simLabImaging();
    return testing::simulateShot(spec);
  }();
  analyseShot(state, shot);
}

}  // namespace

BENCHMARK(BM_SphereDetector)
    ->Args({640, 480, 120})
    ->Args({240, 192, 37})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_HoughCircles)
    ->Args({640, 480, 120, 0})
    ->Args({640, 480, 120, 1})
    ->Args({240, 192, 37, 0})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SphereDetectorLab)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_HoughCirclesLab)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FramePipeline)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FramePipelineLab)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FramePipelineLabAllCores)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Shot200)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Shot200Lab)->Unit(benchmark::kMillisecond);

// glibc's malloc serves a large block from a fresh mmap until a large block
// is freed, and that history depends on what ran before in the process (the
// frame sets' renderer, the other cases). HoughCircles allocates large
// buffers per call, so its time moved 2.5x with it (page faults: 8,000 vs
// 83,000 over the same calls). Large blocks come from the heap throughout,
// as in a long-running program that has warmed up: every case is timed in
// that steady state.
int main(int argc, char** argv) {
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
