// The whole-image fit of a small sphere (vision/silhouette_fit.hpp) against
// ground truth: spheres ray-cast by vision/render.hpp at known centres and
// radii under lamps from every side, and frames it must refuse.
#include "vision/silhouette_fit.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include "tests/analysis/cone_outline.hpp"
#include "vision/render.hpp"

namespace collide::vision {
namespace {

constexpr double kPixel_m = 1e-4;

struct Scene {
  Vec3 lamp = Vec3::UnitZ();
  double ambient = 0.2;
  double full_well_e = 0;  // 0: no noise
};

RenderSettings settings(const Scene& s) {
  RenderSettings rs;
  rs.width = 160, rs.height = 120;
  Imaging im;
  im.optics.pixel_size_m = kPixel_m;
  im.optics.origin_u_px = 79.5;
  im.optics.origin_v_px = 59.5;
  im.lighting.lamp_direction = s.lamp.normalized();
  im.lighting.ambient = s.ambient;
  im.lighting.sphere_albedo = 0.85;
  im.lighting.backdrop_level = 0.03;
  im.sensor.full_well_e = s.full_well_e;
  im.sensor.read_noise_e = s.full_well_e > 0 ? 3 : 0;
  im.samples_per_pixel = 4;
  rs.imaging = im;
  return rs;
}

SphereView sphereAt(double u, double v, double radius_px) {
  SphereView view;
  view.centre_px = {u, v};
  view.radius_px = radius_px;
  view.radius_m = radius_px * kPixel_m;
  view.centre_m = Vec3((u - 79.5) * kPixel_m, (59.5 - v) * kPixel_m, 0);
  return view;
}

CircleFit startAt(double u, double v, double r) {
  CircleFit c;
  c.u = u, c.v = v, c.radius = r;
  return c;
}

// A matte sphere 37 px across, lit from eight sides 30-70 degrees off the
// line of sight, no noise, the start off by 0.4 px and 0.3 px in radius:
// the fit lands on the rendered circle.
TEST(SilhouetteFit, LambertSphereUnderAnyLampIsPlacedWhereItIs) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uni(0, 1);
  for (int k = 0; k < 8; ++k) {
    const double az = 2 * std::numbers::pi * k / 8,
                 off = (30 + 40 * uni(rng)) * std::numbers::pi / 180;
    Scene s;
    s.lamp = Vec3(std::sin(off) * std::cos(az), std::sin(off) * std::sin(az), std::cos(off));
    s.ambient = 0.1 + 0.2 * uni(rng);
    const double u = 70 + 10 * uni(rng), v = 55 + 10 * uni(rng), r = 18.5;
    const cv::Mat img = Renderer(settings(s)).render({sphereAt(u, v, r)}, 0);
    const auto fit = fitSilhouette(img, startAt(u + 0.3, v - 0.25, r - 0.3), {});
    ASSERT_TRUE(fit) << "lamp " << k;
    EXPECT_NEAR(fit->circle.u, u, 0.02) << "lamp " << k;
    EXPECT_NEAR(fit->circle.v, v, 0.02) << "lamp " << k;
    EXPECT_NEAR(fit->circle.radius, r, 0.02) << "lamp " << k;
    EXPECT_GT(fit->circle.sigma_u, 0);
  }
}

// With photon noise the stated sigmas are of the size of the scatter about
// the truth (pull RMS between 0.5 and 2 over 40 frames).
TEST(SilhouetteFit, StatedSigmasMatchTheScatter) {
  Scene s;
  s.lamp = Vec3(0.5, 0.3, 0.81);
  s.ambient = 0.3;
  s.full_well_e = 2000;
  RenderSettings rs = settings(s);
  double pull2 = 0, err2 = 0;
  int n = 0;
  for (int frame = 0; frame < 40; ++frame) {
    rs.noise_seed = 50 + frame;
    const double u = 60 + 0.37 * frame, v = 50 + 0.11 * frame, r = 18.5;
    const cv::Mat img = Renderer(rs).render({sphereAt(u, v, r)}, frame);
    const auto fit = fitSilhouette(img, startAt(u - 0.2, v + 0.2, r + 0.2), {});
    ASSERT_TRUE(fit);
    const double du = fit->circle.u - u, dv = fit->circle.v - v;
    pull2 += du * du / (fit->circle.sigma_u * fit->circle.sigma_u) +
             dv * dv / (fit->circle.sigma_v * fit->circle.sigma_v);
    err2 += du * du + dv * dv;
    n += 2;
  }
  const double pull = std::sqrt(pull2 / n), rms = std::sqrt(err2 / n);
  std::printf("40 frames, 2000 e- full well: centre RMS %.4f px, pull RMS %.2f\n", rms, pull);
  EXPECT_LT(rms, 0.03);
  EXPECT_GT(pull, 0.5);
  EXPECT_LT(pull, 2.0);
}

// A second sphere touching this one: its pixels are left out, so it does not
// pull the circle; without being told of it, it would.
TEST(SilhouetteFit, ANeighbourTheCallerNamesDoesNotPull) {
  const Scene s;
  const double r = 18.5, u = 60, v = 60, u2 = u + 2 * r + 0.5;
  const cv::Mat img = Renderer(settings(s)).render({sphereAt(u, v, r), sphereAt(u2, v, r)}, 0);
  const std::vector<CircleFit> others{startAt(u2, v, r)};
  const auto fit = fitSilhouette(img, startAt(u, v, r), others);
  ASSERT_TRUE(fit);
  EXPECT_NEAR(fit->circle.u, u, 0.03);
  EXPECT_NEAR(fit->circle.radius, r, 0.03);
}

// What it must refuse: a frame with nothing in it, and a start far from any
// sphere (the caller then keeps the start).
TEST(SilhouetteFit, NothingToFitGivesNoFit) {
  const Scene s;
  const cv::Mat empty = Renderer(settings(s)).render({}, 0);
  EXPECT_FALSE(fitSilhouette(empty, startAt(80, 60, 18.5), {}));
  const cv::Mat img = Renderer(settings(s)).render({sphereAt(40, 60, 18.5)}, 0);
  EXPECT_FALSE(fitSilhouette(img, startAt(110, 60, 18.5), {}));
  EXPECT_FALSE(fitSilhouette(cv::Mat(), startAt(80, 60, 18.5), {}));
}

// Under a pinhole lens a sphere off the optical axis is an ellipse, longer
// away from the principal point. A 60 px sphere 6.8 degrees off the axis
// (0.7 % longer that way, 0.4 px), lit from four sides: given the camera, the
// fit's centre, mapped to the world by PinholeCamera::sphereCentre, lands on
// the sphere's centre, and its radius is the mean of the ellipse's
// semi-axes, both from the cone's geometry (truth not computed by the fit).
TEST(SilhouetteFit, UnderPerspectiveTheEllipseIsFittedGivenTheCamera) {
  RenderSettings rs;
  rs.width = 1000, rs.height = 600;
  Imaging im;
  im.optics.perspective = true;
  im.optics.focal_px = 2500;
  im.optics.principal_u_px = 499.5;
  im.optics.principal_v_px = 299.5;
  im.optics.centre_m = Vec3(0, 0, 0.53);
  im.lighting.ambient = 0.15;
  im.lighting.backdrop_level = 0.03;
  im.samples_per_pixel = 4;
  const PinholeCamera cam = im.optics.pinhole();
  const double radius_m = 0.0127;
  const Vec3 centre(0.06, 0.02, 0);
  SphereView view;
  view.radius_m = radius_m;
  view.centre_m = centre;
  // The outline from the tangent cone.
  const double depth = 0.53;
  const double mean_radius =
      cam.focal_px *
      testing::coneOutline(std::hypot(centre.x(), centre.y()), depth, radius_m).meanAxis();
  const Eigen::Vector2d seen = cam.project(centre);
  for (int k = 0; k < 4; ++k) {
    const double az = std::numbers::pi / 2 * k + 0.3;
    im.lighting.lamp_direction = Vec3(0.6 * std::cos(az), 0.6 * std::sin(az), 0.8);
    rs.imaging = im;
    const cv::Mat img = Renderer(rs).render({view}, 0);
    SilhouetteFitSettings with;
    with.camera = cam;
    const auto fit =
        fitSilhouette(img, startAt(seen.x() + 0.4, seen.y() - 0.2, mean_radius - 0.3), {}, with);
    const auto circle =
        fitSilhouette(img, startAt(seen.x() + 0.4, seen.y() - 0.2, mean_radius - 0.3), {});
    ASSERT_TRUE(fit && circle) << "lamp " << k;
    const auto offPx = [&](const SilhouetteFit& f) {
      const Vec3 c = cam.sphereCentre(f.circle.u, f.circle.v, radius_m, 0.0);
      return (c - centre).head<2>().norm() * cam.focal_px / depth;
    };
    std::printf(
        "lamp %d: centre off by %.4f px as an ellipse, %.4f px as a circle; radius %+.4f px\n", k,
        offPx(*fit), offPx(*circle), fit->circle.radius - mean_radius);
    EXPECT_LT(offPx(*fit), 0.03) << "lamp " << k;
    // What the ellipse is for: a circle puts the centre where the lit side pulls it.
    EXPECT_GT(offPx(*circle), 0.05) << "lamp " << k;
    EXPECT_NEAR(fit->circle.radius, mean_radius, 0.03) << "lamp " << k;
  }
}

}  // namespace
}  // namespace collide::vision
