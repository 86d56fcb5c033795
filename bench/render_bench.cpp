// Renderer speed: the simulated camera must outrun the real one (SPEC: 1000
// frames/s) with room to spare. Target: >= 2000 frames/s on one core for
// 640 x 480 Mono8, two dotted spheres ~120 px across, noise 2 grey levels, no
// blur. items_per_second is frames per second.
//   build/bench/render_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only
// Measured (AMD EPYC VM, 2 cores, idle, median CPU time, 2026-11-29, session
// 24): Mono8 9,730 frames/s, Mono8 + motion blur (13 time samples) 886,
// Mono16 8,920. Realistic imaging as config/sim-lab.toml (ray-cast,
// docs/imaging.md): 2,090 frames/s, 352 with motion blur (7 time samples);
// its sensor alone 7,970. docs/benchmarks.md, "Rendering", has the breakdown.
#include <benchmark/benchmark.h>

#include "vision/render.hpp"

namespace {

using collide::Quat;
using collide::Vec3;
using namespace collide::vision;

constexpr double kPixelM = 2.1167e-4;  // object-plane pixel: 2.54 cm ~ 120 px

struct Scene {
  DotPattern p1 = DotPattern::random(1);
  DotPattern p2 = DotPattern::random(2);
  std::vector<SphereView> spheres;
  Scene() {
    // Two 120 px spheres about to touch, spinning, moving at ~3 m/s (14000 px/s
    // for 2.54 cm across 120 px).
    SphereView a, b;
    a.radius_px = b.radius_px = 60;
    a.centre_px = {250.3, 230.7};
    b.centre_px = {372.1, 255.4};
    a.orientation = Quat(Eigen::AngleAxisd(0.4, Vec3(1, 2, 0.5).normalized()));
    b.orientation = Quat(Eigen::AngleAxisd(2.1, Vec3(-1, 0.3, 1).normalized()));
    a.velocity_px_s = {14000, 1000};
    b.velocity_px_s = {-14000, -500};
    a.spin_rad_s = {0, 0, 300};
    b.spin_rad_s = {50, -200, 100};
    a.dots = &p1;
    b.dots = &p2;
    // The same spheres in the world, for the ray-cast imaging cases.
    for (SphereView* s : {&a, &b}) {
      s->centre_m =
          Vec3((s->centre_px.x() - 319.5) * kPixelM, -(s->centre_px.y() - 239.5) * kPixelM, 0.0);
      s->radius_m = s->radius_px * kPixelM;
      s->velocity_m_s = Vec3(s->velocity_px_s.x(), -s->velocity_px_s.y(), 0.0) * kPixelM;
    }
    spheres = {a, b};
  }
};

void run(benchmark::State& state, RenderSettings settings) {
  const Scene scene;
  const Renderer renderer(settings);
  std::uint64_t frame = 0;
  for (auto _ : state) {
    cv::Mat img = renderer.render(scene.spheres, frame++);
    benchmark::DoNotOptimize(img.data);
  }
  state.SetItemsProcessed(state.iterations());
}

RenderSettings base(PixelFormat f) {
  RenderSettings s;
  s.width = 640;
  s.height = 480;
  s.format = f;
  s.noise_grey = f == PixelFormat::Mono8 ? 2.0 : 2.0 * 257;
  return s;
}

void BM_RenderMono8(benchmark::State& state) {
  run(state, base(PixelFormat::Mono8));
}
BENCHMARK(BM_RenderMono8)->Unit(benchmark::kMicrosecond);

// 100 us exposure at 14000 px/s: 1.4 px of smear, 8 time samples chosen automatically.
void BM_RenderMono8MotionBlur(benchmark::State& state) {
  RenderSettings s = base(PixelFormat::Mono8);
  s.exposure_s = 100e-6;
  run(state, s);
}
BENCHMARK(BM_RenderMono8MotionBlur)->Unit(benchmark::kMicrosecond);

void BM_RenderMono16(benchmark::State& state) {
  run(state, base(PixelFormat::Mono16));
}
BENCHMARK(BM_RenderMono16)->Unit(benchmark::kMicrosecond);

// Realistic imaging (vision/imaging.hpp) as config/sim-lab.toml sets it: a
// lamp with a highlight, a 50 mm lens at 0.53 m with distortion, vignetting,
// flicker, fixed patterns, shot and read noise, 10-bit data in Mono16 words;
// 2 x 2 rays per pixel.
RenderSettings lab(double exposure_s) {
  RenderSettings s = base(PixelFormat::Mono16);
  s.exposure_s = exposure_s;
  Imaging im;
  im.lighting.lamp_direction = Vec3(-0.55, 0.45, 0.70);
  im.lighting.ambient = 0.12;
  im.lighting.sphere_albedo = 0.8;
  im.lighting.dot_albedo = 0.06;
  im.lighting.specular_strength = 0.3;
  im.lighting.specular_exponent = 80;
  im.lighting.backdrop_level = 0.07;
  im.optics.perspective = true;
  im.optics.focal_px = 2500;
  im.optics.principal_u_px = 319.5;
  im.optics.principal_v_px = 239.5;
  im.optics.centre_m = Vec3(0, 0, 0.5292);
  im.optics.k1 = -0.08;
  im.optics.k2 = 0.02;
  im.sensor.vignetting_cos4 = true;
  im.sensor.vignetting_falloff = 0.1;
  im.sensor.flicker_hz = 100;
  im.sensor.flicker_amplitude = 0.05;
  im.sensor.prnu = 0.008;
  im.sensor.dsnu = 0.002;
  im.sensor.hot_pixel_fraction = 2e-4;
  im.sensor.full_well_e = 20000;
  im.sensor.read_noise_e = 15;
  im.sensor.adc_bits = 10;
  s.imaging = im;
  return s;
}

void BM_RenderLabImaging(benchmark::State& state) {
  run(state, lab(0.0));
}
BENCHMARK(BM_RenderLabImaging)->Unit(benchmark::kMicrosecond);

// 100 us exposure: 1.4 px of travel plus 1.8 px of spin at the rim, 7 time
// samples chosen automatically (one per 0.5 px).
void BM_RenderLabImagingMotionBlur(benchmark::State& state) {
  run(state, lab(100e-6));
}
BENCHMARK(BM_RenderLabImagingMotionBlur)->Unit(benchmark::kMicrosecond);

// Breakdown: the lab's sensor alone (no spheres in view).
void BM_RenderLabImagingBackgroundOnly(benchmark::State& state) {
  const Renderer renderer(lab(0.0));
  std::uint64_t frame = 0;
  for (auto _ : state) benchmark::DoNotOptimize(renderer.render({}, frame++).data);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RenderLabImagingBackgroundOnly)->Unit(benchmark::kMicrosecond);

// Breakdown: the same frame without dots, and with no spheres at all.
void BM_RenderMono8NoDots(benchmark::State& state) {
  const Scene scene;
  std::vector<SphereView> plain = scene.spheres;
  for (SphereView& s : plain) s.dots = nullptr;
  const Renderer renderer(base(PixelFormat::Mono8));
  std::uint64_t frame = 0;
  for (auto _ : state) benchmark::DoNotOptimize(renderer.render(plain, frame++).data);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RenderMono8NoDots)->Unit(benchmark::kMicrosecond);

void BM_RenderMono8BackgroundOnly(benchmark::State& state) {
  const Renderer renderer(base(PixelFormat::Mono8));
  std::uint64_t frame = 0;
  for (auto _ : state) benchmark::DoNotOptimize(renderer.render({}, frame++).data);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RenderMono8BackgroundOnly)->Unit(benchmark::kMicrosecond);

// The set-up cost of realistic imaging: the simulated camera builds a
// Renderer whenever it is configured (at the rig's bring-up), which tabulates
// the lens, the vignetting, the fixed patterns and the noise for the sensor.
void BM_RenderLabImagingSetUp(benchmark::State& state) {
  for (auto _ : state) {
    const Renderer renderer(lab(0.0));
    benchmark::DoNotOptimize(&renderer);
  }
}
BENCHMARK(BM_RenderLabImagingSetUp)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
