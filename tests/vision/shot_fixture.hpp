#pragma once
// Simulated shots with known truth for the vision tests and benchmarks: two
// spheres in free flight (analysis/flight.hpp, Walton's operator at contact),
// drawn frame by frame by vision/render.hpp the way the simulated camera draws
// them (state at mid-exposure, motion blur over the exposure, noise).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "analysis/flight.hpp"
#include "analysis/walton.hpp"
#include "vision/render.hpp"
#include "vision/shot_analysis.hpp"

namespace collide::vision::testing {

struct ShotSpec {
  int width = 640, height = 480;
  PixelFormat format = PixelFormat::Mono8;
  double pixel_size_m = 2.1167e-4;  // 25.4 mm over 120 px
  double diameter_m = 0.0254;
  double mass_kg = 0.00978;
  double fps = 1000;
  double exposure_us = 200;
  double noise_grey = 2.0;
  int frames_before = 30;  // frames with id < 0 (the collision is between frames -1 and 0)
  int frames_after = 40;
  double speed1_m_s = 2.0, speed2_m_s = 2.0;  // approach speeds (sphere 1 right, sphere 2 left)
  /// Angle (rad) between the line of centres at contact and the horizontal.
  double contact_angle_rad = 0.3;
  double spin_max_rad_s = 20;  ///< each sphere's spin: random axis, magnitude up to this
  /// Standard deviation of the z part of the unit line of centres at contact
  /// (the spheres fly in two planes this far apart, times the diameter).
  double contact_z_sigma = 0.0;
  /// Standard deviation of each sphere's z velocity, as a fraction of its speed.
  double out_of_plane_fraction = 0.0;
  /// Spread of each sphere's vertical launch velocity (uniform, m/s).
  double vy_spread_m_s = 0.15;
  bool dots = true;  ///< false: plain spheres (no spin can be measured)
  /// > 0: the camera's distance from the object plane (m), and each sphere's
  /// drawn radius grows as it comes nearer (r = r0 Z0 / (Z0 - z); the centres
  /// stay where an orthographic camera puts them). 0: radius constant.
  double camera_distance_m = 0;
  Material material{0.97, 0.176, 0.44};
  /// The air the spheres fly through (its drag slows them, analysis/air_drag.hpp),
  /// and the analysis is told; 0: a vacuum.
  double air_density_kg_m3 = kAirDensity_kg_m3;
  /// Lamps, lens and sensor (vision/imaging.hpp): the spheres are ray-cast at
  /// their world positions (the optics' pixel size should be pixel_size_m,
  /// its origin the image centre). Unset: the even-light picture.
  std::optional<Imaging> imaging;
  /// Not physics: sphere 1 drawn after the contact with this much more spin
  /// about the camera axis (rad/s) than the impact gave it, as a dot taken for
  /// another would make it seem (angular momentum then not conserved).
  double spin_kick_after_rad_s = 0;
  std::uint64_t seed = 1;
};

struct SimulatedShot {
  Burst burst;
  AnalysisSettings settings;
  Flight flight;
  double t_first_s = 0;                      ///< flight time of the first frame's mid-exposure
  WaltonMeasurement truth;                   ///< Walton's inverse on the true states at contact
  std::array<SphereState, 2> before, after;  ///< true states just before/after contact
  /// Analysis clock (seconds from the first frame's mid-exposure) of the contact.
  double t_collision_s = 0;
  std::array<DotPattern, 2> dots;
  std::vector<std::array<SphereState, 2>> states;  ///< per frame, at mid-exposure
};

inline Vec3 randomUnitVec(std::mt19937_64& rng) {
  std::normal_distribution<double> nd;
  return Vec3(nd(rng), nd(rng), nd(rng)).normalized();
}

/// config/sim-lab.toml's lamp and sensor (one-sided light with a highlight,
/// 10 bits, shot, read and fixed-pattern noise, hot pixels), orthographic (true
/// centres exact), ShotSpec's 2.1167e-4 m pixels with the origin at the centre
/// of a 640 x 480 frame.
inline Imaging simLabImaging() {
  Imaging im;
  const double pixel = 2.1167e-4;
  im.optics.pixel_size_m = pixel;
  im.optics.origin_u_px = 319.5;
  im.optics.origin_v_px = 239.5;
  im.lighting.lamp_direction = Vec3(-0.55, 0.45, 0.70).normalized();
  im.lighting.ambient = 0.12;
  im.lighting.sphere_albedo = 0.80;
  im.lighting.dot_albedo = 0.06;
  im.lighting.specular_strength = 0.30;
  im.lighting.specular_exponent = 80.0;
  im.lighting.backdrop_level = 0.07;
  im.sensor.vignetting_falloff = 0.10;
  im.sensor.prnu = 0.008;
  im.sensor.dsnu = 0.002;
  im.sensor.hot_pixel_fraction = 0.0002;
  im.sensor.hot_pixel_level = 0.4;
  im.sensor.full_well_e = 20000;
  im.sensor.read_noise_e = 15;
  im.sensor.adc_bits = 10;
  return im;
}

/// config/sim-thesis.toml's camera: 240 x 192 at 6.865e-4 m per pixel (37 px
/// spheres) with the origin at the image centre, one lamp upper right, few
/// photoelectrons (400 e- full well), the intensifier's dark rim.
inline Imaging simThesisImaging() {
  Imaging im;
  im.optics.pixel_size_m = 6.865e-4;
  im.optics.origin_u_px = 119.5;
  im.optics.origin_v_px = 95.5;
  im.lighting.lamp_direction = Vec3(0.5, 0.3, 0.81).normalized();
  im.lighting.ambient = 0.3;
  im.lighting.sphere_albedo = 0.85;
  im.lighting.dot_albedo = 0.05;
  im.lighting.specular_strength = 0.08;
  im.lighting.specular_exponent = 20;
  im.lighting.backdrop_level = 0.04;
  im.sensor.full_well_e = 400;
  im.sensor.read_noise_e = 2;
  im.sensor.vignetting_falloff = 0.3;
  im.samples_per_pixel = 2;
  return im;
}

/// A shot whose spheres touch between frames -1 and 0, in the middle of the image.
inline SimulatedShot simulateShot(const ShotSpec& spec) {
  std::mt19937_64 rng(spec.seed);
  std::uniform_real_distribution<double> uni(0, 1);
  SimulatedShot shot;
  const double dt = 1.0 / spec.fps;
  const double d = spec.diameter_m;
  // Contact at flight time tm, at the world origin (image centre), with the
  // launch (t = 0) before the first frame.
  const double tm = std::max(0.05, (spec.frames_before + 5) * dt);
  const double nz = spec.contact_z_sigma * std::normal_distribution<double>()(rng);
  const Vec3 n = Vec3(std::cos(spec.contact_angle_rad), std::sin(spec.contact_angle_rad), 0) *
                     std::sqrt(1 - nz * nz) +
                 Vec3(0, 0, nz);
  const Vec3 c1 = -0.5 * d * n, c2 = 0.5 * d * n;
  std::normal_distribution<double> nd;
  const Vec3 v1(spec.speed1_m_s, spec.vy_spread_m_s * (uni(rng) - 0.5),
                spec.out_of_plane_fraction * spec.speed1_m_s * nd(rng));
  const Vec3 v2(-spec.speed2_m_s, spec.vy_spread_m_s * (uni(rng) - 0.5),
                spec.out_of_plane_fraction * spec.speed2_m_s * nd(rng));
  FlightSetup setup;
  setup.material = spec.material;
  setup.air_density_kg_m3 = spec.air_density_kg_m3;
  for (int i = 0; i < 2; ++i) {
    Sphere& s = setup.spheres[i];
    const Vec3 v = i == 0 ? v1 : v2;
    const Vec3 c = i == 0 ? c1 : c2;
    s.mass_kg = spec.mass_kg;
    s.diameter_m = d;
    s.velocity_m_s = v - kGravity_m_s2 * tm;  // so that it is v at tm
    s.position_m = c - v * tm + 0.5 * kGravity_m_s2 * tm * tm;
    s.spin_rad_s = randomUnitVec(rng) * spec.spin_max_rad_s * uni(rng);
    setup.orientation_at_launch[i] = Quat(Eigen::AngleAxisd(6.28 * uni(rng), randomUnitVec(rng)));
    setup.launch_time_s[i] = 0;
    const std::uint64_t dot_seed = rng();
    if (spec.dots) shot.dots[i] = DotPattern::random(dot_seed);
  }
  auto flight = Flight::create(setup);
  if (!flight) throw std::runtime_error(flight.error().message);
  shot.flight = *flight;
  const double t_contact = shot.flight.collisionTime_s();
  // Frame 0's mid-exposure a random fraction of a period after the contact.
  const double t0 = t_contact + dt * uni(rng);

  RenderSettings rs;
  rs.width = spec.width;
  rs.height = spec.height;
  rs.format = spec.format;
  rs.exposure_s = spec.exposure_us * 1e-6;
  rs.noise_grey = spec.noise_grey;
  rs.noise_seed = spec.seed * 7919 + 1;
  rs.imaging = spec.imaging;
  const Renderer renderer(rs);
  const double ou = (spec.width - 1) / 2.0, ov = (spec.height - 1) / 2.0;
  const double px = spec.pixel_size_m;
  shot.burst.format = spec.format;
  shot.burst.fps = spec.fps;
  shot.burst.exposure_us = spec.exposure_us;
  const std::int64_t epoch_ns = 123456789000;
  for (int id = -spec.frames_before; id < spec.frames_after; ++id) {
    const double t = t0 + id * dt;
    const auto st = shot.flight.at(t);
    std::vector<SphereView> views;
    for (int i = 0; i < 2; ++i) {
      SphereView v;
      v.centre_px = {ou + st[i].position_m.x() / px, ov - st[i].position_m.y() / px};
      v.radius_px = 0.5 * d / px;
      if (spec.camera_distance_m > 0)
        v.radius_px *= spec.camera_distance_m / (spec.camera_distance_m - st[i].position_m.z());
      v.orientation = st[i].orientation;
      v.velocity_px_s = {st[i].velocity_m_s.x() / px, -st[i].velocity_m_s.y() / px};
      v.spin_rad_s = st[i].spin_rad_s;
      if (i == 0 && t > t_contact && spec.spin_kick_after_rad_s != 0) {
        const double turn = spec.spin_kick_after_rad_s * (t - t_contact);
        v.orientation = Quat(Eigen::AngleAxisd(turn, Vec3::UnitZ())) * v.orientation;
        v.spin_rad_s.z() += spec.spin_kick_after_rad_s;
      }
      v.dots = &shot.dots[i];
      v.centre_m = st[i].position_m;
      v.radius_m = 0.5 * d;
      v.velocity_m_s = st[i].velocity_m_s;
      views.push_back(v);
    }
    Frame f;
    f.id = id;
    f.timestamp_ns = epoch_ns + std::llround((t - t0 - 0.5 * rs.exposure_s) * 1e9);
    f.image = renderer.render(views, static_cast<std::uint64_t>(id + 1000));
    shot.burst.frames.push_back(std::move(f));
    shot.states.push_back(st);
  }
  shot.t_first_s = t0 - spec.frames_before * dt;
  shot.t_collision_s = t_contact - shot.t_first_s;
  shot.before = shot.flight.justBefore();
  shot.after = shot.flight.justAfter();
  std::array<Sphere, 2> b, a;
  for (int i = 0; i < 2; ++i) {
    b[i] = setup.spheres[i];
    b[i].position_m = shot.before[i].position_m;
    b[i].velocity_m_s = shot.before[i].velocity_m_s;
    b[i].spin_rad_s = shot.before[i].spin_rad_s;
    a[i] = b[i];
    a[i].velocity_m_s = shot.after[i].velocity_m_s;
    a[i].spin_rad_s = shot.after[i].spin_rad_s;
  }
  shot.truth = *measureCollision(b, a);

  AnalysisSettings& as = shot.settings;
  as.pixel_size_m = px;
  as.diameter_m = {d, d};
  as.mass_kg = {spec.mass_kg, spec.mass_kg};
  as.air_density_kg_m3 = spec.air_density_kg_m3;
  as.origin_u_px = ou;
  as.origin_v_px = ov;
  as.fps = spec.fps;
  as.line_of_centres_z_sigma = std::max(spec.contact_z_sigma, 1e-4);
  as.out_of_plane_speed_fraction = spec.out_of_plane_fraction;
  as.camera_distance_m = spec.camera_distance_m;
  return shot;
}

}  // namespace collide::vision::testing
