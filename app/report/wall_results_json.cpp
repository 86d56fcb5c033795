#include "app/report/wall_results_json.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

#include "app/report/results_json.hpp"

namespace collide::app {

namespace {

using nlohmann::json;

json number(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}
json vec(const Vec3& v) {
  return json::array({number(v.x()), number(v.y()), number(v.z())});
}

}  // namespace

std::string wallResultsToJson(const vision::WallShotAnalysis& a, int indent) {
  const WaltonMeasurement& m = a.measured;
  constexpr double kDeg = 180.0 / M_PI;
  json j;
  j["schema"] = kResultsSchema;
  j["target"] = "wall";
  const double vs_after = -a.beta_from_spins * m.before.v_s_m_s;  // v_s' . t, from the spins
  j["e"] = number(m.e);
  j["beta"] = number(m.beta);
  j["f"] = number(m.f);
  j["gamma_deg"] = number(m.before.gamma_rad * kDeg);
  j["vn_m_s"] = number(m.before.v_n_m_s);
  j["vs_m_s"] = number(m.before.v_s_m_s);
  j["quality_flags"] = a.quality_flags;
  j["notes"] = a.notes;
  j["pixel_size_m"] = number(a.pixel_size_m);
  json c, u;
  c["e"] = number(m.e);
  u["e"] = number(a.e_sigma);
  c["beta"] = number(m.beta);
  u["beta"] = number(a.beta_sigma);
  c["beta_from_spins"] = number(a.beta_from_spins);
  u["beta_from_spins"] = number(a.beta_from_spins_sigma);
  c["beta_spin_weight"] = number(a.beta_spin_weight);
  c["beta_from_impulse"] = number(m.beta_from_impulse);
  u["beta_from_impulse"] = number(a.beta_from_impulse_sigma);
  c["f"] = number(m.f);
  u["f"] = number(a.f_sigma);
  c["gamma_deg"] = number(m.before.gamma_rad * kDeg);
  u["gamma_deg"] = number(a.gamma_sigma_rad * kDeg);
  c["vn_m_s"] = number(m.before.v_n_m_s);
  u["vn_m_s"] = number(a.vn_sigma_m_s);
  c["vs_m_s"] = number(m.before.v_s_m_s);
  u["vs_m_s"] = number(a.vs_sigma_m_s);
  c["vs_after_m_s"] = number(vs_after);
  u["vs_after_m_s"] = nullptr;
  c["t_collision_s"] = number(a.t_contact_s);
  u["t_collision_s"] = nullptr;
  c["t_collision_before_s"] = number(a.t_contact_s);
  c["t_collision_after_s"] = number(a.t_separation_s);
  json s1, s1u;
  // The analysis' velocities: the fits' in the image plane, and along z the
  // prior's before the impact and, after it, what the spin change gave
  // (appendix B), not the orthographic fit's zero.
  s1["velocity_before_m_s"] = vec(a.sphere_before.velocity_m_s);
  s1u["velocity_before_m_s"] = vec(a.velocity_sigma_before);
  s1["velocity_after_m_s"] = vec(a.sphere_after.velocity_m_s);
  s1u["velocity_after_m_s"] = vec(a.velocity_sigma_after);
  const double nan = std::nan("");
  s1["spin_before_rad_s"] =
      vec(a.spin_before_known ? a.sphere_before.spin_rad_s : Vec3::Constant(nan));
  s1u["spin_before_rad_s"] = vec(a.spin_sigma_before);
  s1["spin_after_rad_s"] =
      vec(a.spin_after_known ? a.sphere_after.spin_rad_s : Vec3::Constant(nan));
  s1u["spin_after_rad_s"] = vec(a.spin_sigma_after);
  s1["frames_before"] = a.frames_used_before;
  s1["frames_after"] = a.frames_used_after;
  s1["spin_before_prior_directions"] = a.spin_before_prior_directions;
  j["sphere1"] = s1;
  u["sphere1"] = s1u;
  j["collision"] = c;
  j["uncertainty"] = u;
  j["wall"] = {{"point_m", vec(a.wall.point_m)},
               {"normal", vec(a.wall.normal)},
               {"t_separation_s", number(a.t_separation_s)},
               {"line_point_px",
                json::array({number(a.wall_line.point_px.x()), number(a.wall_line.point_px.y())})},
               {"line_normal",
                json::array({number(a.wall_line.normal.x()), number(a.wall_line.normal.y())})},
               {"found_in_image", a.wall_found_in_image},
               {"angle_sigma_deg", number(a.wall_angle_sigma_rad * kDeg)},
               {"offset_sigma_px", number(a.wall_offset_sigma_px)}};
  return j.dump(indent);
}

}  // namespace collide::app
