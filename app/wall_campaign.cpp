#include "app/wall_campaign.hpp"

#include <cmath>
#include <cstdio>
#include <regex>

#include "hw/launch_plan.hpp"

namespace collide::app {

namespace {

// The text with the [wall] table's `normal = [...]` replaced.
Result<std::string> withWallNormal(const std::string& text, const Vec3& n) {
  const std::size_t wall = text.find("\n[wall]");
  if (wall == std::string::npos) return fail("the rig profile has no [wall] table to turn");
  static const std::regex normal_re(R"(\nnormal\s*=\s*\[[^\]]*\])");
  std::smatch m;
  const std::string tail = text.substr(wall);
  if (!std::regex_search(tail, m, normal_re))
    return fail("the rig profile's [wall] table has no normal = [x, y, z] line to turn");
  char replacement[160];
  std::snprintf(replacement, sizeof replacement, "\nnormal = [%.9g, %.9g, %.9g]", n.x(), n.y(),
                n.z());
  return text.substr(0, wall + m.position(0)) + replacement +
         tail.substr(m.position(0) + m.length(0));
}

}  // namespace

Result<hw::RigProfile> aimWallForIncidence(const hw::RigProfile& profile, double incidence_deg,
                                           double speed_m_s) {
  if (!profile.wall) return fail("the rig profile has no [wall] table: not a wall rig");
  const double a = incidence_deg * M_PI / 180.0;
  hw::RigProfile trial = profile;
  // Fixed point: the velocity at contact depends (through gravity) on where
  // the plate is met, which depends on the plate's angle; a few rounds settle it.
  for (int round = 0; round < 8; ++round) {
    auto plan = hw::planLaunch(trial, {speed_m_s, speed_m_s});
    if (!plan) return plan.error();
    const Vec3 d = plan->relative_velocity_m_s.normalized();
    // -v turned by a in the image plane, to the side the plate leans now.
    const Vec3 back(-d.x(), -d.y(), 0.0);
    const double side = trial.wall->normal.cross(back).z() >= 0 ? -1.0 : 1.0;
    const double c = std::cos(side * a), s = std::sin(side * a);
    trial.wall->normal = Vec3(c * back.x() - s * back.y(), s * back.x() + c * back.y(), 0.0);
    trial.wall->normal.normalize();
  }
  auto text = withWallNormal(profile.text, trial.wall->normal);
  if (!text) return text.error();
  auto aimed = hw::parseRigProfile(*text, profile.source);
  if (!aimed) return aimed.error();
  if (auto plan = hw::planLaunch(*aimed, {speed_m_s, speed_m_s}); !plan) return plan.error();
  return aimed;
}

}  // namespace collide::app
