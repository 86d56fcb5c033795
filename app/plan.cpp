#include "app/plan.hpp"

#include <cmath>
#include <cstdio>

#include "app/campaign.hpp"
#include "app/wall_campaign.hpp"

namespace collide::app {
namespace {

constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;

std::string num(const char* spec, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, spec, v);
  return buf;
}

// The rig aimed at `incidence_deg` with exit speeds that give the wanted
// speeds at contact: the exit speeds are rescaled until gravity's change on
// the way is accounted for (a few rounds; the change is a few per cent).
struct Aim {
  hw::RigProfile profile;
  double slide_offset_m = 0.0;
  std::array<double, 2> exit_speed_m_s{0.0, 0.0};
  hw::LaunchPlan launch;
};

// A wall rig fires launcher 1 only: its plate is turned instead of launcher
// 2's slide moved, and both exit speeds carry launcher 1's.
Result<Aim> aimAt(const hw::RigProfile& p, double incidence_deg,
                  const std::array<double, 2>& want_m_s) {
  const int fired = p.wall ? 1 : 2;
  std::array<double, 2> exit = want_m_s;
  for (int round = 0; round < 8; ++round) {
    if (p.wall) exit[1] = exit[0];
    Aim a;
    auto aimed = p.wall ? aimWallForIncidence(p, incidence_deg, exit[0])
                        : aimForIncidence(p, incidence_deg, exit, &a.slide_offset_m);
    if (!aimed) return aimed.error();
    auto launch = hw::planLaunch(*aimed, exit);
    if (!launch) return launch.error();
    a.profile = std::move(*aimed);
    a.launch = *launch;
    a.exit_speed_m_s = exit;
    bool settled = true;
    for (int i = 0; i < fired; ++i) {
      const double ratio = want_m_s[i] / a.launch.before_contact[i].velocity_m_s.norm();
      settled = settled && std::abs(ratio - 1) < 1e-5;
      exit[i] *= ratio;
    }
    if (settled || round == 7) return a;
  }
  return fail("unreachable");
}

// The largest angle in [0, wanted] (one decimal, on the feasible side) for
// which `feasible` holds, by bisection (the feasible angles run from head-on
// up to a limit); none when head-on is not feasible either.
template <class Feasible>
std::optional<double> largestAngle(double wanted_deg, const Feasible& feasible) {
  if (!feasible(0.0)) return std::nullopt;
  double lo = 0.0, hi = wanted_deg;
  for (int i = 0; i < 30 && hi - lo > 0.01; ++i) {
    const double mid = 0.5 * (lo + hi);
    (feasible(mid) ? lo : hi) = mid;
  }
  return std::floor(lo * 10) / 10;
}

// The largest incidence in [0, wanted] that can be aimed at these speeds.
std::optional<double> largestAimable(const hw::RigProfile& p, double wanted_deg,
                                     const std::array<double, 2>& speed) {
  return largestAngle(wanted_deg, [&](double g) { return static_cast<bool>(aimAt(p, g, speed)); });
}

// The smallest common scale (>= 1, at most `max_scale`) of both speeds at
// which `incidence_deg` can be aimed (slow spheres fall out of the image).
std::optional<std::array<double, 2>> fasterAimable(const hw::RigProfile& p, double incidence_deg,
                                                   const std::array<double, 2>& speed,
                                                   double max_scale) {
  const auto scaled = [&](double k) { return std::array<double, 2>{k * speed[0], k * speed[1]}; };
  if (!(max_scale > 1) || !aimAt(p, incidence_deg, scaled(max_scale))) return std::nullopt;
  double lo = 1.0, hi = max_scale;
  for (int i = 0; i < 30 && hi - lo > 1e-3; ++i) {
    const double mid = 0.5 * (lo + hi);
    (aimAt(p, incidence_deg, scaled(mid)) ? hi : lo) = mid;
  }
  std::array<double, 2> out = scaled(hi);
  for (double& v : out) v = std::ceil(v * 100) / 100;  // two decimals, on the feasible side
  return out;
}

// Speeds at contact scaled so that the exit speeds stay inside [lo, hi] m/s.
std::array<double, 2> speedsInside(const Aim& a, const std::array<double, 2>& want, double lo,
                                   double hi) {
  std::array<double, 2> out = want;
  for (int i = 0; i < 2; ++i) {
    const double exit = a.exit_speed_m_s[i];
    const double clamped = std::clamp(exit, lo * 1.001, hi * 0.999);
    out[i] = want[i] * clamped / exit;
  }
  return out;
}

std::string describeRequest(const PlanRequest& r) {
  std::string s = num("%.1f deg at ", r.incidence_deg) + num("%.2f", r.speed_m_s[0]);
  if (std::abs(r.speed_m_s[1] - r.speed_m_s[0]) > 1e-9) s += num(" and %.2f", r.speed_m_s[1]);
  return s + " m/s";
}

std::string refusal(const Infeasible& why) {
  return why.reason + (why.nearest ? "; the nearest shot the rig can fire: " +
                                         describeRequest(*why.nearest) + " (plan that instead)"
                                   : "; no nearby shot can be fired: check the launchers' "
                                     "geometry in the profile");
}

Result<ShotPlan> refuse(Infeasible* out, const std::string& reason,
                        std::optional<PlanRequest> nearest) {
  *out = {reason, nearest};
  return fail(refusal(*out));
}

Status checkRequest(const PlanRequest& r) {
  if (!(r.incidence_deg >= 0 && r.incidence_deg < 90))
    return fail("--incidence-deg must be at least 0 and below 90 degrees (got " +
                num("%g", r.incidence_deg) + "; 0 is head-on)");
  for (int i = 0; i < 2; ++i)
    if (!(r.speed_m_s[i] > 0 && std::isfinite(r.speed_m_s[i])))
      return fail(std::string(i == 0 ? "--speed-m-s" : "--speed2-m-s") +
                  " must be a speed > 0 in m/s (got " + num("%g", r.speed_m_s[i]) + ")");
  if (r.material)
    if (auto ok = validateMaterial(*r.material); !ok) return ok.error();
  return Ok{};
}

// The highest pressure both the calibration and the regulator's limit allow, kPa.
double maxPressure(const hw::RigProfile& profile, const LaunchCalibration& curve) {
  return std::min(curve.maxPressure_kPa(), profile.regulator_config.max_kPa);
}

// The fastest exit the calibration and the regulator's limit give, m/s.
double maxExitSpeed(const hw::RigProfile& profile, const LaunchCalibration& curve) {
  return std::min(curve.maxSpeed_m_s(), curve.speed_m_s(maxPressure(profile, curve)));
}

// The exit speed's pressure from the calibration, or why not, naming the
// launcher and the range.
Result<double> pressureFor(const hw::RigProfile& profile, const LaunchCalibration& curve, int i,
                           double exit_m_s) {
  const double p_max = maxPressure(profile, curve);
  auto p = curve.pressure_kPa(exit_m_s);
  if (p && *p <= p_max) return *p;
  return fail(
      "launcher " + profile.launchers[i].name + " would need an exit speed of " +
      num("%.2f", exit_m_s) + " m/s, outside what the launch calibration and the regulator give (" +
      num("%.2f", curve.minSpeed_m_s()) + " to " + num("%.2f", maxExitSpeed(profile, curve)) +
      " m/s, " + num("%.0f", curve.minPressure_kPa()) + " to " + num("%.0f", p_max) + " kPa)");
}

// A sphere-on-wall rig: launcher 1 at the plate, turned for the incidence.
Result<ShotPlan> planWallOnce(const hw::RigProfile& profile, const PlanRequest& request,
                              Infeasible* infeasible) {
  auto curve = profile.calibration.curve();
  if (!curve) return curve.error();
  const double want = request.speed_m_s[0];
  auto aim = aimAt(profile, request.incidence_deg, {want, want});
  if (!aim) {
    std::optional<PlanRequest> nearest;
    if (const auto angle = largestAimable(profile, request.incidence_deg, {want, want})) {
      nearest = request;
      nearest->incidence_deg = *angle;
    }
    return refuse(
        infeasible,
        "a wall shot of " + describeRequest(request) + " cannot be fired: " + aim.error().message,
        nearest);
  }
  auto pressure = pressureFor(profile, *curve, 0, aim->exit_speed_m_s[0]);
  if (!pressure) {
    const double v_lo = curve->minSpeed_m_s(), v_max = maxExitSpeed(profile, *curve);
    PlanRequest nearest = request;
    const double exit = aim->exit_speed_m_s[0];
    nearest.speed_m_s[0] = nearest.speed_m_s[1] =
        want * std::clamp(exit, v_lo * 1.001, v_max * 0.999) / exit;
    return refuse(infeasible, pressure.error().message, nearest);
  }
  ShotPlan plan;
  plan.request = request;
  plan.exit_speed_m_s = aim->exit_speed_m_s;
  plan.pressure_kPa = {*pressure, *pressure};
  plan.launch = aim->launch;
  plan.aimed = std::move(aim->profile);
  for (int i = 0; i < 2; ++i) plan.exit_m[i] = plan.aimed.launchers[i].exit_m;
  const double v = plan.launch.before_contact[0].velocity_m_s.norm();
  plan.speed_at_contact_m_s = {v, v};
  plan.material = request.material.value_or(profile.spheres.material);
  auto hit = collideWithWall(plan.launch.before_contact[0], *plan.aimed.wall, plan.material);
  if (!hit) return fail("Walton's model on the planned contact: " + hit.error().message);
  plan.prediction.after[0] = hit->after;
  plan.prediction.contact = hit->contact;
  // gamma = 180 deg - incidence.
  plan.incidence_deg = 180.0 - hit->contact.before.gamma_rad * kDegPerRad;
  return plan;
}

// One attempt: the plan, or why not with a nearest wish that clears the limit
// named (another limit may still stand in its way).
Result<ShotPlan> planOnce(const hw::RigProfile& profile, const PlanRequest& request,
                          Infeasible* infeasible) {
  if (auto ok = checkRequest(request); !ok) return ok.error();
  if (profile.wall) return planWallOnce(profile, request, infeasible);
  auto curve = profile.calibration.curve();
  if (!curve) return curve.error();
  const double v_lo = curve->minSpeed_m_s(), v_hi = curve->maxSpeed_m_s();

  // Aimed without the slide's travel, which is checked below with its own message.
  hw::RigProfile free = profile;
  free.launchers[1].slide_travel_m.reset();
  auto aim = aimAt(free, request.incidence_deg, request.speed_m_s);
  if (!aim) {
    const auto largest = largestAimable(free, request.incidence_deg, request.speed_m_s);
    const double max_scale = v_hi / std::max(request.speed_m_s[0], request.speed_m_s[1]);
    std::optional<PlanRequest> nearest;
    if (largest) {
      nearest = request;
      nearest->incidence_deg = *largest;
    } else if (const auto faster_head_on = fasterAimable(free, 0.0, request.speed_m_s, max_scale);
               faster_head_on &&
               !fasterAimable(free, request.incidence_deg, request.speed_m_s, max_scale)) {
      // Too slow for any angle and too grazing at any speed: faster, then
      // as near the angle as that speed allows.
      const auto angle = largestAimable(free, request.incidence_deg, *faster_head_on);
      if (angle) {
        nearest = request;
        nearest->speed_m_s = *faster_head_on;
        nearest->incidence_deg = *angle;
      }
    } else if (const auto faster =
                   fasterAimable(free, request.incidence_deg, request.speed_m_s, max_scale)) {
      nearest = request;
      nearest->speed_m_s = *faster;
    }
    return refuse(
        infeasible,
        "an incidence of " + describeRequest(request) + " cannot be fired: " + aim.error().message,
        nearest);
  }
  // The slide's travel.
  if (const auto& travel = profile.launchers[1].slide_travel_m;
      travel && (aim->slide_offset_m < (*travel)[0] || aim->slide_offset_m > (*travel)[1])) {
    // The slide's offset grows with the angle: bisect for the largest angle
    // whose slide stays inside the travel.
    const auto inside = [&](double g) {
      auto a = aimAt(free, g, request.speed_m_s);
      return a && a->slide_offset_m >= (*travel)[0] && a->slide_offset_m <= (*travel)[1];
    };
    std::optional<PlanRequest> nearest;
    if (const auto angle = largestAngle(request.incidence_deg, inside)) {
      nearest = request;
      nearest->incidence_deg = *angle;
    }
    return refuse(infeasible,
                  describeRequest(request) + " needs launcher " + profile.launchers[1].name +
                      "'s slide " + num("%+.1f", aim->slide_offset_m * 1e3) +
                      " mm from exit_m, outside its travel (" + num("%+.1f", (*travel)[0] * 1e3) +
                      " to " + num("%+.1f", (*travel)[1] * 1e3) + " mm, launcher.slide_travel_m)",
                  nearest);
  }
  // The calibrated speeds, and the pressures the regulator may give.
  ShotPlan plan;
  for (int i = 0; i < 2; ++i) {
    auto p = pressureFor(profile, *curve, i, aim->exit_speed_m_s[i]);
    if (!p) {
      const double v_max = maxExitSpeed(profile, *curve);
      PlanRequest nearest = request;
      nearest.speed_m_s = speedsInside(*aim, request.speed_m_s, v_lo, v_max);
      const bool ok = static_cast<bool>(aimAt(free, nearest.incidence_deg, nearest.speed_m_s));
      return refuse(infeasible, p.error().message,
                    ok ? std::optional<PlanRequest>(nearest) : std::nullopt);
    }
    plan.pressure_kPa[i] = *p;
  }
  plan.request = request;
  plan.slide_offset_m = aim->slide_offset_m;
  plan.exit_speed_m_s = aim->exit_speed_m_s;
  plan.launch = aim->launch;
  plan.aimed = std::move(aim->profile);
  for (int i = 0; i < 2; ++i) {
    plan.exit_m[i] = plan.aimed.launchers[i].exit_m;
    plan.speed_at_contact_m_s[i] = plan.launch.before_contact[i].velocity_m_s.norm();
  }
  const Vec3 n = plan.launch.contact_normal;
  const Vec3 approach = -plan.launch.relative_velocity_m_s.normalized();
  plan.incidence_deg = std::acos(std::clamp(n.dot(approach), -1.0, 1.0)) * kDegPerRad;
  plan.material = request.material.value_or(profile.spheres.material);
  auto predicted =
      collideSpheres(plan.launch.before_contact[0], plan.launch.before_contact[1], plan.material);
  if (!predicted)
    return fail("Walton's model on the planned contact: " + predicted.error().message);
  plan.prediction = *predicted;
  return plan;
}

std::string vec3(const Vec3& v, const char* spec, double scale = 1.0) {
  // Appended, not "(" + ...: GCC 12 warns falsely (-Wrestrict) on a literal
  // put before a temporary string.
  std::string out = "(";
  out += num(spec, v.x() * scale) + ", " + num(spec, v.y() * scale) + ", ";
  out += num(spec, v.z() * scale) + ")";
  return out;
}

// Where and when the contact happens, after `since` (which valve opening).
std::string contactLine(const ShotPlan& p, const std::string& since) {
  return "  contact: " + num("%.2f", p.launch.contact_s * 1e3) + " ms after " + since + ", at (" +
         num("%.2f", p.launch.contact_point_m.x() * 1e3) + ", " +
         num("%.2f", p.launch.contact_point_m.y() * 1e3) + ") mm, pixel (" +
         num("%.1f", p.launch.contact_px.x()) + ", " + num("%.1f", p.launch.contact_px.y()) + ")";
}

// Walton's prediction for the planned contact (`against`: "" or " against a wall").
std::string waltonLine(const ShotPlan& p, const std::string& against) {
  const ContactOutcome& c = p.prediction.contact;
  return "  Walton's model" + against + " (e " + num("%.3f", p.material.e) + ", mu " +
         num("%.3f", p.material.mu) + ", beta0 " + num("%.3f", p.material.beta0) +
         "): " + (c.regime == Regime::Sliding ? "sliding" : "rolling") + ", beta " +
         num("%.3f", c.beta) + ", gamma " + num("%.2f", c.before.gamma_rad * kDegPerRad) +
         " deg, v_n " + num("%.3f", c.before.v_n_m_s) + " m/s, v_s " +
         num("%.3f", c.before.v_s_m_s) + " m/s";
}

// A sphere's state after the impact, as `who` ("sphere 1", "sphere").
std::string afterLine(const Sphere& a, const std::string& who) {
  return "    " + who + " after: velocity " + vec3(a.velocity_m_s, "%.3f") + " m/s, spin " +
         vec3(a.spin_rad_s, "%.1f") + " rad/s";
}

// A wall shot's lines after the first: the plate, launcher 1, the contact and
// Walton's infinite-mass prediction.
std::string describeWallPlan(const ShotPlan& p) {
  std::string s;
  const auto line = [&](const std::string& l) { s += l + "\n"; };
  const Wall& w = *p.aimed.wall;
  line("  plate: turned to normal " + vec3(w.normal.normalized(), "%.4f") + " through " +
       vec3(w.point_m, "%.2f", 1e3) + " mm (the profile's [wall] normal and point_m)");
  line("  launcher " + p.aimed.launchers[0].name + ": exit at " + vec3(p.exit_m[0], "%.2f", 1e3) +
       " mm; exit speed " + num("%.3f", p.exit_speed_m_s[0]) + " m/s, pressure " +
       num("%.2f", p.pressure_kPa[0]) + " kPa; launcher " + p.aimed.launchers[1].name +
       " is not fired");
  line(contactLine(p, "the valve opens"));
  line("  incidence " + num("%.2f", p.incidence_deg) + " deg; speed at contact " +
       num("%.3f", p.speed_at_contact_m_s[0]) + " m/s (spin and launch scatter aside)");
  line(waltonLine(p, " against a wall"));
  line(afterLine(p.prediction.after[0], "sphere"));
  return s;
}

}  // namespace

