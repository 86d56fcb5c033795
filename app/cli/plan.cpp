// `collide plan`: the rig settings for a wanted incidence and speed (issue 16).
#include "app/plan.hpp"

#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/cli/command.hpp"

namespace {

struct PlanArgs {
  std::string rig;
  double incidence_deg = NAN, speed_m_s = NAN, speed2_m_s = NAN;
  double e = NAN, mu = NAN, beta0 = NAN;
  bool json = false;
};

nlohmann::json vec(const collide::Vec3& v) {
  return {v.x(), v.y(), v.z()};
}

nlohmann::json toJson(const collide::app::ShotPlan& p) {
  using nlohmann::json;
  json launchers = json::array();
  for (int i = 0; i < 2; ++i) {
    const bool fired = !p.isWall() || i == 0;  // a wall rig fires launcher 1 only
    launchers.push_back({{"name", p.aimed.launchers[i].name},
                         {"fired", fired},
                         {"exit_m", vec(p.exit_m[i])},
                         {"exit_speed_m_s", fired ? json(p.exit_speed_m_s[i]) : json(nullptr)},
                         {"pressure_kpa", fired ? json(p.pressure_kPa[i]) : json(nullptr)},
                         {"valve_open_s", p.launch.valve_open_s[i]}});
  }
  const auto& c = p.prediction.contact;
  json after = json::array();
  for (int i = 0; i < (p.isWall() ? 1 : 2); ++i)
    after.push_back({{"velocity_m_s", vec(p.prediction.after[i].velocity_m_s)},
                     {"spin_rad_s", vec(p.prediction.after[i].spin_rad_s)}});
  json out = {
      {"target", p.isWall() ? "wall" : "sphere"},
      {"incidence_deg", p.incidence_deg},
      {"speed_at_contact_m_s", p.speed_at_contact_m_s},
      {"slide_offset_m", p.slide_offset_m},
      {"launchers", launchers},
      {"contact",
       {{"time_s", p.launch.contact_s},
        {"point_m", vec(p.launch.contact_point_m)},
        {"pixel", {p.launch.contact_px.x(), p.launch.contact_px.y()}}}},
      {"prediction",
       {{"material", {{"e", p.material.e}, {"mu", p.material.mu}, {"beta0", p.material.beta0}}},
        {"regime", c.regime == collide::Regime::Sliding ? "sliding" : "rolling"},
        {"beta", c.beta},
        {"gamma_deg", c.before.gamma_rad * 180 / 3.14159265358979323846},
        {"vn_m_s", c.before.v_n_m_s},
        {"vs_m_s", c.before.v_s_m_s},
        {"spheres", after}}}};
  if (p.isWall())
    out["wall"] = {{"point_m", vec(p.aimed.wall->point_m)},
                   {"normal", vec(p.aimed.wall->normal.normalized())}};
  return out;
}

void setupPlan(CLI::App& sub, std::function<int()>& run) {
  auto a = std::make_shared<PlanArgs>();
  sub.add_option("--rig", a->rig, "Rig profile (TOML), e.g. config/sim.toml")->required();
  sub.add_option("--incidence-deg", a->incidence_deg,
                 "Wanted incidence at contact, degrees (0 head-on, below 90)")
      ->required();
  sub.add_option("--speed-m-s", a->speed_m_s, "Wanted speed of each sphere at contact, m/s")
      ->required();
  sub.add_option("--speed2-m-s", a->speed2_m_s, "Sphere 2's speed at contact if it differs, m/s");
  sub.add_option("--e", a->e, "Normal restitution for the prediction (default: the profile's)");
  sub.add_option("--mu", a->mu, "Friction coefficient for the prediction");
  sub.add_option("--beta0", a->beta0, "Tangential restitution limit for the prediction");
  sub.add_flag("--json", a->json, "Print the plan as JSON");
  sub.footer(
      "Prints launcher 2's slide position, each launcher's exit speed and pressure (from the\n"
      "launch calibration), the valve delays, where and when the spheres meet in the image and\n"
      "what Walton's model predicts. A wish the rig cannot fire (speeds outside the calibration,\n"
      "contact outside the image, a slide out of travel) is refused with the reason and the\n"
      "nearest shot it can fire.\n"
      "Exit status: 0 planned; 1 infeasible (the message names the nearest feasible shot);\n"
      "2 bad input.");
  run = [a] {
    using namespace collide;
    auto profile = hw::loadRigProfile(a->rig);
    if (!profile) {
      std::cerr << "collide plan: " << profile.error().message << "\n";
      return cli::kExitBadInput;
    }
    app::PlanRequest req;
    req.incidence_deg = a->incidence_deg;
    req.speed_m_s = {a->speed_m_s, std::isnan(a->speed2_m_s) ? a->speed_m_s : a->speed2_m_s};
    const bool any = !std::isnan(a->e) || !std::isnan(a->mu) || !std::isnan(a->beta0);
    if (any) {
      Material m = profile->spheres.material;
      if (!std::isnan(a->e)) m.e = a->e;
      if (!std::isnan(a->mu)) m.mu = a->mu;
      if (!std::isnan(a->beta0)) m.beta0 = a->beta0;
      req.material = m;
    }
    app::Infeasible why;
    auto plan = app::planShot(*profile, req, &why);
    if (!plan) {
      std::cerr << "collide plan: " << plan.error().message << "\n";
      return why.reason.empty() ? cli::kExitBadInput : cli::kExitFailure;
    }
    if (a->json)
      std::cout << toJson(*plan).dump(2) << "\n";
    else
      std::cout << app::describePlan(*plan);
    return cli::kExitOk;
  };
}

}  // namespace

COLLIDE_COMMAND(plan, "The rig settings for a wanted incidence angle and speed", setupPlan);
