#include "hw/launch_plan.hpp"

#include <algorithm>

#include "analysis/flight.hpp"
#include "hw/format.hpp"

namespace collide::hw {

Vec3 meetPoint(const RigProfile& p) {
  if (p.geometry.meet_point_m) return *p.geometry.meet_point_m;
  const double u = 0.5 * (p.camera_config.width - 1);
  const double v = 0.5 * (p.camera_config.height - 1);
  return {(u - p.geometry.origin_u_px) * p.geometry.pixel_size_m,
          -(v - p.geometry.origin_v_px) * p.geometry.pixel_size_m, 0.0};
}

Eigen::Vector2d worldToPixel(const RigProfile& p, const Vec3& w) {
  return {p.geometry.origin_u_px + w.x() / p.geometry.pixel_size_m,
          p.geometry.origin_v_px - w.y() / p.geometry.pixel_size_m};
}

namespace {

// A wall rig: launcher 1 fires at the plate, launcher 2 stays shut (the
// sequencer holds it at 0 kPa and never opens its valve).
Result<LaunchPlan> planWallLaunch(const RigProfile& p, const std::array<double, 2>& v) {
  LaunchPlan plan;
  plan.exit_speed_m_s = v;
  const LauncherProfile& l = p.launchers[0];
  if (!(v[0] > 0))
    return fail("launcher " + l.name + ": exit speed " + num(v[0]) + " m/s must be > 0");
  FlightSetup setup;
  setup.material = p.spheres.material;
  setup.air_density_kg_m3 = p.analysis.air_density_kg_m3;
  setup.wall = p.wall;
  for (int i = 0; i < 2; ++i) {
    Sphere& s = setup.spheres[i];
    s.mass_kg = p.spheres.mass_kg[i];
    s.diameter_m = p.spheres.diameter_m[i];
    s.position_m = p.launchers[i].exit_m;
  }
  setup.spheres[0].velocity_m_s = v[0] * l.direction;
  setup.launch_time_s = {p.calibration.exit_delay_s, 1e6};
  Result<Flight> flight = Flight::create(setup);
  if (!flight) return fail("launch plan: " + flight.error().message);
  if (!flight->collides())
    return fail("the sphere would miss the wall at " + num(v[0]) +
                " m/s: check launcher 1's exit_m and direction and the [wall] table");
  plan.contact_s = flight->collisionTime_s();
  const SphereState& before = flight->justBefore()[0];
  Vec3 n = p.wall->normal;
  if ((before.position_m - p.wall->point_m).dot(n) < 0) n = -n;
  plan.contact_point_m = before.position_m - 0.5 * p.spheres.diameter_m[0] * n;
  plan.contact_normal = n;
  plan.relative_velocity_m_s = before.velocity_m_s;
  plan.before_contact[0] = setup.spheres[0];
  plan.before_contact[0].position_m = before.position_m;
  plan.before_contact[0].velocity_m_s = before.velocity_m_s;
  plan.before_contact[1] = setup.spheres[1];
  plan.contact_px = worldToPixel(p, plan.contact_point_m);
  const double u = plan.contact_px.x(), vpx = plan.contact_px.y();
  if (u < 0 || vpx < 0 || u > p.camera_config.width - 1 || vpx > p.camera_config.height - 1)
    return fail("at " + num(v[0]) + " m/s the sphere would strike the wall at pixel (" + num(u) +
                ", " + num(vpx) + "), outside the " + std::to_string(p.camera_config.width) + "x" +
                std::to_string(p.camera_config.height) +
                " image: choose another speed or move the wall");
  return plan;
}

}  // namespace

Result<LaunchPlan> planLaunch(const RigProfile& p, const std::array<double, 2>& v) {
  if (p.wall) return planWallLaunch(p, v);
  LaunchPlan plan;
  plan.exit_speed_m_s = v;
  const Vec3 meet = meetPoint(p);
  // First guess, ignoring gravity: each sphere's centre stops one radius short
  // of the meet point along its tube's axis; launch them so both get there at
  // once.
  std::array<double, 2> travel_s{};
  for (int i = 0; i < 2; ++i) {
    const LauncherProfile& l = p.launchers[i];
    if (!(v[i] > 0))
      return fail("launcher " + l.name + ": exit speed " + num(v[i]) + " m/s must be > 0");
    const double distance = (meet - l.exit_m).dot(l.direction) - 0.5 * p.spheres.diameter_m[i];
    if (!(distance > 0))
      return fail("launcher " + l.name +
                  ": the meet point lies behind its muzzle: check "
                  "launcher.exit_m, launcher.direction and geometry.meet_point_m");
    // Slowed by the air on the way (gravity bends the path, not the time).
    const AirDrag air{p.spheres.diameter_m[i], p.spheres.mass_kg[i], p.analysis.air_density_kg_m3};
    travel_s[i] = air.travelTime_s(distance, v[i]);
  }
  const double longest = std::max(travel_s[0], travel_s[1]);
  for (int i = 0; i < 2; ++i) plan.valve_open_s[i] = longest - travel_s[i];

  // Then the real flight, with gravity, for the contact instant and place.
  FlightSetup setup;
  setup.material = p.spheres.material;
  setup.air_density_kg_m3 = p.analysis.air_density_kg_m3;
  for (int i = 0; i < 2; ++i) {
    Sphere& s = setup.spheres[i];
    s.mass_kg = p.spheres.mass_kg[i];
    s.diameter_m = p.spheres.diameter_m[i];
    s.position_m = p.launchers[i].exit_m;
    s.velocity_m_s = v[i] * p.launchers[i].direction;
    setup.launch_time_s[i] = plan.valve_open_s[i] + p.calibration.exit_delay_s;
  }
  Result<Flight> flight = Flight::create(setup);
  if (!flight) return fail("launch plan: " + flight.error().message);
  if (!flight->collides())
    return fail("the spheres would miss each other at " + num(v[0]) + " and " + num(v[1]) +
                " m/s: check the launchers' exit_m and direction");
  plan.contact_s = flight->collisionTime_s();
  const auto& before = flight->justBefore();
  plan.contact_point_m = 0.5 * (before[0].position_m + before[1].position_m);
  plan.contact_normal = (before[0].position_m - before[1].position_m).normalized();
  plan.relative_velocity_m_s = before[0].velocity_m_s - before[1].velocity_m_s;
  for (int i = 0; i < 2; ++i) {
    Sphere& s = plan.before_contact[i];
    s = setup.spheres[i];
    s.position_m = before[i].position_m;
    s.velocity_m_s = before[i].velocity_m_s;
    s.spin_rad_s = before[i].spin_rad_s;
  }
  plan.contact_px = worldToPixel(p, plan.contact_point_m);
  const double u = plan.contact_px.x(), vpx = plan.contact_px.y();
  if (u < 0 || vpx < 0 || u > p.camera_config.width - 1 || vpx > p.camera_config.height - 1)
    return fail("at " + num(v[0]) + " and " + num(v[1]) + " m/s the spheres would meet at pixel (" +
                num(u) + ", " + num(vpx) + "), outside the " +
                std::to_string(p.camera_config.width) + "x" +
                std::to_string(p.camera_config.height) +
                " image: choose other speeds or move the launchers");
  return plan;
}

}  // namespace collide::hw