Result<ShotPlan> planShot(const hw::RigProfile& profile, const PlanRequest& request,
                          Infeasible* infeasible) {
  Infeasible why;
  auto plan = planOnce(profile, request, &why);
  if (plan || why.reason.empty()) return plan;
  // The nearest wish must itself be feasible: follow it through the other
  // limits (a faster shot may then need a smaller angle, ...).
  for (int round = 0; round < 4 && why.nearest; ++round) {
    Infeasible next;
    if (planOnce(profile, *why.nearest, &next)) break;
    why.nearest = next.nearest;
  }
  if (infeasible) *infeasible = why;
  return fail(refusal(why));
}

std::string describePlan(const ShotPlan& p) {
  std::string s;
  const auto line = [&](const std::string& l) { s += l + "\n"; };
  line("plan: " + describeRequest(p.request) + " at contact, rig " + p.aimed.name);
  if (p.isWall()) return s + describeWallPlan(p);
  for (int i = 0; i < 2; ++i) {
    const Vec3& x = p.exit_m[i];
    std::string slide = i == 1 ? (std::abs(p.slide_offset_m) < 5e-7
                                      ? " (slide as in the profile)"
                                      : " (slide " + num("%+.2f", p.slide_offset_m * 1e3) +
                                            " mm from the profile's exit_m)")
                               : " (as in the profile)";
    line("  launcher " + p.aimed.launchers[i].name + ": exit at " + vec3(x, "%.2f", 1e3) + " mm" +
         slide + "; exit speed " + num("%.3f", p.exit_speed_m_s[i]) + " m/s, pressure " +
         num("%.2f", p.pressure_kPa[i]) + " kPa; valve opens at " +
         num("%.2f", p.launch.valve_open_s[i] * 1e3) + " ms");
  }
  line(contactLine(p, "the first valve opens"));
  line("  incidence " + num("%.2f", p.incidence_deg) + " deg; speeds at contact " +
       num("%.3f", p.speed_at_contact_m_s[0]) + " and " + num("%.3f", p.speed_at_contact_m_s[1]) +
       " m/s (spin and launch scatter aside)");
  line(waltonLine(p, ""));
  for (int i = 0; i < 2; ++i)
    line(afterLine(p.prediction.after[i], "sphere " + std::to_string(i + 1)));
  return s;
}

}  // namespace collide::app
