// The renderer with a real camera's imaging (vision/imaging.hpp) against
// analytic truth worked out here, never from the renderer's own output:
// Lambert's law at known surface points, the limb-to-centre ratio, the
// highlight's position, the backlit silhouette, the perspective silhouette of
// an off-axis sphere (the cone tangent to the sphere cut by the image plane),
// a dot's image area summed over its cap (on the limb too), OpenCV's
// distortion model written out from its documentation, energy
// conservation under motion blur, vignetting, flicker and sensor noise.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "vision/render.hpp"

namespace collide::vision {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kFull = 65535.0;  // Mono16

double at(const cv::Mat& img, int v, int u) {
  return img.depth() == CV_8U ? img.at<std::uint8_t>(v, u) : img.at<std::uint16_t>(v, u);
}

// Orthographic 320 x 240 Mono16, 0.1 mm pixels, world origin at the centre.
RenderSettings orthographic() {
  RenderSettings s;
  s.width = 320;
  s.height = 240;
  s.format = PixelFormat::Mono16;
  Imaging im;
  im.optics.pixel_size_m = 1e-4;
  im.optics.origin_u_px = 160;
  im.optics.origin_v_px = 120;
  im.lighting.backdrop_level = 0.0;
  im.samples_per_pixel = 1;
  s.imaging = im;
  return s;
}

// A sphere of `radius_px` at the world origin under orthographic().
SphereView sphereAtOrigin(double radius_px) {
  SphereView v;
  v.radius_m = radius_px * 1e-4;
  return v;
}

TEST(RenderImaging, LambertLawAtKnownSurfacePoints) {
  RenderSettings s = orthographic();
  Lighting& l = s.imaging->lighting;
  l.lamp_direction = Vec3(0.6, 0.3, 0.74);
  l.ambient = 0.1;
  l.sphere_albedo = 0.8;
  const Vec3 lamp = l.lamp_direction.normalized();
  const cv::Mat img = Renderer(s).render({sphereAtOrigin(100)}, 0);
  int checked = 0, dark = 0;
  for (int v = 25; v <= 215; v += 7)
    for (int u = 65; u <= 255; u += 7) {
      // The surface point under pixel (u, v)'s centre, seen along -z.
      const double x = (u - 160) / 100.0, y = -(v - 120) / 100.0;
      const double rho2 = x * x + y * y;
      if (rho2 > 0.95 * 0.95) continue;
      const Vec3 n(x, y, std::sqrt(1 - rho2));
      const double cos_i = n.dot(lamp);
      const double expected = kFull * 0.8 * (0.1 + 0.9 * std::max(0.0, cos_i));
      EXPECT_NEAR(at(img, v, u), expected, 1.0) << "pixel " << u << ", " << v << " cos " << cos_i;
      ++checked;
      if (cos_i < 0) ++dark;
    }
  EXPECT_GT(checked, 400);
  EXPECT_GT(dark, 10);  // the limb away from the lamp was sampled: ambient only
}

TEST(RenderImaging, LambertLawHoldsForPixelAveragesToo) {
  RenderSettings s = orthographic();
  s.imaging->samples_per_pixel = 4;
  s.imaging->lighting.lamp_direction = Vec3(-0.2, 0.5, 0.8);
  s.imaging->lighting.ambient = 0.0;
  s.imaging->lighting.sphere_albedo = 1.0;
  const Vec3 lamp = s.imaging->lighting.lamp_direction.normalized();
  const cv::Mat img = Renderer(s).render({sphereAtOrigin(100)}, 0);
  for (int v = 40; v <= 200; v += 20)
    for (int u = 80; u <= 240; u += 20) {
      const double x = (u - 160) / 100.0, y = -(v - 120) / 100.0;
      if (x * x + y * y > 0.8 * 0.8) continue;
      const double cos_i = Vec3(x, y, std::sqrt(1 - x * x - y * y)).dot(lamp);
      if (std::abs(cos_i) < 0.05) continue;  // the terminator's kink is not smooth
      EXPECT_NEAR(at(img, v, u) / kFull, std::max(0.0, cos_i), 2e-3);
    }
}

TEST(RenderImaging, LimbToCentreRatioMatchesACoaxialLamp) {
  RenderSettings s = orthographic();
  s.imaging->lighting.lamp_direction = Vec3::UnitZ();
  s.imaging->lighting.ambient = 0.25;
  const cv::Mat img = Renderer(s).render({sphereAtOrigin(100)}, 0);
  const double centre = at(img, 120, 160);
  for (const double rho : {0.5, 0.8, 0.95}) {
    const int u = 160 + static_cast<int>(std::lround(100 * rho));
    const double r = (u - 160) / 100.0;
    const double expected = 0.25 + 0.75 * std::sqrt(1 - r * r);
    EXPECT_NEAR(at(img, 120, u) / centre, expected, 2e-4) << "rho " << r;
  }
}

TEST(RenderImaging, HighlightSitsWhereTheHalfVectorIsTheNormal) {
  RenderSettings s = orthographic();
  Lighting& l = s.imaging->lighting;
  l.lamp_direction = Vec3(0.5, 0.4, 0.77);
  l.ambient = 0.1;
  l.sphere_albedo = 0.5;
  l.specular_strength = 0.4;
  l.specular_exponent = 80;
  const Vec3 lamp = l.lamp_direction.normalized();
  const cv::Mat img = Renderer(s).render({sphereAtOrigin(100)}, 0);
  const Vec3 h = (lamp + Vec3::UnitZ()).normalized();
  const double hu = 160 + 100 * h.x(), hv = 120 - 100 * h.y();
  double best = -1;
  int bu = 0, bv = 0;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u)
      if (at(img, v, u) > best) best = at(img, v, u), bu = u, bv = v;
  EXPECT_NEAR(bu, hu, 1.5);
  EXPECT_NEAR(bv, hv, 1.5);
  // Lambert part plus the full highlight, at its peak.
  EXPECT_NEAR(best / kFull, 0.5 * (0.1 + 0.9 * h.dot(lamp)) + 0.4, 0.01);
}

