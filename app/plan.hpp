#pragma once
// `collide plan` (issue 16 §1): from what the physicist wants (an incidence
// angle and a speed at the contact) to how the rig is set: launcher 2's
// vertical slide, each launcher's exit speed and pressure from the launch
// calibration, the valve delay, where and when the spheres meet in the image,
// and what Walton's model predicts for the shot. A wish the rig cannot fire
// is refused with the reason and the nearest shot it can fire. On a
// sphere-on-wall rig (a [wall] table) the plate is turned instead of the
// slide moved, only launcher 1 fires, and the prediction is Walton's
// infinite-mass limit.
#include <array>
#include <optional>
#include <string>

#include "analysis/result.hpp"
#include "analysis/types.hpp"
#include "analysis/walton.hpp"
#include "hw/launch_plan.hpp"
#include "hw/rig_profile.hpp"

namespace collide::app {

struct PlanRequest {
  /// Incidence: the angle between the line of centres and the approach
  /// (relative) velocity of the centres at contact, degrees; 0 head-on. SPEC's
  /// gamma = 180 - this.
  double incidence_deg = 0.0;
  /// Each sphere's speed just before contact, m/s (gravity changes it on the
  /// way from the muzzle; the exit speeds are solved for).
  std::array<double, 2> speed_m_s{0.0, 0.0};
  /// Walton's properties for the prediction; none: the profile's [spheres].
  std::optional<Material> material;
};

struct ShotPlan {
  PlanRequest request;
  hw::RigProfile aimed;         ///< the profile with launcher 2's slide moved (fire this)
  double slide_offset_m = 0.0;  ///< launcher 2's exit moved up by this from the profile, m
  std::array<Vec3, 2> exit_m;   ///< each muzzle's exit point as planned, world m
  std::array<double, 2> exit_speed_m_s{0.0, 0.0};
  std::array<double, 2> pressure_kPa{0.0, 0.0};  ///< from the calibrated cubic
  hw::LaunchPlan launch;                         ///< valve delays, contact time, place, states
  double incidence_deg = 0.0;                    ///< as planned (spins and scatter aside)
  std::array<double, 2> speed_at_contact_m_s{0.0, 0.0};
  Material material;     ///< used for the prediction
  Collision prediction;  ///< Walton's model on launch.before_contact (a wall shot: after[0] only)
  /// A sphere-on-wall shot (the rig has a plate, aimed.wall, turned for it):
  /// launcher 2 is not fired (its exit speed and pressure repeat launcher 1's).
  bool isWall() const { return aimed.wall.has_value(); }
};

/// Why a wish cannot be fired, and the nearest one that can.
struct Infeasible {
  std::string reason;                  ///< names the limit (calibration, image, slide)
  std::optional<PlanRequest> nearest;  ///< none when no shot near it can be fired
};

/// Plans one shot. Errors: bad request values (message names the option),
/// or the wish is infeasible: the message says why and what the nearest
/// feasible shot is; `infeasible` (when given) receives the same, with the
/// nearest request to plan instead.
Result<ShotPlan> planShot(const hw::RigProfile& profile, const PlanRequest& request,
                          Infeasible* infeasible = nullptr);

/// The plan as the lines `collide plan` prints (units in every line).
std::string describePlan(const ShotPlan& plan);

}  // namespace collide::app
