// Prints, to the last bit, what the vision library measures on simulated
// shots: every frame's pixels (a hash), every sphere and dot found, the
// velocities, spins and collision properties. Built twice, against
// collide_vision (the hot loops in AVX2 and baseline clones, the loader
// choosing AVX2 here) and against collide_vision_baseline (the same sources
// built with COLLIDE_NO_CLONES: baseline only); tests/vision/clones_agree.cmake
// runs both and requires the same output (vision/avx2_clones.hpp: each clone
// does the same operations in the same order, so both give the same numbers).
//
//   vision_clones_dump   (no arguments; the output on stdout)
#include <cstdint>
#include <cstdio>
#include <string>

#include "shot_fixture.hpp"
#include "vision/shot_analysis.hpp"

using namespace collide;
using namespace collide::vision;
using namespace collide::vision::testing;

namespace {

// FNV-1a over a frame's bytes: the renderer's clones drew the same pixels.
std::uint64_t frameHash(const cv::Mat& img) {
  std::uint64_t h = 1469598103934665603ull;
  for (int y = 0; y < img.rows; ++y) {
    const auto* row = img.ptr<std::uint8_t>(y);
    for (std::size_t b = 0; b < img.cols * img.elemSize(); ++b) h = (h ^ row[b]) * 1099511628211ull;
  }
  return h;
}

void printVec(const char* what, const Estimate3& e) {
  std::printf("  %s %a %a %a +- %a %a %a\n", what, e.value.x(), e.value.y(), e.value.z(),
              e.sigma.x(), e.sigma.y(), e.sigma.z());
}

void printMeasured(const char* what, const Measured& m) {
  std::printf("  %s %a +- %a\n", what, m.value, m.sigma);
}

void dumpShot(const char* name, const ShotSpec& spec) {
  const SimulatedShot shot = simulateShot(spec);
  std::printf("shot %s: %zu frames\n", name, shot.burst.frames.size());
  for (const Frame& f : shot.burst.frames)
    std::printf(" frame %lld pixels %016llx\n", static_cast<long long>(f.id),
                static_cast<unsigned long long>(frameHash(f.image)));
  const auto r = analyzeBurst(shot.burst, shot.settings);
  if (!r) {
    std::printf(" not analysed: %s\n", r.error().message.c_str());
    return;
  }
  for (const FrameDetections& fd : r->frames)
    for (int s = 0; s < 2; ++s) {
      if (!fd.sphere[s]) continue;
      const SphereDetection& d = *fd.sphere[s];
      std::printf(" frame %lld sphere %d: %a %a r %a sigma %a\n",
                  static_cast<long long>(fd.frame_id), s + 1, d.u_px, d.v_px, d.radius_px,
                  d.sigma_px);
      for (const DotDetection& dot : fd.dots[s]) std::printf("  dot %a %a\n", dot.u_px, dot.v_px);
    }
  for (int s = 0; s < 2; ++s) {
    const SphereKinematics& k = r->sphere[s];
    std::printf(" sphere %d\n", s + 1);
    printVec("v before", k.velocity_before_m_s);
    printVec("v after", k.velocity_after_m_s);
    printVec("w before", k.spin_before_rad_s);
    printVec("w after", k.spin_after_rad_s);
  }
  const CollisionProperties& c = r->collision;
  printMeasured("e", c.e);
  printMeasured("beta", c.beta);
  printMeasured("gamma_deg", c.gamma_deg);
  printMeasured("t_collision_s", c.t_collision_s);
  for (const std::string& flag : r->quality_flags) std::printf("  flag %s\n", flag.c_str());
}

}  // namespace

int main() {
#if defined(__x86_64__) && defined(__GNUC__)
  // On a processor without AVX2 both builds run the baseline: nothing compared.
  __builtin_cpu_init();
  if (!__builtin_cpu_supports("avx2")) {
    std::printf("no AVX2 on this processor: the clones are not compared\n");
    return 0;
  }
#endif
  // The even-light picture (sphere detector's profiles, dots, the renderer's
  // plain path).
  ShotSpec even;
  even.frames_before = 8, even.frames_after = 8;
  even.seed = 3;
  dumpShot("even light", even);

  // sim-lab's lamp and sensor (one-sided light: the shaded limb's second
  // pass; Mono12 with 10-bit data; the ray-caster's sensor loop).
  ShotSpec lab;
  lab.format = PixelFormat::Mono12;
  lab.frames_before = 8, lab.frames_after = 8;
  lab.exposure_us = 150;
  lab.noise_grey = 0;
  lab.seed = 5;
  lab.imaging = simLabImaging();
  dumpShot("lab light", lab);

  // The thesis' scale (37 px spheres, 240 x 192, photon-limited): the
  // whole-image silhouette fit.
  ShotSpec thesis;
  thesis.width = 240, thesis.height = 192;
  thesis.pixel_size_m = simThesisImaging().optics.pixel_size_m;
  thesis.frames_before = 7, thesis.frames_after = 7;
  thesis.noise_grey = 0;
  thesis.seed = 7;
  thesis.imaging = simThesisImaging();
  dumpShot("thesis scale", thesis);
  return 0;
}
