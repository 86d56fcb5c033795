#include "app/wall_campaign.hpp"

#include <cmath>
#include <cstdio>
#include <regex>

#include "hw/launch_plan.hpp"

namespace collide::app {

namespace {

// The text with one `key = [...]` line of the [wall] table replaced.
Result<std::string> withWallVector(const std::string& text, const std::string& key,
                                   const Vec3& value) {
  const std::size_t wall = text.find("\n[wall]");
  if (wall == std::string::npos) return fail("the rig profile has no [wall] table to turn");
  const std::regex key_re("\n" + key + R"(\s*=\s*\[[^\]]*\])");
  std::smatch m;
  const std::string tail = text.substr(wall);
  if (!std::regex_search(tail, m, key_re))
    return fail("the rig profile's [wall] table has no " + key + " = [x, y, z] line to change");
  char replacement[200];
  std::snprintf(replacement, sizeof replacement, "\n%s = [%.9g, %.9g, %.9g]", key.c_str(),
                value.x(), value.y(), value.z());
  return text.substr(0, wall + m.position(0)) + replacement +
         tail.substr(m.position(0) + m.length(0));
}

}  // namespace

Result<hw::RigProfile> aimWallForIncidence(const hw::RigProfile& profile, double incidence_deg,
                                           double speed_m_s) {
  if (!profile.wall) return fail("the rig profile has no [wall] table: not a wall rig");
  if (!(incidence_deg >= 0 && incidence_deg < 90))
    return fail("incidence " + std::to_string(incidence_deg) + " deg: must be in [0, 90)");
  // The sphere's path does not depend on the plate until it touches it: the
  // centre where it meets the profile's plate is the pivot, and the plate is
  // turned about the point under it so that it meets the path there at the
  // wanted angle from the velocity at that point.
  auto plan = hw::planLaunch(profile, {speed_m_s, speed_m_s});
  if (!plan) return plan.error();
  const Vec3 pivot = plan->before_contact[0].position_m;
  const Vec3 d = plan->relative_velocity_m_s.normalized();
  const Vec3 back(-d.x(), -d.y(), 0.0);
  // Turned towards the side the profile's plate leans to.
  const double side = profile.wall->normal.cross(back).z() >= 0 ? -1.0 : 1.0;
  const double a = side * incidence_deg * M_PI / 180.0;
  const Vec3 n = Vec3(std::cos(a) * back.x() - std::sin(a) * back.y(),
                      std::sin(a) * back.x() + std::cos(a) * back.y(), 0.0)
                     .normalized();
  const Vec3 point = pivot - 0.5 * profile.spheres.diameter_m[0] * n;
  auto text = withWallVector(profile.text, "normal", n);
  if (text) text = withWallVector(*text, "point_m", point);
  if (!text) return text.error();
  auto aimed = hw::parseRigProfile(*text, profile.source);
  if (!aimed) return aimed.error();
  if (auto check = hw::planLaunch(*aimed, {speed_m_s, speed_m_s}); !check) return check.error();
  return aimed;
}

}  // namespace collide::app
