#pragma once
// The simulated truth at the contact, shared by the benchmarks that score a
// shot against it (accuracy_bench, plan_bench) and by the tests that do
// (tests/app/lab_lens_sim_test.cpp).
#include <array>

#include "analysis/flight.hpp"
#include "analysis/types.hpp"
#include "hw/shot.hpp"

namespace collide::bench {

// The truth at the collision: free flight (gravity only) is exact, so the
// states of the last frame before and the first frame after the contact,
// carried to the contact instant, are the states just before and after it.
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
  for (int i = 0; i < spheres; ++i) {
    for (const bool pre : {true, false}) {
      const SphereState& st = t.states[pre ? kb : ka][i];
      const double dt = t.t_collision_s - t.t_s[pre ? kb : ka];
      Sphere s;
      s.mass_kg = shot.scene.mass_kg[i];
      s.diameter_m = shot.scene.diameter_m[i];
      s.position_m = st.position_m + st.velocity_m_s * dt + 0.5 * kGravity_m_s2 * dt * dt;
      s.velocity_m_s = st.velocity_m_s + kGravity_m_s2 * dt;
      s.spin_rad_s = st.spin_rad_s;
      (pre ? before : after)[i] = s;
    }
    after[i].position_m = before[i].position_m;
  }
  return true;
}

}  // namespace collide::bench