TEST(RenderImaging, BacklitSphereIsADarkSilhouetteWithABrightSpot) {
  RenderSettings s = orthographic();
  Lighting& l = s.imaging->lighting;
  l.mode = Lighting::Mode::Back;
  l.backdrop_level = 0.9;
  l.ambient = 0.05;
  l.sphere_albedo = 0.8;
  l.spot_level = 0.5;
  l.spot_fraction = 0.3;
  const cv::Mat img = Renderer(s).render({sphereAtOrigin(60)}, 0);
  EXPECT_NEAR(at(img, 5, 5) / kFull, 0.9, 1e-4);
  EXPECT_NEAR(at(img, 120, 160) / kFull, 0.04 + 0.5, 1e-4);  // inside the spot
  EXPECT_NEAR(at(img, 120, 160 + 40) / kFull, 0.04, 1e-4);   // 2/3 of the radius
  EXPECT_NEAR(at(img, 120, 160 + 17) / kFull, 0.54, 1e-4);   // spot edge at 18 px
  EXPECT_NEAR(at(img, 120 + 19, 160) / kFull, 0.04, 1e-4);   // just outside it
  EXPECT_NEAR(at(img, 120, 160 + 61) / kFull, 0.9, 1e-4);    // off the sphere
}

// Perspective: a sphere whose centre is off the optical axis.
struct Cone {
  Eigen::Vector2d centre_px;  // the silhouette ellipse's centre
  Eigen::Vector2d centre_projection_px;
  double area_px2;
};

