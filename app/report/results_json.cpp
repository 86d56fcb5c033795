#include "app/report/results_json.hpp"

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

namespace collide::app {
namespace {

using nlohmann::json;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// NaN and infinities are written as null (JSON has no such numbers).
json number(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}
json vec(const Vec3& v) {
  return json::array({number(v.x()), number(v.y()), number(v.z())});
}

const char* const kCollisionKeys[] = {"e",
                                      "beta",
                                      "beta_from_spins",
                                      "beta_from_impulse",
                                      "f",
                                      "gamma_deg",
                                      "vn_m_s",
                                      "vs_m_s",
                                      "vs_after_m_s",
                                      "t_collision_s",
                                      "kinetic_energy_change_J",
                                      "line_of_centres_z"};

// Pointers to the Measured fields in the order of kCollisionKeys (one list
// for writing and reading).
template <class C>
auto measuredFields(C& c) {
  return std::array{&c.e,
                    &c.beta,
                    &c.beta_from_spins,
                    &c.beta_from_impulse,
                    &c.f,
                    &c.gamma_deg,
                    &c.vn_m_s,
                    &c.vs_m_s,
                    &c.vs_after_m_s,
                    &c.t_collision_s,
                    &c.kinetic_energy_change_J,
                    &c.line_of_centres_z};
}

const char* const kVectorKeys[] = {"velocity_before_m_s", "velocity_after_m_s", "spin_before_rad_s",
                                   "spin_after_rad_s"};
std::array<const Estimate3*, 4> vectorFields(const vision::SphereKinematics& s) {
  return {&s.velocity_before_m_s, &s.velocity_after_m_s, &s.spin_before_rad_s, &s.spin_after_rad_s};
}
std::array<Estimate3*, 4> vectorFields(vision::SphereKinematics& s) {
  return {&s.velocity_before_m_s, &s.velocity_after_m_s, &s.spin_before_rad_s, &s.spin_after_rad_s};
}

// Reading: a number, or null for "unknown"; anything else is an error naming the key.
Result<double> readNumber(const json& obj, const std::string& key, const std::string& where) {
  auto it = obj.find(key);
  if (it == obj.end() || it->is_null()) return kNaN;
  if (!it->is_number()) return fail("results JSON: " + where + key + " is not a number");
  return it->get<double>();
}
// An array of strings (none when absent); anything else is an error naming the key.
Result<std::vector<std::string>> readStrings(const json& obj, const std::string& key) {
  std::vector<std::string> out;
  auto it = obj.find(key);
  if (it == obj.end()) return out;
  const std::string bad = "results JSON: " + key + " is not an array of strings";
  if (!it->is_array()) return fail(bad);
  for (const auto& s : *it) {
    if (!s.is_string()) return fail(bad);
    out.push_back(s.get<std::string>());
  }
  return out;
}
Result<Vec3> readVec(const json& obj, const std::string& key, const std::string& where) {
  auto it = obj.find(key);
  if (it == obj.end() || it->is_null()) return Vec3(Vec3::Constant(kNaN));
  if (!it->is_array() || it->size() != 3)
    return fail("results JSON: " + where + key + " is not an array of 3 numbers");
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    const json& x = (*it)[i];
    if (x.is_null()) {
      v[i] = kNaN;
    } else if (x.is_number()) {
      v[i] = x.get<double>();
    } else {
      return fail("results JSON: " + where + key + " is not an array of 3 numbers");
    }
  }
  return v;
}
const json& member(const json& obj, const char* key) {
  static const json empty = json::object();
  auto it = obj.find(key);
  return it != obj.end() && it->is_object() ? *it : empty;
}

// "error_budget": an array of {"source": name, "e", "beta", "gamma_deg"};
// none when missing.
Result<std::vector<ErrorBudgetLine>> readErrorBudget(const json& j) {
  std::vector<ErrorBudgetLine> out;
  auto it = j.find("error_budget");
  if (it == j.end() || it->is_null()) return out;
  const std::string bad =
      "results JSON: error_budget is not an array of {\"source\", \"e\", "
      "\"beta\", \"gamma_deg\"} objects";
  if (!it->is_array()) return fail(bad);
  for (const json& row : *it) {
    if (!row.is_object()) return fail(bad);
    auto source = row.find("source");
    if (source == row.end() || !source->is_string()) return fail(bad);
    ErrorBudgetLine line{source->get<std::string>()};
    const std::string where = "error_budget[" + line.source + "].";
    for (auto [key, field] : {std::pair{"e", &line.e}, std::pair{"beta", &line.beta},
                              std::pair{"gamma_deg", &line.gamma_deg}}) {
      auto v = readNumber(row, key, where);
      if (!v) return v.error();
      *field = *v;
    }
    out.push_back(std::move(line));
  }
  return out;
}

}  // namespace

