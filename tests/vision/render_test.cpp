// Checks the renderer against analytic geometry: centroids, areas, projected
// dot caps, noise statistics and blur moments computed from first principles,
// never from the renderer's own earlier output.
#include "vision/render.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

namespace collide::vision {
namespace {

constexpr double kPi = std::numbers::pi;
// Variance a pixel-integrated image gains over the continuous one (box of 1 px).
constexpr double kPixelVar = 1.0 / 12.0;

// Background-subtracted intensity moments over a window (clipped to the image).
struct Moments {
  double mass = 0;      // sum of (I - bg), grey levels
  double u = 0, v = 0;  // centroid, pixels
  double var_u = 0, var_v = 0, cov_uv = 0;
};

double pixel(const cv::Mat& img, int v, int u) {
  switch (img.depth()) {
    case CV_8U: return img.at<std::uint8_t>(v, u);
    case CV_16U: return img.at<std::uint16_t>(v, u);
    default: return img.at<std::int32_t>(v, u);
  }
}

Moments moments(const cv::Mat& img, double bg_grey, double u_lo, double u_hi, double v_lo,
                double v_hi) {
  Moments m;
  const int u0 = std::max(0, static_cast<int>(std::floor(u_lo)));
  const int u1 = std::min(img.cols - 1, static_cast<int>(std::ceil(u_hi)));
  const int v0 = std::max(0, static_cast<int>(std::floor(v_lo)));
  const int v1 = std::min(img.rows - 1, static_cast<int>(std::ceil(v_hi)));
  double su = 0, sv = 0, suu = 0, svv = 0, suv = 0;
  for (int v = v0; v <= v1; ++v)
    for (int u = u0; u <= u1; ++u) {
      const double w = pixel(img, v, u) - bg_grey;
      m.mass += w;
      su += w * u;
      sv += w * v;
      suu += w * u * u;
      svv += w * v * v;
      suv += w * u * v;
    }
  m.u = su / m.mass;
  m.v = sv / m.mass;
  m.var_u = suu / m.mass - m.u * m.u;
  m.var_v = svv / m.mass - m.v * m.v;
  m.cov_uv = suv / m.mass - m.u * m.v;
  return m;
}

Moments sphereMoments(const cv::Mat& img, double bg_grey, const SphereView& s, double margin = 2) {
  const double r = s.radius_px + margin;
  return moments(img, bg_grey, s.centre_px.x() - r, s.centre_px.x() + r, s.centre_px.y() - r,
                 s.centre_px.y() + r);
}

// The background is drawn as round(level * full scale) when there is no noise.
double bgGrey(const RenderSettings& s) {
  return std::round(s.background_level * maxValue(s.format));
}

RenderSettings noiseFree(PixelFormat f) {
  RenderSettings s;
  s.format = f;
  s.noise_grey = 0;
  return s;
}

// (a) The intensity centroid of a dotless, noise-free sphere is its centre, for
// any sub-pixel position and radius 15..80 px, with two spheres in one frame.
void expectCentroidsExact(PixelFormat f) {
  const RenderSettings st = noiseFree(f);
  const Renderer r(st);
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> radius(15, 80), frac(0, 1);
  double worst = 0;
  for (int trial = 0; trial < 200; ++trial) {
    SphereView a, b;
    a.radius_px = radius(rng);
    b.radius_px = radius(rng);
    // Left and right halves of the frame; whole spheres inside it.
    a.centre_px = {90 + 140 * frac(rng), 90 + 300 * frac(rng)};
    b.centre_px = {410 + 140 * frac(rng), 90 + 300 * frac(rng)};
    const cv::Mat img = r.render({a, b}, 0);
    for (const SphereView& s : {a, b}) {
      const Moments m = sphereMoments(img, bgGrey(st), s);
      worst = std::max({worst, std::abs(m.u - s.centre_px.x()), std::abs(m.v - s.centre_px.y())});
      ASSERT_NEAR(m.u, s.centre_px.x(), 0.02) << "trial " << trial << " r=" << s.radius_px;
      ASSERT_NEAR(m.v, s.centre_px.y(), 0.02) << "trial " << trial << " r=" << s.radius_px;
    }
  }
  ::testing::Test::RecordProperty("worst_centroid_error_px", std::to_string(worst));
  std::printf("%s worst centroid error %.5f px\n", toString(f), worst);
}

TEST(Render, CentroidIsTrueCentreMono16) {
  expectCentroidsExact(PixelFormat::Mono16);
}
TEST(Render, CentroidIsTrueCentreMono8) {
  expectCentroidsExact(PixelFormat::Mono8);
}

// (b) Flat white disc on black: summed intensity / full scale = pi r^2.
TEST(Render, SummedIntensityIsDiscArea) {
  RenderSettings st = noiseFree(PixelFormat::Mono16);
  st.sphere_level = st.rim_level = 1.0;
  st.background_level = 0.0;
  const Renderer r(st);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> radius(15, 80), frac(0, 1);
  for (int trial = 0; trial < 50; ++trial) {
    SphereView s;
    s.radius_px = radius(rng);
    s.centre_px = {200 + frac(rng), 200 + frac(rng)};
    const Moments m = sphereMoments(r.render({s}, 0), 0.0, s);
    const double area = kPi * s.radius_px * s.radius_px;
    // 16-bit rounding contributes < 1e-5 px^2 per pixel; the rest is the
    // renderer's edge integration.
    EXPECT_NEAR(m.mass / 65535.0, area, 2e-4 * area) << "r=" << s.radius_px;
  }
}

// (b') With the front-lit profile, b(rho) = rim + (centre - rim)(1 - rho^2/R^2)
// integrates to pi R^2 (rim + (centre - rim)/2); the centre is brighter than the rim.
TEST(Render, ShadedSumMatchesProfileIntegral) {
  const RenderSettings st = noiseFree(PixelFormat::Mono16);
  const Renderer r(st);
  SphereView s;
  s.radius_px = 50.3;
  s.centre_px = {300.37, 210.81};
  const cv::Mat img = r.render({s}, 0);
  const Moments m = sphereMoments(img, bgGrey(st), s);
  const double expected =
      kPi * s.radius_px * s.radius_px *
      (st.rim_level + 0.5 * (st.sphere_level - st.rim_level) - st.background_level) * 65535.0;
  EXPECT_NEAR(m.mass, expected, 2e-4 * expected);
  EXPECT_NEAR(pixel(img, 211, 300) / 65535.0, st.sphere_level, 0.01);
  // A pixel fully inside, 2 px from the limb: rho/R = 48.3/50.3.
  const double rho = 48.3 / 50.3;
  EXPECT_NEAR(pixel(img, 211, 300 - 48) / 65535.0,
              st.rim_level + (st.sphere_level - st.rim_level) * (1 - rho * rho), 0.01);
}

// (c) Dot patterns.
TEST(DotPattern, CountSizeSeparationAndSeed) {
  const DotPattern p = DotPattern::random(123);
  // Dot diameter / sphere diameter = sin(alpha) = 1/10.
  EXPECT_NEAR(std::sin(p.angular_radius_rad), 0.1, 1e-12);
  // Cap area fraction (1 - cos a)/2 = 0.00251; 5 % / that = 19.95 dots.
  EXPECT_GE(p.centres.size(), 19u);
  EXPECT_LE(p.centres.size(), 21u);
  for (std::size_t i = 0; i < p.centres.size(); ++i) {
    EXPECT_NEAR(p.centres[i].norm(), 1.0, 1e-12);
    for (std::size_t j = 0; j < i; ++j) {
      const double angle = std::acos(std::clamp(p.centres[i].dot(p.centres[j]), -1.0, 1.0));
      EXPECT_GT(angle, 2 * p.angular_radius_rad) << "dots " << i << " and " << j << " touch";
    }
  }
  const DotPattern same = DotPattern::random(123);
  ASSERT_EQ(same.centres.size(), p.centres.size());
  for (std::size_t i = 0; i < p.centres.size(); ++i) EXPECT_EQ(same.centres[i], p.centres[i]);
  const DotPattern other = DotPattern::random(124);
  ASSERT_FALSE(other.centres.empty());
  EXPECT_GT((other.centres[0] - p.centres[0]).norm(), 1e-6);
}

TEST(DotPattern, CentresAreUniformOnTheSphere) {
  // Over many patterns the mean centre is ~0 and each |component|^2 averages 1/3.
  Vec3 mean = Vec3::Zero();
  Vec3 sq = Vec3::Zero();
  int n = 0;
  for (std::uint64_t seed = 0; seed < 200; ++seed)
    for (const Vec3& c : DotPattern::random(seed).centres) {
      mean += c;
      sq += c.cwiseProduct(c);
      ++n;
    }
  mean /= n;
  sq /= n;
  // ~4000 samples: standard errors ~0.009 (mean) and ~0.005 (squares).
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(mean[k], 0.0, 0.04);
    EXPECT_NEAR(sq[k], 1.0 / 3.0, 0.02);
  }
}

TEST(DotPattern, DarkenedFractionOfDiscMatchesCoverage) {
  // A surface fraction f of uniformly placed dots covers, on average, the same
  // fraction f of the projected disc (projected area = integral of cos(theta) dA).
  RenderSettings st = noiseFree(PixelFormat::Mono16);
  st.dot_level = 0.0;
  const Renderer r(st);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  double fraction_sum = 0;
  const int trials = 40;
  for (int t = 0; t < trials; ++t) {
    const DotPattern p = DotPattern::random(1000 + t);
    SphereView s;
    s.radius_px = 60;
    s.centre_px = {320.3, 240.6};
    s.orientation = Quat(Eigen::AngleAxisd(angle(rng), Vec3::UnitZ()) *
                         Eigen::AngleAxisd(angle(rng), Vec3::UnitY()) *
                         Eigen::AngleAxisd(angle(rng), Vec3::UnitX()));
    const cv::Mat plain = r.render({s}, 0);
    s.dots = &p;
    const cv::Mat dotted = r.render({s}, 0);
    double dark = 0;  // pixels' worth of paint: (plain - dotted) / (plain - dot level)
    for (int v = 0; v < plain.rows; ++v)
      for (int u = 0; u < plain.cols; ++u) {
        const double a = pixel(plain, v, u), b = pixel(dotted, v, u);
        if (a - b > 0) dark += (a - b) / a;
      }
    fraction_sum += dark / (kPi * s.radius_px * s.radius_px);
  }
  const double mean_fraction = fraction_sum / trials;
  std::printf("darkened fraction of the disc %.4f\n", mean_fraction);
  EXPECT_GT(mean_fraction, 0.03);
  EXPECT_LT(mean_fraction, 0.07);
}

// (d) Bit depths, ranges and noise.
TEST(Render, FormatsHaveTheirTypesAndRanges) {
  for (PixelFormat f : {PixelFormat::Mono8, PixelFormat::Mono12, PixelFormat::Mono16}) {
    RenderSettings st;
    st.format = f;
    st.sphere_level = 1.0;  // saturates with noise: clamped to full scale
    st.rim_level = 1.0;
    st.noise_grey = 0.02 * maxValue(f);
    const Renderer r(st);
    SphereView s;
    s.radius_px = 60;
    s.centre_px = {320, 240};
    const cv::Mat img = r.render({s}, 0);
    EXPECT_EQ(img.type(), cvType(f)) << toString(f);
    EXPECT_EQ(img.cols, 640);
    EXPECT_EQ(img.rows, 480);
    double lo, hi;
    cv::minMaxLoc(img, &lo, &hi);
    EXPECT_EQ(hi, maxValue(f)) << toString(f);
    // The background (0.02 of full scale) minus 1 sigma of noise reaches 0 often.
    EXPECT_EQ(lo, 0) << toString(f);
  }
}

TEST(Render, NoiseStdDevOnBackgroundMatchesSetting) {
  for (auto [f, sigma] :
       {std::pair{PixelFormat::Mono8, 2.0}, std::pair{PixelFormat::Mono8, 5.0},
        std::pair{PixelFormat::Mono12, 20.0}, std::pair{PixelFormat::Mono16, 300.0}}) {
    RenderSettings st;
    st.format = f;
    st.background_level = 0.3;  // far from 0 and full scale: no clipping
    st.noise_grey = sigma;
    st.noise_seed = 99;
    const Renderer r(st);
    SphereView s;
    s.radius_px = 40;
    s.centre_px = {100, 100};
    const cv::Mat img = r.render({s}, 5);
    const cv::Mat bg = img(cv::Rect(200, 0, 440, 480));  // right of the sphere
    cv::Scalar mean, sd;
    cv::meanStdDev(bg, mean, sd);
    // Rounding adds variance 1/12 grey^2.
    const double expected_sd = std::sqrt(sigma * sigma + 1.0 / 12.0);
    EXPECT_NEAR(sd[0], expected_sd, 0.1 * expected_sd) << toString(f) << " sigma " << sigma;
    EXPECT_NEAR(mean[0], 0.3 * maxValue(f), 0.05 * sigma) << toString(f);
  }
}

TEST(Render, NoiseIsReproducibleAndVariesPerFrame) {
  RenderSettings st;
  st.noise_grey = 3;
  st.noise_seed = 5;
  SphereView s;
  s.radius_px = 50;
  s.centre_px = {320, 240};
  const cv::Mat f0 = Renderer(st).render({s}, 0);
  const cv::Mat f0_again = Renderer(st).render({s}, 0);
  const cv::Mat f1 = Renderer(st).render({s}, 1);
  EXPECT_EQ(cv::norm(f0, f0_again, cv::NORM_INF), 0.0);
  // Independent noise in two frames: the difference has std dev ~sqrt(2)*3.
  cv::Mat diff;
  cv::subtract(f0, f1, diff, cv::noArray(), CV_32F);
  cv::Scalar mean, sd;
  cv::meanStdDev(diff, mean, sd);
  EXPECT_NEAR(sd[0], std::sqrt(2.0) * std::sqrt(9.0 + 1.0 / 12.0), 0.3);
  st.noise_seed = 6;
  EXPECT_GT(cv::norm(f0, Renderer(st).render({s}, 0), cv::NORM_INF), 0.0);
}

// (e) Motion blur: a box of length L = |v| T along the velocity adds L^2/12 to
// the variance along it, nothing across it, and keeps the centroid at the
// mid-exposure centre.
TEST(Render, MotionBlurCentroidAndLength) {
  RenderSettings st = noiseFree(PixelFormat::Mono16);
  st.exposure_s = 1e-3;
  const Renderer blurred(st);
  const Renderer sharp(noiseFree(PixelFormat::Mono16));
  SphereView s;
  s.radius_px = 30;
  s.centre_px = {320.27, 240.61};
  s.velocity_px_s = {16000, -12000};  // 20 px over the exposure
  const double length = s.velocity_px_s.norm() * st.exposure_s;
  const Eigen::Vector2d along = s.velocity_px_s.normalized();
  const Eigen::Vector2d across(-along.y(), along.x());
  const auto varAlong = [](const Moments& m, const Eigen::Vector2d& d) {
    return d.x() * d.x() * m.var_u + 2 * d.x() * d.y() * m.cov_uv + d.y() * d.y() * m.var_v;
  };
  const Moments mb = sphereMoments(blurred.render({s}, 0), bgGrey(st), s, 14);
  const Moments ms = sphereMoments(sharp.render({s}, 0), bgGrey(st), s, 14);
  EXPECT_NEAR(mb.u, s.centre_px.x(), 0.02);
  EXPECT_NEAR(mb.v, s.centre_px.y(), 0.02);
  EXPECT_NEAR(varAlong(mb, along) - varAlong(ms, along), length * length / 12,
              0.01 * length * length / 12);
  EXPECT_NEAR(varAlong(mb, across), varAlong(ms, across), 0.01);
  EXPECT_NEAR(mb.mass, ms.mass, 1e-4 * ms.mass);  // blur moves light, does not make it
}

TEST(Render, SpinBlurSmearsDotsNotTheDisc) {
  // Spin about the line of sight turns the dots around the centre; the disc
  // itself is unchanged and the dots' darkness spreads over a wider arc.
  const DotPattern p = DotPattern::random(11);
  RenderSettings st = noiseFree(PixelFormat::Mono16);
  st.exposure_s = 1e-3;
  SphereView s;
  s.radius_px = 60;
  s.centre_px = {320, 240};
  s.dots = &p;
  const cv::Mat still = Renderer(st).render({s}, 0);
  s.spin_rad_s = {0, 0, 500};  // 0.5 rad over the exposure
  const cv::Mat spun = Renderer(st).render({s}, 0);
  SphereView plain = s;
  plain.dots = nullptr;
  const cv::Mat disc = Renderer(st).render({plain}, 0);
  // Total paint is conserved (rotation about z keeps each dot's projected area).
  const double paint_still = cv::sum(disc)[0] - cv::sum(still)[0];
  const double paint_spun = cv::sum(disc)[0] - cv::sum(spun)[0];
  EXPECT_NEAR(paint_spun, paint_still, 0.02 * paint_still);
  // ...but smeared: fewer pixels are fully dark.
  EXPECT_LT(cv::countNonZero(spun < 0.1 * 65535), cv::countNonZero(still < 0.1 * 65535));
}

// (f) A sphere cut by the frame border equals the same sphere drawn whole in a
// larger frame, over the visible part.
TEST(Render, SphereCutByBorderMatchesWholeSphere) {
  RenderSettings small = noiseFree(PixelFormat::Mono16);
  small.width = 200;
  small.height = 150;
  RenderSettings big = small;
  big.width = 400;
  big.height = 350;
  const DotPattern p = DotPattern::random(5);
  for (const Eigen::Vector2d& c : {Eigen::Vector2d(5.3, 140.6), Eigen::Vector2d(-20.4, 70.2),
                                   Eigen::Vector2d(190.7, -15.1), Eigen::Vector2d(210.0, 160.5)}) {
    SphereView s;
    s.radius_px = 37.4;
    s.centre_px = c;
    s.dots = &p;
    s.orientation = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
    const cv::Mat cut = Renderer(small).render({s}, 0);
    s.centre_px += Eigen::Vector2d(100, 100);  // whole inside the big frame
    const cv::Mat whole = Renderer(big).render({s}, 0);
    // Equal up to one level in 65535: float arithmetic at positions 100 px
    // apart may round a pixel the other way.
    EXPECT_LE(cv::norm(cut, whole(cv::Rect(100, 100, 200, 150)), cv::NORM_INF), 1.0)
        << c.transpose();
    // ...and clipping really happened: the cut frame holds less light than the whole sphere.
    EXPECT_LT(cv::sum(cut)[0] - bgGrey(small) * cut.total(),
              cv::sum(whole)[0] - bgGrey(big) * whole.total());
  }
  // Entirely outside, absurdly far, or not finite: background only.
  for (const Eigen::Vector2d& c : {Eigen::Vector2d(-30, 50), Eigen::Vector2d(1e15, -1e15),
                                   Eigen::Vector2d(std::nan(""), 50)}) {
    SphereView away;
    away.radius_px = 20;
    away.centre_px = c;
    away.dots = &p;
    const cv::Mat empty = Renderer(small).render({away}, 0);
    double lo, hi;
    cv::minMaxLoc(empty, &lo, &hi);
    EXPECT_EQ(lo, bgGrey(small)) << c.transpose();
    EXPECT_EQ(hi, bgGrey(small)) << c.transpose();
  }
}

// (g) Orientation: a dot at body +z faces the camera at identity; rotated by
// theta about y it moves to u = cu + R cos(alpha) sin(theta) (the centre of
// its projected rim ellipse), squashed across to R sin(alpha) cos(theta).
TEST(Render, RotationMovesDotsTheRightWay) {
  RenderSettings st = noiseFree(PixelFormat::Mono16);
  st.sphere_level = st.rim_level = 0.8;  // flat shading: paint is uniformly weighted
  st.dot_level = 0.0;
  const Renderer r(st);
  DotPattern one;
  one.centres = {Vec3::UnitZ()};
  one.angular_radius_rad = std::asin(0.1);
  const double a = one.angular_radius_rad;
  SphereView s;
  s.radius_px = 60;
  s.centre_px = {320.4, 240.7};
  SphereView plain = s;
  const cv::Mat disc = r.render({plain}, 0);
  s.dots = &one;

  const auto paint = [&](const Quat& q) {
    s.orientation = q;
    cv::Mat d;
    cv::subtract(disc, r.render({s}, 0), d, cv::noArray(), CV_32S);
    return moments(d, 0, 0, 639, 0, 479);
  };
  const double sa = s.radius_px * std::sin(a);  // semi-axis of the face-on dot
  {
    const Moments m = paint(Quat::Identity());
    EXPECT_NEAR(m.u, s.centre_px.x(), 0.02);
    EXPECT_NEAR(m.v, s.centre_px.y(), 0.02);
    // Uniform disc of radius a: variance a^2/4 along each axis, plus 1/12 px^2
    // from integrating over pixels (a box filter) before sampling.
    EXPECT_NEAR(m.var_u, sa * sa / 4 + kPixelVar, 0.01 * sa * sa / 4);
    EXPECT_NEAR(m.var_v, sa * sa / 4 + kPixelVar, 0.01 * sa * sa / 4);
  }
  for (double theta : {kPi / 6, kPi / 4, kPi / 3}) {
    const Moments m = paint(Quat(Eigen::AngleAxisd(theta, Vec3::UnitY())));
    EXPECT_NEAR(m.u, s.centre_px.x() + s.radius_px * std::cos(a) * std::sin(theta), 0.05) << theta;
    EXPECT_NEAR(m.v, s.centre_px.y(), 0.02) << theta;
    const double ax = sa * std::cos(theta);
    EXPECT_NEAR(m.var_u, ax * ax / 4 + kPixelVar, 0.02 * ax * ax / 4) << theta;
    EXPECT_NEAR(m.var_v, sa * sa / 4 + kPixelVar, 0.01 * sa * sa / 4) << theta;
  }
  // 90 degrees about y: body +z -> world +x, the right limb; about x: world -y, the bottom.
  {
    const Moments m = paint(Quat(Eigen::AngleAxisd(kPi / 2, Vec3::UnitY())));
    EXPECT_GT(m.u, s.centre_px.x() + 0.95 * s.radius_px);
    EXPECT_NEAR(m.v, s.centre_px.y(), 0.05);
  }
  {
    const Moments m = paint(Quat(Eigen::AngleAxisd(kPi / 2, Vec3::UnitX())));
    EXPECT_GT(m.v, s.centre_px.y() + 0.95 * s.radius_px);
    EXPECT_NEAR(m.u, s.centre_px.x(), 0.05);
  }
  // Just past the limb the cap still shows a sliver; a cap radius past it, nothing.
  {
    const Moments m = paint(Quat(Eigen::AngleAxisd(kPi / 2 + 0.5 * a, Vec3::UnitY())));
    EXPECT_GT(m.mass, 0.0);
    EXPECT_GT(m.u, s.centre_px.x() + 0.95 * s.radius_px);
    s.orientation = Quat(Eigen::AngleAxisd(kPi / 2 + 1.01 * a, Vec3::UnitY()));
    EXPECT_EQ(cv::norm(disc, r.render({s}, 0), cv::NORM_INF), 0.0);
  }
  // 180 degrees: on the far side, invisible.
  {
    s.orientation = Quat(Eigen::AngleAxisd(kPi, Vec3::UnitY()));
    EXPECT_EQ(cv::norm(disc, r.render({s}, 0), cv::NORM_INF), 0.0);
  }
}

TEST(Render, DotsAndSphereHaveTheirLevels) {
  // Face-on dot of radius 6 px at the centre: its middle pixels are dot_level;
  // the lit sphere just outside it follows the profile.
  RenderSettings st = noiseFree(PixelFormat::Mono16);
  st.dot_level = 0.05;
  DotPattern one;
  one.centres = {Vec3::UnitZ()};
  one.angular_radius_rad = std::asin(0.1);
  SphereView s;
  s.radius_px = 60;
  s.centre_px = {320, 240};
  s.dots = &one;
  const cv::Mat img = Renderer(st).render({s}, 0);
  for (const auto& [du, dv] : {std::pair{0, 0}, std::pair{4, 0}, std::pair{0, -4}, std::pair{3, 3}})
    EXPECT_NEAR(pixel(img, 240 + dv, 320 + du), 0.05 * 65535, 1.0) << du << "," << dv;
  const double rho = 8.0 / 60.0;  // 2 px outside the dot's edge
  EXPECT_NEAR(pixel(img, 240, 328) / 65535.0,
              st.rim_level + (st.sphere_level - st.rim_level) * (1 - rho * rho), 1e-3);
}

TEST(Render, TouchingSpheresBothDrawn) {
  // Two spheres in contact: each keeps its centroid (the shared edge pixels
  // hold light from both) and no pixel exceeds the brighter sphere's centre.
  const RenderSettings st = noiseFree(PixelFormat::Mono16);
  const Renderer r(st);
  SphereView a, b;
  a.radius_px = b.radius_px = 40;
  a.centre_px = {250.3, 240.2};
  const Eigen::Vector2d n = Eigen::Vector2d(1, 0.5).normalized();
  b.centre_px = a.centre_px + 80 * n;
  const cv::Mat img = r.render({a, b}, 0);
  double lo, hi;
  cv::minMaxLoc(img, &lo, &hi);
  EXPECT_LE(hi, st.sphere_level * 65535 + 1);
  const Moments both = moments(img, bgGrey(st), 0, 639, 0, 479);
  const Eigen::Vector2d mid = 0.5 * (a.centre_px + b.centre_px);
  EXPECT_NEAR(both.u, mid.x(), 0.02);
  EXPECT_NEAR(both.v, mid.y(), 0.02);
}

}  // namespace
}  // namespace collide::vision
