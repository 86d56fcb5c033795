// Dots found on rendered spheres against the true dot centres (the pattern
// rotated by the sphere's orientation), and the limb correction of lifting
// against the closed-form centroid of a projected spherical cap.
#include "vision/dot_detector.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "shot_fixture.hpp"
#include "vision/render.hpp"

namespace collide::vision {
namespace {

constexpr double kPi = std::numbers::pi;

struct DotStats {
  double sum_a2 = 0;                // squared angle errors, rad^2
  double radial[4] = {0, 0, 0, 0};  // mean radial image error by polar angle band, px
  int radial_n[4] = {0, 0, 0, 0};
  int matched = 0, visible = 0, found_visible = 0, spurious = 0;
  double angleRms() const { return std::sqrt(sum_a2 / matched); }
};

// The pattern's dot centres turned by the sphere's orientation.
std::vector<Vec3> truthDots(const DotPattern& pat, const Quat& orientation) {
  std::vector<Vec3> truth;
  for (const Vec3& c : pat.centres) truth.push_back(orientation * c);
  return truth;
}

// Each dot found against the nearest true dot (`radius`: the sphere's nominal
// radius for the spurious test, `radius_px` its drawn one for the radial
// errors): into `st`; which true dots were seen.
std::vector<bool> matchDots(const DotFrame& df, const std::vector<Vec3>& truth, double radius,
                            double radius_px, DotStats& st) {
  std::vector<bool> seen(truth.size(), false);
  for (const Dot& d : df.dots) {
    EXPECT_NEAR(d.on_sphere.norm(), 1.0, 1e-12);
    int best = -1;
    double best_a = 1e9;
    for (std::size_t i = 0; i < truth.size(); ++i) {
      const double a = std::acos(std::clamp(d.on_sphere.dot(truth[i]), -1.0, 1.0));
      if (a < best_a) best_a = a, best = static_cast<int>(i);
    }
    // Spurious: no true dot within 3 px on the image (0.05 rad on a 60 px
    // sphere; 0.16 rad on an 18.5 px one, where a dot measured 1 px off
    // is an error of the measurement, which the angle RMS below takes in).
    if (best_a * radius > 3.0) {
      std::printf("spurious dot at (%.2f, %.2f), area %.1f px^2, nearest true dot %.3f rad away\n",
                  d.u_px, d.v_px, d.area_px2, best_a);
      ++st.spurious;
      continue;
    }
    seen[best] = true;
    st.sum_a2 += best_a * best_a;
    ++st.matched;
    const Vec3& t = truth[best];
    const int band = std::min(3, static_cast<int>(std::acos(t.z()) / (kPi / 8)));
    st.radial[band] += (d.on_sphere.head<2>().norm() - t.head<2>().norm()) * radius_px;
    ++st.radial_n[band];
  }
  return seen;
}

// Renders `frames` random single spheres and compares every dot found with the truth.
DotStats run(RenderSettings rs, double radius, int frames, std::uint64_t seed,
             double must_find_deg = 60) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0, 1);
  std::normal_distribution<double> nd;
  DotStats st;
  const SphereDetector det;
  for (int f = 0; f < frames; ++f) {
    rs.noise_seed = seed * 1000 + f;
    const DotPattern pat = DotPattern::random(seed * 77 + f);
    SphereView v;
    v.radius_px = radius + uni(rng);
    v.centre_px = {rs.width / 2.0 + (uni(rng) - 0.5) * 40, rs.height / 2.0 + (uni(rng) - 0.5) * 40};
    v.orientation = Quat(nd(rng), nd(rng), nd(rng), nd(rng)).normalized();
    v.dots = &pat;
    if (rs.imaging) {
      // Ray-cast (orthographic): the same sphere in the world, under a lamp
      // from a random side (25 to 70 degrees off the line of sight).
      Imaging& im = *rs.imaging;
      const double px = im.optics.pixel_size_m;
      v.radius_m = v.radius_px * px;
      v.centre_m = Vec3((v.centre_px.x() - im.optics.origin_u_px) * px,
                        (im.optics.origin_v_px - v.centre_px.y()) * px, 0);
      const double az = 2 * kPi * uni(rng), off = (25 + 45 * uni(rng)) * kPi / 180;
      im.lighting.lamp_direction =
          Vec3(std::sin(off) * std::cos(az), std::sin(off) * std::sin(az), std::cos(off));
      im.lighting.ambient = 0.05 + 0.25 * uni(rng);
      im.lighting.specular_strength = f % 2 ? 0.3 : 0.0;
      if (im.lighting.mode == Lighting::Mode::Back) {
        im.lighting.ambient = 0.2 + 0.15 * uni(rng);
        im.lighting.spot_level = f % 2 ? 0.35 : 0.0;
      }
    }
    const cv::Mat img = Renderer(rs).render({v}, f);
    const FrameSpheres fs = det.detect(img, maxValue(rs.format));
    EXPECT_EQ(fs.spheres.size(), 1u);
    if (fs.spheres.size() != 1) continue;
    const std::vector<Vec3> truth = truthDots(pat, v.orientation);
    const std::vector<bool> seen = matchDots(findDots(img, fs.spheres[0], maxValue(rs.format)),
                                             truth, radius, v.radius_px, st);
    // Dots well inside the disc (near the line of sight) must be found.
    for (std::size_t i = 0; i < truth.size(); ++i)
      if (truth[i].z() > std::cos(must_find_deg * kPi / 180)) {
        ++st.visible;
        st.found_visible += seen[i];
      }
  }
  for (int b = 0; b < 4; ++b)
    if (st.radial_n[b]) st.radial[b] /= st.radial_n[b];
  return st;
}