// The sphere (centre C, camera frame X right, Y down, Z forward; radius R) is
// seen inside the cone of half-angle alpha = asin(R / |C|) around c = C / |C|,
// at angle theta from the axis. In the plane through the axis and c, the
// image's edges are at tan(theta -+ alpha); across it (by symmetry the
// ellipse's other axis, through its centre X0) the plane z = 1 meets the cone
// where (X0 sin theta + cos theta)^2 = cos^2 alpha (X0^2 + Y^2 + 1).
Cone perspectiveSilhouette(const Vec3& C, double R, double f, const Eigen::Vector2d& principal) {
  const double d = C.norm();
  const double alpha = std::asin(R / d);
  const double theta = std::acos(C.z() / d);
  const Eigen::Vector2d radial = Eigen::Vector2d(C.x(), C.y()).normalized();
  const double t1 = std::tan(theta - alpha), t2 = std::tan(theta + alpha);
  const double x0 = 0.5 * (t1 + t2);
  const double a = 0.5 * (t2 - t1);
  const double k = x0 * std::sin(theta) + std::cos(theta);
  const double b = std::sqrt(k * k / std::pow(std::cos(alpha), 2) - x0 * x0 - 1);
  return {principal + f * x0 * radial, principal + f * Eigen::Vector2d(C.x(), C.y()) / C.z(),
          kPi * a * b * f * f};
}

RenderSettings perspective(double f_px) {
  RenderSettings s;
  s.width = 640;
  s.height = 480;
  s.format = PixelFormat::Mono16;
  Imaging im;
  im.optics.perspective = true;
  im.optics.focal_px = f_px;
  im.optics.principal_u_px = 319.5;
  im.optics.principal_v_px = 239.5;
  im.optics.centre_m = Vec3(0, 0, 0.5);
  im.lighting.ambient = 1.0;  // evenly bright: the image is the silhouette
  im.lighting.sphere_albedo = 0.5;
  im.lighting.backdrop_level = 0.0;
  im.samples_per_pixel = 4;
  s.imaging = im;
  return s;
}

struct Blob {
  double area = 0;  // sum of levels / the sphere's level
  Eigen::Vector2d centroid{0, 0};
};

Blob blob(const cv::Mat& img, double level) {
  Blob b;
  double su = 0, sv = 0, sum = 0;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u) {
      const double w = at(img, v, u);
      sum += w;
      su += w * u;
      sv += w * v;
    }
  b.area = sum / level;
  b.centroid = {su / sum, sv / sum};
  return b;
}

TEST(RenderImaging, OffAxisSphereImagesAsTheTangentConesEllipse) {
  const RenderSettings s = perspective(500);
  SphereView sv;
  sv.centre_m = Vec3(0.16, 0.05, 0.0);
  sv.radius_m = 0.04;
  const cv::Mat img = Renderer(s).render({sv}, 0);
  // Camera frame: X = x - 0, Y = -(y - 0), Z = 0.5 - z.
  const Cone cone = perspectiveSilhouette(Vec3(0.16, -0.05, 0.5), 0.04, 500, {319.5, 239.5});
  const Blob b = blob(img, 0.5 * kFull);
  EXPECT_NEAR(b.area / cone.area_px2, 1.0, 1e-3);
  EXPECT_NEAR(b.centroid.x(), cone.centre_px.x(), 0.02);
  EXPECT_NEAR(b.centroid.y(), cone.centre_px.y(), 0.02);
  // The test means something: the ellipse's centre is not the centre's image.
  EXPECT_GT((cone.centre_px - cone.centre_projection_px).norm(), 0.5);
  EXPECT_GT((b.centroid - cone.centre_projection_px).norm(), 0.5);
}