json errorBudgetJson(const std::vector<ErrorBudgetLine>& rows) {
  json out = json::array();
  for (const ErrorBudgetLine& r : rows)
    out.push_back({{"source", r.source},
                   {"e", number(r.e)},
                   {"beta", number(r.beta)},
                   {"gamma_deg", number(r.gamma_deg)}});
  return out;
}

std::string resultsToJson(const vision::ShotAnalysis& a, int indent) {
  json j;
  j["schema"] = kResultsSchema;
  const auto& c = a.collision;
  j["e"] = number(c.e.value);
  j["beta"] = number(c.beta.value);
  j["f"] = number(c.f.value);
  j["gamma_deg"] = number(c.gamma_deg.value);
  j["vn_m_s"] = number(c.vn_m_s.value);
  j["vs_m_s"] = number(c.vs_m_s.value);
  j["quality_flags"] = a.quality_flags;
  j["pixel_size_m"] = number(a.pixel_size_m);
  j["radius_scatter_px"] = number(a.radius_scatter_px);
  j["radius_systematic_px"] = number(a.radius_systematic_px);
  j["kink_gap"] = {{"gap_s", number(a.kink_gap.gap_s)},
                   {"sigma_s", number(a.kink_gap.sigma_s)},
                   {"var_per_px2_s2", number(a.kink_gap.var_per_px2)}};
  j["notes"] = a.notes;
  json collision, uncertainty;
  const auto fields = measuredFields(c);
  for (std::size_t i = 0; i < fields.size(); ++i) {
    collision[kCollisionKeys[i]] = number(fields[i]->value);
    uncertainty[kCollisionKeys[i]] = number(fields[i]->sigma);
  }
  collision["beta_spin_weight"] = number(c.beta_spin_weight);
  collision["t_collision_before_s"] = number(c.t_collision_before_s);
  collision["t_collision_after_s"] = number(c.t_collision_after_s);
  if (c.line_of_centres_z_from_size) {
    collision["line_of_centres_z_from_size"] = number(c.line_of_centres_z_from_size->value);
    uncertainty["line_of_centres_z_from_size"] = number(c.line_of_centres_z_from_size->sigma);
  }
  for (int s = 0; s < 2; ++s) {
    const std::string name = s == 0 ? "sphere1" : "sphere2";
    json values, sigmas;
    const auto vf = vectorFields(a.sphere[s]);
    for (std::size_t i = 0; i < vf.size(); ++i) {
      values[kVectorKeys[i]] = vec(vf[i]->value);
      sigmas[kVectorKeys[i]] = vec(vf[i]->sigma);
    }
    values["frames_before"] = a.sphere[s].frames_before;
    values["frames_after"] = a.sphere[s].frames_after;
    values["spin_before_prior_directions"] = a.sphere[s].spin_before_prior_directions;
    // Towards the camera, from the apparent size (null when not measured).
    json vz = json::array(), vz_sigma = json::array();
    for (const auto& m : a.sphere[s].vz_from_size_m_s) {
      vz.push_back(m ? number(m->value) : json(nullptr));
      vz_sigma.push_back(m ? number(m->sigma) : json(nullptr));
    }
    values["vz_from_size_m_s"] = vz;
    sigmas["vz_from_size_m_s"] = vz_sigma;
    j[name] = values;
    uncertainty[name] = sigmas;
  }
  j["collision"] = collision;
  j["uncertainty"] = uncertainty;
  if (!a.error_budget.empty()) {
    std::vector<ErrorBudgetLine> rows;
    for (const ErrorBudgetRow& r : a.error_budget)
      rows.push_back({r.name, r.e, r.beta, r.gamma_deg});
    j["error_budget"] = errorBudgetJson(rows);
  }
  return j.dump(indent);
}

std::string failedResultsJson(const std::string& reason) {
  json j;
  j["schema"] = kResultsSchema;
  j["error"] = reason;
  j["quality_flags"] = json::array({"analysis_failed"});
  return j.dump(2);
}