TEST(LiftToSphere, CapCentroidCorrection) {
  // The projected-area centroid of a cap of half-angle alpha centred at polar
  // angle theta lies at sin(theta) cos(alpha) from the centre (unit sphere).
  // Check that closed form by integrating over the cap numerically, then that
  // lifting the centroid with alpha returns the cap's centre.
  const double alpha = 0.1, r = 50;
  for (const double theta : {0.2, 0.7, 1.2, 1.4}) {
    const Vec3 c(std::sin(theta), 0, std::cos(theta));
    const Vec3 e1(std::cos(theta), 0, -std::sin(theta)), e2(0, 1, 0);
    double area = 0, mx = 0;
    const int n = 400;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const double phi = alpha * (i + 0.5) / n, psi = 2 * kPi * (j + 0.5) / n;
        const Vec3 p =
            c * std::cos(phi) + std::sin(phi) * (std::cos(psi) * e1 + std::sin(psi) * e2);
        const double da = std::sin(phi) * p.z();  // projected area element
        area += da;
        mx += da * p.x();
      }
    const double centroid = mx / area;
    EXPECT_NEAR(centroid, std::sin(theta) * std::cos(alpha), 1e-6) << theta;
    const Vec3 lifted = liftToSphere(100 + centroid * r, 80, 100, 80, r, alpha);
    EXPECT_NEAR(lifted.x(), c.x(), 1e-6);
    EXPECT_NEAR(lifted.z(), c.z(), 1e-5);
  }
  // Image v down is world y up.
  EXPECT_GT(liftToSphere(0, -10, 0, 0, 20).y(), 0);
  // Points beyond the limb land on the limb.
  EXPECT_NEAR(liftToSphere(30, 0, 0, 0, 20).x(), 1.0, 1e-12);
}

TEST(FindDots, RenderedDotsAreFoundAndLiftedAccurately) {
  RenderSettings rs;
  rs.noise_grey = 2.0;
  rs.exposure_s = 200e-6;  // no motion here, only the timing of a real frame
  const DotStats st = run(rs, 60, 60, 3);
  std::printf(
      "640x480: %d dots, angle RMS %.5f rad (%.4f px), found %d of %d within 60 deg, "
      "%d spurious; radial bias by polar band %.4f %.4f %.4f %.4f px\n",
      st.matched, st.angleRms(), st.angleRms() * 60, st.found_visible, st.visible, st.spurious,
      st.radial[0], st.radial[1], st.radial[2], st.radial[3]);
  EXPECT_EQ(st.spurious, 0);
  EXPECT_GE(st.found_visible, 0.97 * st.visible);
  // 0.002 rad is 0.12 px on a 60 px sphere.
  EXPECT_LT(st.angleRms(), 0.002);
  for (int b = 0; b < 4; ++b) EXPECT_LT(std::abs(st.radial[b]), 0.02) << "band " << b;
}