// The image area (px^2) of the part of a spherical cap (centre `dot`, a unit
// vector from the sphere's centre C, half-angle rho) that a pinhole at O sees,
// by summing over the cap: a surface element dA at P with normal n subtends
// the solid angle (n . w) dA / |w|^3, w = O - P, and a solid angle at field
// angle theta covers f^2 / cos^3(theta) of the image plane. The camera looks
// along -z; the element is seen when n . w > 0.
double capImageArea(const Vec3& C, double R, const Vec3& dot, double rho, const Vec3& O, double f) {
  const Vec3 e1 = dot.unitOrthogonal(), e2 = dot.cross(e1);
  constexpr int kA = 400, kPhi = 1600;  // converged to ~1e-3 px^2 (checked at 4x)
  double area = 0;
  for (int i = 0; i < kA; ++i) {
    const double a = (i + 0.5) * rho / kA;
    const double dA = R * R * std::sin(a) * (rho / kA) * (2 * kPi / kPhi);
    for (int j = 0; j < kPhi; ++j) {
      const double phi = (j + 0.5) * 2 * kPi / kPhi;
      const Vec3 n = std::cos(a) * dot + std::sin(a) * (std::cos(phi) * e1 + std::sin(phi) * e2);
      const Vec3 w = O - (C + R * n);
      const double facing = n.dot(w);
      if (facing <= 0) continue;
      const double dist = w.norm(), cos_field = w.z() / dist;
      area += f * f * facing * dA / (dist * dist * dist) / std::pow(cos_field, 3);
    }
  }
  return area;
}

// Dots are drawn wherever their caps show, on the limb too (where the image
// of a cap is no longer bounded by the image of its rim): the light a dot
// takes from an evenly lit sphere is its cap's image area, summed over the
// cap here. One dot at a time: wholly in view, centred on the limb, and
// mostly behind it with a sliver in view.
TEST(RenderImaging, ADotsImageAreaIsItsVisibleCapsProjectedArea) {
  RenderSettings s = perspective(500);
  s.imaging->lighting.dot_albedo = 0.0;  // a dot takes all the light of its area
  const Vec3 C(0.1, 0.05, 0.0), O(0, 0, 0.5);
  const double R = 0.04, rho = 0.6;
  SphereView sv;
  sv.centre_m = C;
  sv.radius_m = R;
  const Renderer renderer(s);
  const double level = 0.5 * kFull;
  const double bare = blob(renderer.render({sv}, 0), level).area;
  const Vec3 towards = (O - C).normalized();
  const double limit = std::acos(R / (O - C).norm());  // the limb, from `towards`
  // Round `towards`: t1 points along +u in the image, t2 along v. The limb
  // dot and the sliver lie along u, where the silhouette's arc bulges out of
  // the box of the cap's rim by pixels.
  const Vec3 t1 = (Vec3::UnitX() - towards.x() * towards).normalized(), t2 = towards.cross(t1);
  struct Case {
    double from_axis, azimuth;
  };
  std::vector<double> areas;
  for (const Case c : {Case{0.6, 2.0}, Case{limit, 0.0}, Case{limit + 0.5 * rho, kPi}}) {
    DotPattern one;
    one.angular_radius_rad = rho;
    one.centres = {std::cos(c.from_axis) * towards +
                   std::sin(c.from_axis) * (std::cos(c.azimuth) * t1 + std::sin(c.azimuth) * t2)};
    sv.dots = &one;
    const double rendered = bare - blob(renderer.render({sv}, 0), level).area;
    const double truth = capImageArea(C, R, one.centres[0], rho, O, 500);
    // 4 x 4 rays place an edge to 1/16 of a pixel: along the ~50 px of a
    // rim near the limb, a bias of up to ~1 px^2 (the renderer before the
    // traced batches gave the same areas to 1e-3 px^2).
    EXPECT_NEAR(rendered, truth, 1.0 + 2e-3 * truth)
        << "dot " << c.from_axis << " rad from the axis";
    areas.push_back(truth);
  }
  // The cases are what they say: half of the limb dot and a sliver of the
  // last one show.
  EXPECT_LT(areas[1], 0.6 * areas[0]);
  EXPECT_GT(areas[2], 1.0);
  EXPECT_LT(areas[2], 0.3 * areas[1]);
}

