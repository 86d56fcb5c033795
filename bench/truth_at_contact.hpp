#pragma once
// The simulated truth at the contact, shared by the benchmarks that score a
// shot against it (accuracy_bench, plan_bench) and by the tests that do
// (tests/app/lab_lens_sim_test.cpp).
#include <array>

#include "analysis/flight.hpp"
#include "analysis/types.hpp"
#include "hw/rig_profile.hpp"
#include "hw/shot.hpp"

namespace collide::bench {

// The truth at the collision: the states of the last frame before and the
// first frame after the contact, flown on to the contact instant as the
// simulated rig flew them (gravity and, through its air, the drag:
// analysis/flight.hpp), are the states just before and after it.
// `spheres`: 2, or 1 for a sphere-on-wall shot (sphere 1 only).
inline bool truthAtContact(const hw::Shot& shot, std::array<Sphere, 2>& before,
                           std::array<Sphere, 2>& after, int spheres = 2) {
  const hw::TruthRecord& t = *shot.truth;
  int kb = -1, ka = -1;
  for (std::size_t k = 0; k < t.t_s.size(); ++k) {
    if (t.t_s[k] < t.t_collision_s) kb = static_cast<int>(k);
    if (t.t_s[k] > t.t_collision_s && ka < 0) ka = static_cast<int>(k);
  }
  if (kb < 0 || ka < 0) return false;
  const auto profile = hw::parseRigProfile(shot.rig_profile_toml, shot.id);
  const double air_kg_m3 = profile ? profile->simulation.air_density_kg_m3 : 0.0;
  for (int i = 0; i < spheres; ++i) {
    const AirDrag air{shot.scene.diameter_m[i], shot.scene.mass_kg[i], air_kg_m3};
    for (const bool pre : {true, false}) {
      const int k = pre ? kb : ka;
      const SphereState st =
          freeFlight(t.states[k][i], t.t_collision_s - t.t_s[k], kGravity_m_s2, air);
      Sphere s;
      s.mass_kg = shot.scene.mass_kg[i];
      s.diameter_m = shot.scene.diameter_m[i];
      s.position_m = st.position_m;
      s.velocity_m_s = st.velocity_m_s;
      s.spin_rad_s = st.spin_rad_s;
      (pre ? before : after)[i] = s;
    }
    after[i].position_m = before[i].position_m;
  }
  return true;
}

}  // namespace collide::bench
