#include "app/predict.hpp"

#include <cmath>
#include <initializer_list>
#include <numbers>
#include <string>

#include "analysis/walton.hpp"

namespace collide::app {
namespace {

using nlohmann::json;

std::string join(const std::string& path, std::string_view key) {
  return path.empty() ? std::string(key) : path + "." + std::string(key);
}

// Every object must hold exactly the documented keys: a misspelt optional
// key would otherwise be ignored silently.
Status checkObject(const json& j, const std::string& path,
                   std::initializer_list<std::string_view> keys) {
  if (!j.is_object()) return fail((path.empty() ? "input" : path) + ": must be a JSON object");
  for (const auto& [key, value] : j.items()) {
    bool known = false;
    for (auto k : keys) known = known || key == k;
    if (!known) {
      std::string expected;
      for (auto k : keys) expected += (expected.empty() ? "" : ", ") + std::string(k);
      return fail(join(path, key) + ": unknown field (expected " + expected + ")");
    }
  }
  for (auto k : keys)
    if (!j.contains(k)) return fail(join(path, k) + ": missing");
  return Ok{};
}

Result<double> number(const json& j, const std::string& path, std::string_view key) {
  const json& v = j.at(std::string(key));
  if (!v.is_number()) return fail(join(path, key) + ": must be a number");
  const double x = v.get<double>();
  if (!std::isfinite(x)) return fail(join(path, key) + ": must be finite");
  return x;
}

Result<Vec3> vec3(const json& j, const std::string& path, std::string_view key) {
  const json& v = j.at(std::string(key));
  const auto bad = [&] { return fail(join(path, key) + ": must be an array of 3 finite numbers"); };
  if (!v.is_array() || v.size() != 3) return bad();
  Vec3 out;
  for (int i = 0; i < 3; ++i) {
    if (!v[i].is_number()) return bad();
    out[i] = v[i].get<double>();
  }
  if (!out.allFinite()) return bad();
  return out;
}

json toJson(const Vec3& v) {
  return json::array({v.x(), v.y(), v.z()});
}

Result<Material> readMaterial(const json& in) {
  const std::string path = "material";
  if (auto st = checkObject(in.at(path), path, {"e", "mu", "beta0"}); !st) return st.error();
  Material m;
  for (auto [field, key] : {std::pair{&m.e, "e"}, {&m.mu, "mu"}, {&m.beta0, "beta0"}}) {
    auto x = number(in.at(path), path, key);
    if (!x) return x.error();
    *field = *x;
  }
  return m;
}

Result<Sphere> readSphere(const json& j, const std::string& path) {
  if (auto st = checkObject(j, path,
                            {"diameter_m", "mass_kg", "position_m", "velocity_m_s", "spin_rad_s"});
      !st)
    return st.error();
  Sphere s;
  for (auto [field, key] : {std::pair{&s.diameter_m, "diameter_m"}, {&s.mass_kg, "mass_kg"}}) {
    auto x = number(j, path, key);
    if (!x) return x.error();
    *field = *x;
  }
  for (auto [field, key] : {std::pair{&s.position_m, "position_m"},
                            {&s.velocity_m_s, "velocity_m_s"},
                            {&s.spin_rad_s, "spin_rad_s"}}) {
    auto v = vec3(j, path, key);
    if (!v) return v.error();
    *field = *v;
  }
  return s;
}

Result<Wall> readWall(const json& j, const std::string& path) {
  if (auto st = checkObject(j, path, {"point_m", "normal"}); !st) return st.error();
  auto point = vec3(j, path, "point_m");
  if (!point) return point.error();
  auto normal = vec3(j, path, "normal");
  if (!normal) return normal.error();
  return Wall{*point, *normal};
}

json outcomeJson(const ContactOutcome& c) {
  return {{"regime", c.regime == Regime::Sliding ? "sliding" : "rolling"},
          {"e", c.e},
          {"beta", c.beta},
          {"f", c.f},
          {"gamma_deg", c.before.gamma_rad * 180.0 / std::numbers::pi},
          {"vn_m_s", c.before.v_n_m_s},
          {"vs_m_s", c.before.v_s_m_s},
          {"normal", toJson(c.before.normal)},
          {"impulse_N_s", toJson(c.impulse_N_s)}};
}

json motionJson(const Sphere& s) {
  return {{"velocity_m_s", toJson(s.velocity_m_s)}, {"spin_rad_s", toJson(s.spin_rad_s)}};
}

}  // namespace

Result<nlohmann::json> predict(const nlohmann::json& in) {
  if (auto st = checkObject(in, "", {"material", "spheres"}); !st) return st.error();
  auto material = readMaterial(in);
  if (!material) return material.error();
  const json& spheres = in.at("spheres");
  if (!spheres.is_array() || spheres.size() != 2)
    return fail(
        R"(spheres: must be an array of two entries: two spheres, or a sphere and {"wall": {...}})");
  auto s1 = readSphere(spheres[0], "spheres[0]");
  if (!s1) return s1.error();
  if (spheres[1].is_object() && spheres[1].contains("wall")) {
    if (auto st = checkObject(spheres[1], "spheres[1]", {"wall"}); !st) return st.error();
    auto wall = readWall(spheres[1].at("wall"), "spheres[1].wall");
    if (!wall) return wall.error();
    auto hit = collideWithWall(*s1, *wall, *material);
    if (!hit) {
      // analysis names the wall "wall"; here it sits in spheres[1].
      const std::string& msg = hit.error().message;
      return fail(msg.rfind("wall.", 0) == 0 ? "spheres[1]." + msg : msg);
    }
    json out = outcomeJson(hit->contact);
    out["spheres"] = json::array({motionJson(hit->after)});
    return out;
  }
  auto s2 = readSphere(spheres[1], "spheres[1]");
  if (!s2) return s2.error();
  auto hit = collideSpheres(*s1, *s2, *material);
  if (!hit) return hit.error();
  json out = outcomeJson(hit->contact);
  out["spheres"] = json::array({motionJson(hit->after[0]), motionJson(hit->after[1])});
  return out;
}

Result<nlohmann::json> parseJson(std::string_view text, std::string_view source) {
  try {
    return json::parse(text);
  } catch (const json::exception& e) {
    // Drop the library's "[json.exception.parse_error.101] " tag: the rest
    // says where and why.
    std::string what = e.what();
    if (auto end = what.find("] ");
        what.rfind("[json.exception", 0) == 0 && end != std::string::npos)
      what.erase(0, end + 2);
    return fail(std::string(source) + ": invalid JSON: " + what);
  }
}

}  // namespace collide::app