TEST(RenderImaging, PerspectiveShadingFollowsTheTrueNormals) {
  RenderSettings s = perspective(500);
  s.imaging->samples_per_pixel = 1;
  Lighting& l = s.imaging->lighting;
  l.lamp_direction = Vec3(0.3, 0.5, 0.8);
  l.ambient = 0.1;
  l.sphere_albedo = 0.8;
  const Vec3 lamp = l.lamp_direction.normalized();
  SphereView sv;
  sv.centre_m = Vec3(0.1, 0.05, 0.0);
  sv.radius_m = 0.04;
  const cv::Mat img = Renderer(s).render({sv}, 0);
  // Each pixel centre's ray from the lens at (0, 0, 0.5) meets the sphere at
  // the nearer root of |O + t d - C| = R; the normal there sets the level.
  const Vec3 O(0, 0, 0.5), C = sv.centre_m;
  int checked = 0;
  for (int v = 100; v < 240; v += 3)
    for (int u = 380; u < 520; u += 3) {
      const Vec3 d = Vec3((u - 319.5) / 500, -(v - 239.5) / 500, -1).normalized();
      const double b = d.dot(C - O), c = (C - O).squaredNorm() - 0.04 * 0.04;
      if (b * b - c < 1e-6) continue;  // misses, or grazes the limb
      const Vec3 n = (O + (b - std::sqrt(b * b - c)) * d - C) / 0.04;
      const double expected = kFull * 0.8 * (0.1 + 0.9 * std::max(0.0, n.dot(lamp)));
      EXPECT_NEAR(at(img, v, u), expected, 1.0) << u << ", " << v;
      ++checked;
    }
  EXPECT_GT(checked, 300);
}

TEST(RenderImaging, OnAxisSphereIsACircleOfRadiusFTanAlpha) {
  const RenderSettings s = perspective(800);
  SphereView sv;
  sv.centre_m = Vec3(0, 0, 0.1);  // 0.4 m from the lens
  sv.radius_m = 0.0127;
  const Blob b = blob(Renderer(s).render({sv}, 0), 0.5 * kFull);
  const double r = 800 * std::tan(std::asin(0.0127 / 0.4));
  EXPECT_NEAR(b.area / (kPi * r * r), 1.0, 1e-3);
  EXPECT_NEAR(b.centroid.x(), 319.5, 0.01);
  EXPECT_NEAR(b.centroid.y(), 239.5, 0.01);
}

// OpenCV's camera model (docs of cv::projectPoints / calib3d), written out.
Eigen::Vector2d opencvProject(const Vec3& Xc, double f, double cu, double cv, double k1, double k2,
                              double p1, double p2) {
  const double x = Xc.x() / Xc.z(), y = Xc.y() / Xc.z();
  const double r2 = x * x + y * y;
  const double radial = 1 + k1 * r2 + k2 * r2 * r2;
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {f * xd + cu, f * yd + cv};
}

TEST(RenderImaging, DistortionMovesAPointWhereOpenCvsModelSays) {
  RenderSettings s = perspective(800);
  Optics& o = s.imaging->optics;
  o.k1 = -0.25;
  o.k2 = 0.08;
  o.p1 = 0.002;
  o.p2 = -0.003;
  s.imaging->samples_per_pixel = 8;
  for (const Vec3& w : {Vec3(0.12, -0.08, 0.0), Vec3(-0.15, 0.1, 0.02), Vec3(0.05, 0.11, -0.03)}) {
    SphereView sv;
    sv.centre_m = w;
    sv.radius_m = 0.001;
    const Blob b = blob(Renderer(s).render({sv}, 0), 0.5 * kFull);
    const Vec3 Xc(w.x(), -w.y(), 0.5 - w.z());
    const Eigen::Vector2d expected =
        opencvProject(Xc, 800, 319.5, 239.5, -0.25, 0.08, 0.002, -0.003);
    const Eigen::Vector2d ideal = opencvProject(Xc, 800, 319.5, 239.5, 0, 0, 0, 0);
    EXPECT_GT((expected - ideal).norm(), 2.0);  // the distortion is well visible
    EXPECT_NEAR(b.centroid.x(), expected.x(), 0.03) << w.transpose();
    EXPECT_NEAR(b.centroid.y(), expected.y(), 0.03) << w.transpose();
    EXPECT_NEAR((o.project(w) - expected).norm(), 0.0, 1e-9);
  }
}