TEST(FindDots, SixteenBitAndThesisScale) {
  RenderSettings rs;
  rs.format = PixelFormat::Mono16;
  rs.noise_grey = 2.0 * 65535 / 255;
  const DotStats st16 = run(rs, 60, 20, 5);
  EXPECT_EQ(st16.spurious, 0);
  EXPECT_LT(st16.angleRms(), 0.002);

  RenderSettings small;
  small.width = 240, small.height = 192;
  small.noise_grey = 1.5;
  small.exposure_s = 200e-6;
  const DotStats st = run(small, 18.5, 60, 7, 45);
  std::printf("thesis scale: %d dots, angle RMS %.4f rad (%.3f px), found %d of %d within 45 deg\n",
              st.matched, st.angleRms(), st.angleRms() * 18.5, st.found_visible, st.visible);
  EXPECT_LE(st.spurious, 1);
  EXPECT_GE(st.found_visible, 0.9 * st.visible);
  EXPECT_LT(st.angleRms(), 0.012);  // ~0.2 px
}

// Issue 12: one-sided front light (lamp all round, ambient 0.05-0.3, a glossy
// highlight on every other frame, shot and read noise): a dot on the shaded
// side is dark against its own surroundings, not against one level for the
// whole sphere. Before (one threshold halfway from backdrop to limb, radial
// shading model): 60 px 93 of 151 found, 0.89 px RMS; 18 px 37 of 194, 91
// spurious, 0.70 px. After: 150 of 151, 0.33 px; 173 of 194, 24 "spurious"
// (mostly real dots off by 1-3 px: at 18 px the sphere's own centre is off by
// ~0.5 px RMS under this shading, see sphere_detector_test).
RenderSettings shadedImaging(int width, int height, double full_well_e) {
  RenderSettings rs;
  rs.width = width, rs.height = height;
  rs.format = PixelFormat::Mono8;
  Imaging im;
  im.optics.pixel_size_m = 1e-4;
  im.optics.origin_u_px = 0.5 * (width - 1);
  im.optics.origin_v_px = 0.5 * (height - 1);
  im.lighting.sphere_albedo = 0.8;
  im.lighting.dot_albedo = 0.06;
  im.lighting.backdrop_level = 0.02;
  im.lighting.specular_exponent = 80;
  im.sensor.full_well_e = full_well_e;
  im.sensor.read_noise_e = 4;
  im.samples_per_pixel = 4;
  rs.imaging = im;
  return rs;
}

TEST(FindDots, ShadedSpheres) {
  const DotStats st = run(shadedImaging(640, 480, 20000), 60, 30, 11);
  std::printf(
      "shaded 60 px: %d dots, angle RMS %.5f rad (%.4f px), found %d of %d within 60 deg, "
      "%d spurious\n",
      st.matched, st.angleRms(), st.angleRms() * 60, st.found_visible, st.visible, st.spurious);
  EXPECT_LE(st.spurious, 1);
  EXPECT_GE(st.found_visible, 0.97 * st.visible);
  EXPECT_LT(st.angleRms(), 0.0065);  // 0.39 px on a 60 px sphere
}