Result<ShotResults> parseResultsJson(const std::string& text) {
  json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return fail("results JSON: not valid JSON");
  if (!j.is_object()) return fail("results JSON: not a JSON object");
  if (auto it = j.find("schema"); it != j.end() && *it != kResultsSchema)
    return fail("results JSON: schema " + it->dump() + " is not " + kResultsSchema +
                " (written by another collide version: re-run `collide analyze`)");
  ShotResults r;
  if (auto it = j.find("error"); it != j.end() && it->is_string()) r.error = it->get<std::string>();
  for (auto [key, field] :
       {std::pair{"quality_flags", &r.quality_flags}, std::pair{"notes", &r.notes}}) {
    auto v = readStrings(j, key);
    if (!v) return v.error();
    *field = std::move(*v);
  }
  for (auto [key, field] : {std::pair{"pixel_size_m", &r.pixel_size_m},
                            std::pair{"radius_scatter_px", &r.radius_scatter_px},
                            std::pair{"radius_systematic_px", &r.radius_systematic_px}}) {
    auto v = readNumber(j, key, "");
    if (!v) return v.error();
    *field = *v;
  }
  const json& kink = member(j, "kink_gap");
  for (auto [key, field] :
       {std::pair{"gap_s", &r.kink_gap.gap_s}, std::pair{"sigma_s", &r.kink_gap.sigma_s},
        std::pair{"var_per_px2_s2", &r.kink_gap.var_per_px2}}) {
    auto v = readNumber(kink, key, "kink_gap.");
    if (!v) return v.error();
    *field = *v;
  }

  const json& collision = member(j, "collision");
  const json& uncertainty = member(j, "uncertainty");
  const auto fields = measuredFields(r.collision);
  for (std::size_t i = 0; i < fields.size(); ++i) {
    auto v = readNumber(collision, kCollisionKeys[i], "collision.");
    if (!v) return v.error();
    auto s = readNumber(uncertainty, kCollisionKeys[i], "uncertainty.");
    if (!s) return s.error();
    *fields[i] = {*v, *s};
  }
  for (auto [key, field] : {std::pair{"t_collision_before_s", &r.collision.t_collision_before_s},
                            std::pair{"t_collision_after_s", &r.collision.t_collision_after_s},
                            std::pair{"beta_spin_weight", &r.collision.beta_spin_weight}}) {
    auto v = readNumber(collision, key, "collision.");
    if (!v) return v.error();
    *field = *v;
  }
  // Results of an earlier collide: beta was the spins' alone.
  if (!std::isfinite(r.collision.beta_spin_weight)) {
    r.collision.beta_spin_weight = 1.0;
    if (!std::isfinite(r.collision.beta_from_spins.value))
      r.collision.beta_from_spins = r.collision.beta;
  }
  for (int s = 0; s < 2; ++s) {
    const std::string name = s == 0 ? "sphere1" : "sphere2";
    const json& values = member(j, name.c_str());
    const json& sigmas = member(uncertainty, name.c_str());
    const auto vf = vectorFields(r.sphere[s]);
    for (std::size_t i = 0; i < vf.size(); ++i) {
      auto v = readVec(values, kVectorKeys[i], name + ".");
      if (!v) return v.error();
      auto sg = readVec(sigmas, kVectorKeys[i], "uncertainty." + name + ".");
      if (!sg) return sg.error();
      *vf[i] = {*v, *sg};
    }
    for (auto [key, field] :
         {std::pair{"frames_before", &r.sphere[s].frames_before},
          std::pair{"frames_after", &r.sphere[s].frames_after},
          std::pair{"spin_before_prior_directions", &r.sphere[s].spin_before_prior_directions}}) {
      auto v = readNumber(values, key, name + ".");
      if (!v) return v.error();
      // A count: converting a number beyond int's range would be undefined.
      if (std::isfinite(*v) && !(*v >= 0 && *v <= 1e9))
        return fail("results JSON: " + name + "." + key + " = " + std::to_string(*v) +
                    " is not a count (0 to 1e9)");
      *field = std::isfinite(*v) ? static_cast<int>(*v) : 0;
    }
  }
  auto budget = readErrorBudget(j);
  if (!budget) return budget.error();
  r.error_budget = std::move(*budget);
  return r;
}

Result<CampaignShot> toCampaignShot(const ShotResults& r) {
  if (r.error) return fail("the analysis failed: " + *r.error);
  const auto& c = r.collision;
  const std::pair<const char*, const vision::Measured*> needed[] = {
      {"collision.vn_m_s", &c.vn_m_s}, {"collision.vs_m_s", &c.vs_m_s}, {"collision.e", &c.e}};
  for (const auto& [name, m] : needed)
    if (!std::isfinite(m->value)) return fail(std::string("no ") + name + " in the results");
  return campaignShotFrom(c);
}

CampaignShot campaignShotFrom(const vision::CollisionProperties& c) {
  CampaignShot s;
  s.v_n_m_s = c.vn_m_s.value;
  s.v_n_sigma_m_s = std::isfinite(c.vn_m_s.sigma) ? c.vn_m_s.sigma : 0.0;
  s.v_s_m_s = c.vs_m_s.value;
  s.v_s_sigma_m_s = std::isfinite(c.vs_m_s.sigma) ? c.vs_m_s.sigma : 0.0;
  s.e = c.e.value;
  s.e_sigma = c.e.sigma;
  s.beta = c.beta.value;
  s.beta_sigma = c.beta.sigma;
  s.f = c.f.value;
  s.f_sigma = std::isfinite(c.f.sigma) ? c.f.sigma : 0.0;
  return s;
}

}  // namespace collide::app