TEST(RenderImaging, BlurKeepsTheImagesEnergyAndSmearsTranslationAndRotation) {
  // Lamp along the line of sight and spin about it: every surface point keeps
  // its brightness as it turns, and an in-plane translation keeps the disc
  // whole, so the image's integral cannot change; only its shape may.
  RenderSettings s = orthographic();
  s.imaging->samples_per_pixel = 3;
  s.imaging->lighting.lamp_direction = Vec3::UnitZ();
  s.imaging->lighting.ambient = 0.2;
  s.imaging->lighting.backdrop_level = 0.1;
  const DotPattern dots = DotPattern::random(7);
  SphereView sv = sphereAtOrigin(50);
  sv.dots = &dots;
  sv.velocity_m_s = Vec3(1.0, 0.4, 0.0);  // 2 ms: 20 x 8 px
  sv.spin_rad_s = Vec3(0, 0, 300);        // 0.6 rad over the exposure
  const cv::Mat still = Renderer(s).render({sv}, 0);
  s.exposure_s = 2e-3;
  const cv::Mat blurred = Renderer(s).render({sv}, 0);
  const double bg = 0.1 * kFull;
  double e_still = 0, e_blur = 0, diff = 0;
  for (int v = 0; v < still.rows; ++v)
    for (int u = 0; u < still.cols; ++u) {
      e_still += at(still, v, u) - bg;
      e_blur += at(blurred, v, u) - bg;
      diff += std::abs(at(still, v, u) - at(blurred, v, u));
    }
  EXPECT_NEAR(e_blur / e_still, 1.0, 1e-3);
  EXPECT_GT(diff / std::abs(e_still), 0.1);  // it did blur
  // Rotation alone: the dots' smear changes the picture, the energy stays.
  sv.velocity_m_s = Vec3::Zero();
  const cv::Mat spun = Renderer(s).render({sv}, 0);
  double e_spun = 0, d_spun = 0;
  for (int v = 0; v < still.rows; ++v)
    for (int u = 0; u < still.cols; ++u) {
      e_spun += at(spun, v, u) - bg;
      d_spun += std::abs(at(still, v, u) - at(spun, v, u));
    }
  EXPECT_NEAR(e_spun / e_still, 1.0, 1e-3);
  EXPECT_GT(d_spun / std::abs(e_still), 0.01);
}

TEST(RenderImaging, VignettingFollowsCos4OfTheFieldAngle) {
  RenderSettings s = perspective(400);
  s.imaging->lighting.backdrop_level = 0.5;
  s.imaging->sensor.vignetting_cos4 = true;
  const cv::Mat img = Renderer(s).render({}, 0);
  for (const auto& [u, v] : {std::pair{0, 0}, std::pair{639, 479}, std::pair{320, 10}}) {
    const double q = 1 + (std::pow(u - 319.5, 2) + std::pow(v - 239.5, 2)) / (400.0 * 400.0);
    EXPECT_NEAR(at(img, v, u) / kFull, 0.5 / (q * q), 1e-4) << u << ", " << v;
  }
  EXPECT_LT(at(img, 0, 0), 0.6 * at(img, 240, 320));  // plainly visible
}

TEST(RenderImaging, RadialFalloffDimsTheCornersByItsFraction) {
  RenderSettings s = orthographic();
  s.imaging->lighting.backdrop_level = 0.8;
  s.imaging->sensor.vignetting_falloff = 0.3;
  const cv::Mat img = Renderer(s).render({}, 0);
  EXPECT_NEAR(at(img, 0, 0) / kFull, 0.8 * 0.7, 1e-4);
  EXPECT_NEAR(at(img, 239, 319) / kFull, 0.8 * 0.7, 1e-4);
}

