#pragma once
// Campaigns on a sphere-on-wall rig (a profile with a [wall] table): the
// incidence is swept by turning the plate about wall.point_m in the image
// plane, launcher 1 firing at the planned speed (launcher 2 never fires).
#include "analysis/result.hpp"
#include "hw/rig_profile.hpp"

namespace collide::app {

/// The profile with [wall] normal turned so that, at this exit speed, the
/// sphere meets the plate at `incidence_deg` from its normal (gravity
/// included, spin and scatter aside). The returned profile's text carries the
/// edited `normal = [...]` line, so the shot records the plate it was fired
/// at. Errors: no [wall] table or no `normal` line in it; the contact would
/// fall outside the image (from the launch plan).
Result<hw::RigProfile> aimWallForIncidence(const hw::RigProfile& profile, double incidence_deg,
                                           double speed_m_s);

}  // namespace collide::app
