// Accuracy of `collide calibrate-camera` on a simulated camera's own targets
// (issue 11): for each run the profile's simulation.seed changes (so the
// sensor noise and fixed patterns), the camera draws its chessboard views
// through its lens (app::renderCalibrationTargets) and the calibration fits
// them (app::calibrateFromFiles). Against the lens the profile states:
// the error and stated sigma of f, k1, the principal point and the plane's
// pixel scale, their pulls (error / sigma: RMS near 1 if the sigmas are
// right), and the reprojection RMS.
//
//   build/bench/calibration_bench [--runs N] [--profile FILE] [--views V] [--square-mm S]
//
// Figures and the command used go in docs/benchmarks.md ("Camera calibration").
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "app/calibrate.hpp"
#include "app/profile_edit.hpp"
#include "hw/camera_sim.hpp"
#include "hw/rig_profile.hpp"

using namespace collide;

namespace {

struct Stat {
  const char* name;
  double sum_err2 = 0, sum_pull2 = 0, sum_sigma = 0, max_pull = 0;
  int n = 0, within3 = 0;
  void add(double err, double sigma) {
    const double pull = sigma > 0 ? err / sigma : INFINITY;
    sum_err2 += err * err;
    sum_pull2 += pull * pull;
    sum_sigma += sigma;
    max_pull = std::max(max_pull, std::abs(pull));
    within3 += std::abs(pull) < 3;
    ++n;
  }
};

}  // namespace

int main(int argc, char** argv) {
  int runs = 10, views = 16;
  double square_mm = 8.5;
  std::string profile_path = std::string(COLLIDE_SOURCE_DIR) + "/config/sim-lab.toml";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--runs") runs = std::stoi(argv[i + 1]);
    if (a == "--views") views = std::stoi(argv[i + 1]);
    if (a == "--profile") profile_path = argv[i + 1];
    if (a == "--square-mm") square_mm = std::stod(argv[i + 1]);
  }
  auto base = hw::loadRigProfile(profile_path);
  if (!base) return std::fprintf(stderr, "%s\n", base.error().message.c_str()), 2;
  auto lens = hw::simulatedLens(*base);
  if (!lens || !*lens)
    return std::fprintf(stderr, "%s: no perspective lens\n", profile_path.c_str()), 2;
  const PinholeCamera truth = **lens;
  const double truth_scale = truth.centre_m.z() / truth.focal_px;
  std::printf(
      "%s: f %.1f px, principal (%.2f, %.2f) px, k1 %.4f k2 %.4f p1 %.5f p2 %.5f, "
      "%.5e m/px at the plane; %d views + plane, %.4g mm squares\n",
      profile_path.c_str(), truth.focal_px, truth.principal_u_px, truth.principal_v_px, truth.k1,
      truth.k2, truth.p1, truth.p2, truth_scale, views, square_mm);
  std::printf("%4s %9s %7s %9s %7s %8s %7s %11s %9s %7s %5s\n", "seed", "f err px", "sigma",
              "k1 err", "sigma", "u0 err", "sigma", "scale err", "sigma", "rms px", "k2");
  Stat f{"f (px)"}, k1{"k1"}, u0{"principal u (px)"}, v0{"principal v (px)"},
      scale{"plane scale (m/px)"};
  double rms_sum = 0;
  int k2_held = 0;
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("collide-calibration-bench-" + std::to_string(getpid())))
                              .string();
  for (int seed = 1; seed <= runs; ++seed) {
    auto text = app::setProfileValue(base->text, "simulation", "seed", std::to_string(seed));
    if (!text) return std::fprintf(stderr, "%s\n", text.error().message.c_str()), 2;
    auto profile = hw::parseRigProfile(*text, profile_path);
    if (!profile) return std::fprintf(stderr, "%s\n", profile.error().message.c_str()), 2;
    std::filesystem::remove_all(dir);
    auto targets = app::renderCalibrationTargets(*profile, dir, {{9, 6}, square_mm * 1e-3}, views);
    if (!targets) return std::fprintf(stderr, "%s\n", targets.error().message.c_str()), 1;
    auto run = app::calibrateFromFiles({targets->views, targets->plane, targets->board});
    if (!run) {
      std::printf("%4d calibration failed: %s\n", seed, run.error().message.c_str());
      continue;
    }
    const vision::CameraCalibration& c = run->calibration;
    const vision::CalibrationSigma& s = c.sigma;
    f.add(c.camera.focal_px - truth.focal_px, s.focal_px);
    k1.add(c.camera.k1 - truth.k1, s.k1);
    u0.add(c.camera.principal_u_px - truth.principal_u_px, s.principal_u_px);
    v0.add(c.camera.principal_v_px - truth.principal_v_px, s.principal_v_px);
    scale.add(c.plane_pixel_size_m - truth_scale, s.plane_pixel_size_m);
    rms_sum += c.rms_px;
    k2_held += !c.k2_fitted;
    std::printf("%4d %9.2f %7.2f %9.4f %7.4f %8.2f %7.2f %11.2e %9.2e %7.3f %5s\n", seed,
                c.camera.focal_px - truth.focal_px, s.focal_px, c.camera.k1 - truth.k1, s.k1,
                c.camera.principal_u_px - truth.principal_u_px, s.principal_u_px,
                c.plane_pixel_size_m - truth_scale, s.plane_pixel_size_m, c.rms_px,
                c.k2_fitted ? "fit" : "held");
  }
  std::filesystem::remove_all(dir);
  std::printf(
      "\n| quantity | RMS error | mean stated sigma | RMS pull | max abs pull | within 3 sigma |\n"
      "|---|---|---|---|---|---|\n");
  for (const Stat* st : {&f, &k1, &u0, &v0, &scale}) {
    if (st->n == 0) continue;
    std::printf("| %s | %.3g | %.3g | %.2f | %.2f | %d / %d |\n", st->name,
                std::sqrt(st->sum_err2 / st->n), st->sum_sigma / st->n,
                std::sqrt(st->sum_pull2 / st->n), st->max_pull, st->within3, st->n);
  }
  if (f.n > 0)
    std::printf("\nreprojection RMS %.3f px (mean over %d runs); k2 held at 0 in %d of them\n",
                rms_sum / f.n, f.n, k2_held);
  return 0;
}