// A noisy camera: sim-lab's imaging (one lamp upper left, the right limbs
// dark) with a 4000 e- well and 40 e- read noise, photon noise about 3x
// sim-lab's. On the shaded side halfway to the backdrop is only a few noise
// sigmas below the bare level, and noise alone made specks there by the
// dozen, whose areas then set the dots' size and got the real dots refused
// (before: 313 spurious dots in 20 frames, 7 real ones, 1 of the 28 lit
// dots below found; now none spurious, 104 real, 28 of 28). Candidates must
// now also lie 3 noise sigmas below the bare level. The sphere is given at
// its true place, so this is the dot detector's own test.
TEST(FindDots, NoisyShadedSpheresGiveNoSpecks) {
  RenderSettings rs;
  rs.format = PixelFormat::Mono12;
  rs.exposure_s = 150e-6;
  rs.imaging = testing::simLabImaging();
  rs.imaging->sensor.full_well_e = 4000;
  rs.imaging->sensor.read_noise_e = 40;
  const double pixel = rs.imaging->optics.pixel_size_m, radius_m = 0.0127;
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> uni(0, 1);
  std::normal_distribution<double> nd;
  const SphereDetector det;
  DotStats st;
  int frames = 0;
  for (int f = 0; f < 20; ++f) {
    const DotPattern pat = DotPattern::random(500 + f);
    SphereView v;
    v.radius_m = radius_m;
    const Eigen::Vector2d c(250 + 140 * uni(rng), 180 + 120 * uni(rng));
    v.centre_m = Vec3((c.x() - 319.5) * pixel, (239.5 - c.y()) * pixel, 0);
    v.orientation = Quat(nd(rng), nd(rng), nd(rng), nd(rng)).normalized();
    v.dots = &pat;
    const cv::Mat img = Renderer(rs).render({v}, f);
    const FrameSpheres fs = det.detect(img, 4095);
    if (fs.spheres.size() != 1) continue;
    SphereMeasurement m = fs.spheres[0];
    m.circle.u = c.x(), m.circle.v = c.y(), m.circle.radius = radius_m / pixel;
    ++frames;
    const std::vector<Vec3> truth = truthDots(pat, v.orientation);
    const std::vector<bool> seen =
        matchDots(findDots(img, m, 4095), truth, m.circle.radius, m.circle.radius, st);
    // Dots within 45 degrees of the line of sight on the lit half must be found.
    for (std::size_t i = 0; i < truth.size(); ++i)
      if (truth[i].z() > std::cos(kPi / 4) && truth[i].x() < 0) {
        ++st.visible;
        st.found_visible += seen[i];
      }
  }
  std::printf("noisy sim-lab imaging: %d frames, %d dots matched, %d spurious, %d of %d found\n",
              frames, st.matched, st.spurious, st.found_visible, st.visible);
  EXPECT_GE(frames, 15);
  EXPECT_LE(st.spurious, 0.05 * st.matched);
  EXPECT_GE(st.found_visible, 0.9 * st.visible);
}

TEST(FindDots, ShadedThesisScale) {
  const DotStats st = run(shadedImaging(240, 192, 2000), 18.5, 60, 13, 45);
  std::printf(
      "shaded 18 px: %d dots, angle RMS %.4f rad (%.3f px), found %d of %d within 45 deg, "
      "%d spurious\n",
      st.matched, st.angleRms(), st.angleRms() * 18.5, st.found_visible, st.visible, st.spurious);
  EXPECT_LE(st.spurious, 0.15 * st.matched);
  EXPECT_GE(st.found_visible, 0.85 * st.visible);
  EXPECT_LT(st.angleRms(), 0.025);  // ~0.46 px
}

// Backlit (sim-backlit's field): dark dots on a dark silhouette, the front
// room light on the spheres' faces, a bright central spot on every other frame.
TEST(FindDots, BacklitSilhouettes) {
  RenderSettings rs = shadedImaging(640, 480, 12000);
  rs.imaging->lighting.mode = Lighting::Mode::Back;
  rs.imaging->lighting.sphere_albedo = 0.5;
  rs.imaging->lighting.dot_albedo = 0.05;
  rs.imaging->lighting.backdrop_level = 0.85;
  rs.imaging->lighting.spot_fraction = 0.15;
  const DotStats st = run(rs, 60, 20, 17);
  std::printf(
      "backlit 60 px: %d dots, angle RMS %.5f rad (%.4f px), found %d of %d within 60 deg, "
      "%d spurious\n",
      st.matched, st.angleRms(), st.angleRms() * 60, st.found_visible, st.visible, st.spurious);
  EXPECT_LE(st.spurious, 2);
  EXPECT_GE(st.found_visible, 0.9 * st.visible);
  EXPECT_LT(st.angleRms(), 0.0065);
}

TEST(FindDots, PlainSphereAndBadInputGiveNoDots) {
  RenderSettings rs;
  rs.noise_grey = 2.0;
  SphereView v;
  v.centre_px = {300.2, 200.7};
  v.radius_px = 60;
  const cv::Mat img = Renderer(rs).render({v}, 1);
  const FrameSpheres fs = SphereDetector().detect(img, 255);
  ASSERT_EQ(fs.spheres.size(), 1u);
  EXPECT_TRUE(findDots(img, fs.spheres[0], 255).dots.empty());
  EXPECT_TRUE(findDots(cv::Mat(), fs.spheres[0], 255).dots.empty());
  SphereMeasurement bogus = fs.spheres[0];
  bogus.circle.radius = -3;
  EXPECT_TRUE(findDots(img, bogus, 255).dots.empty());
  bogus.circle.radius = 60;
  bogus.circle.u = -500;  // wholly outside the frame
  EXPECT_TRUE(findDots(img, bogus, 255).dots.empty());
}

}  // namespace
}  // namespace collide::vision
