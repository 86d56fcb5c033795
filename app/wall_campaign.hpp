#pragma once
// Campaigns on a sphere-on-wall rig (a profile with a [wall] table): the
// incidence is swept by turning the plate in the image plane about the point
// where the sphere's path meets the profile's plate, launcher 1 firing at the
// planned speed (launcher 2 never fires).
#include "analysis/result.hpp"
#include "hw/rig_profile.hpp"

namespace collide::app {

/// The profile with the [wall] plate turned (normal and point_m) so that, at
/// this exit speed, the sphere meets it at `incidence_deg` from its normal
/// where it met the profile's plate (gravity included, spin and scatter
/// aside). The returned profile's text carries the edited lines, so the shot
/// records the plate it was fired at. Errors: no [wall] table or no `normal`
/// or `point_m` line in it; an angle outside [0, 90); a launch the plan
/// refuses (the contact outside the image, launcher 1 behind the plate).
Result<hw::RigProfile> aimWallForIncidence(const hw::RigProfile& profile, double incidence_deg,
                                           double speed_m_s);

}  // namespace collide::app
