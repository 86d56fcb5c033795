#pragma once
// When to open each valve so that the spheres meet in the field of view: from
// the tube geometry, the exit speeds and the exit delay of the profile, the
// valve openings (relative to each other) and the predicted contact instant
// and place. The contact is predicted with analysis::Flight (gravity
// included), the same model the simulator flies.
#include <Eigen/Dense>
#include <array>

#include "analysis/result.hpp"
#include "analysis/types.hpp"
#include "hw/rig_profile.hpp"

namespace collide::hw {

struct LaunchPlan {
  std::array<double, 2> exit_speed_m_s{0.0, 0.0};
  /// Each launcher's valve opening, seconds after the earlier of the two (one is 0).
  std::array<double, 2> valve_open_s{0.0, 0.0};
  /// Predicted first contact, seconds after the earlier valve opening.
  double contact_s = 0.0;
  Vec3 contact_point_m = Vec3::Zero();   ///< midway between the centres at contact
  Eigen::Vector2d contact_px{0.0, 0.0};  ///< where that is in the image (u, v)
  /// Unit line of centres at contact, n = (r1 - r2)/|r1 - r2| (docs/SPEC.md).
  Vec3 contact_normal = Vec3::UnitX();
  /// v1 - v2 just before contact, m/s (spins aside, the approach velocity).
  Vec3 relative_velocity_m_s = Vec3::Zero();
  /// Both spheres just before contact (positions, velocities; no spin): what
  /// Walton's model is given to predict the shot.
  std::array<Sphere, 2> before_contact{};
};

/// The world point the spheres are aimed to meet at: geometry.meet_point_m, or
/// the centre of the configured image.
Vec3 meetPoint(const RigProfile& profile);

/// World point -> image pixel (u right, v down) through the profile's geometry.
Eigen::Vector2d worldToPixel(const RigProfile& profile, const Vec3& world_m);

/// Plans a shot at these exit speeds (m/s, > 0). Errors: a meet point behind
/// a muzzle, spheres that would miss each other, a contact outside the image
/// (each message names the geometry or speeds to change).
Result<LaunchPlan> planLaunch(const RigProfile& profile,
                              const std::array<double, 2>& exit_speed_m_s);

}  // namespace collide::hw