TEST(RenderImaging, MainsFlickerModulatesFramesByItsExposureAveragedAmplitude) {
  RenderSettings s = orthographic();
  s.imaging->lighting.backdrop_level = 0.5;
  s.imaging->sensor.flicker_hz = 100;
  s.imaging->sensor.flicker_amplitude = 0.2;
  s.exposure_s = 2e-3;  // a fifth of a flicker period: cos averages to sinc(0.2)
  const Renderer r(s);
  const double avg = std::sin(kPi * 0.2) / (kPi * 0.2);
  EXPECT_NEAR(at(r.render({}, 0, 0.0), 5, 5) / kFull, 0.5 * (1 + 0.2 * avg), 2e-5);
  EXPECT_NEAR(at(r.render({}, 1, 0.005), 5, 5) / kFull, 0.5 * (1 - 0.2 * avg), 2e-5);
  EXPECT_NEAR(at(r.render({}, 2, 0.0025), 5, 5) / kFull, 0.5, 2e-5);
}

TEST(RenderImaging, ShotAndReadNoiseHaveThePhotonLimitedSpread) {
  RenderSettings s = orthographic();
  s.imaging->lighting.backdrop_level = 0.5;
  s.imaging->sensor.full_well_e = 10000;
  s.imaging->sensor.read_noise_e = 20;
  const cv::Mat img = Renderer(s).render({}, 3);
  cv::Scalar mean, sd;
  cv::meanStdDev(img, mean, sd);
  EXPECT_NEAR(mean[0] / kFull, 0.5, 1e-3);
  const double expected_sd = kFull * std::sqrt(5000.0 + 400.0) / 10000.0;
  EXPECT_NEAR(sd[0] / expected_sd, 1.0, 0.03);
  // Gain multiplies signal and noise alike.
  s.imaging->sensor.gain = 1.5;
  s.imaging->lighting.backdrop_level = 0.3;
  cv::meanStdDev(Renderer(s).render({}, 3), mean, sd);
  EXPECT_NEAR(mean[0] / kFull, 0.45, 1e-3);
  EXPECT_NEAR(sd[0] / (1.5 * kFull * std::sqrt(3000.0 + 400.0) / 10000.0), 1.0, 0.03);
}

TEST(RenderImaging, AdcBitsAreShiftedIntoTheFormatsWords) {
  RenderSettings s = orthographic();
  s.imaging->lighting.backdrop_level = 0.3;
  s.imaging->sensor.adc_bits = 10;
  s.imaging->sensor.full_well_e = 20000;
  const cv::Mat img = Renderer(s).render({sphereAtOrigin(40)}, 0);
  int distinct_low_bits = 0;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u) distinct_low_bits += img.at<std::uint16_t>(v, u) % 64 != 0;
  EXPECT_EQ(distinct_low_bits, 0);
  EXPECT_NEAR(at(img, 5, 5) / 64.0, 0.3 * 1023, 15);
}

TEST(RenderImaging, HotPixelsAndFixedPatternStayPutFromFrameToFrame) {
  RenderSettings s = orthographic();
  s.imaging->lighting.backdrop_level = 0.3;
  s.imaging->sensor.hot_pixel_fraction = 0.01;
  s.imaging->sensor.hot_pixel_level = 0.5;
  s.imaging->sensor.prnu = 0.02;
  const Renderer r(s);
  const cv::Mat a = r.render({}, 0), b = r.render({}, 1);
  EXPECT_EQ(cv::countNonZero(a != b), 0);
  const int hot = cv::countNonZero(a > 0.7 * kFull);
  EXPECT_NEAR(hot / (320.0 * 240.0), 0.01, 0.002);
  cv::Mat cold;
  a.convertTo(cold, CV_64F);
  cv::Scalar mean, sd;
  cv::meanStdDev(cold, mean, sd, a < 0.6 * kFull);
  EXPECT_NEAR(sd[0] / mean[0], 0.02, 0.002);
}

}  // namespace
}  // namespace collide::vision
