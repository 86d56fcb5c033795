#include "app/campaign.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numeric>
#include <optional>
#include <random>
#include <regex>

#include "app/plan.hpp"
#include "app/rig_setup.hpp"
#include "app/store/atomic_file.hpp"
#include "app/store/save.hpp"
#include "app/store/shot_id.hpp"
#include "app/version.hpp"
#include "app/wall_campaign.hpp"
#include "hw/launch_plan.hpp"
#include "hw/sequencer.hpp"

namespace collide::app {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Signed angle (rad) between the line of centres and the approach direction at
// the planned contact: 0 head-on, +-pi/2 grazing; the sign says which side.
Result<double> plannedIncidence(const hw::RigProfile& p, const std::array<double, 2>& v) {
  auto plan = hw::planLaunch(p, v);
  if (!plan) return plan.error();
  const Vec3 n = plan->contact_normal;
  const Vec3 approach = -plan->relative_velocity_m_s.normalized();  // v_n < 0: n . v_rel < 0
  return std::atan2(n.cross(approach).z(), n.dot(approach));
}

// The profile text with the second launcher's exit_m moved up by dy (m).
Result<std::string> withSlideOffset(const std::string& text, double dy_m) {
  static const std::regex exit_re(R"(exit_m\s*=\s*\[\s*([^,\]]+),\s*([^,\]]+),\s*([^,\]]+)\])");
  auto it = std::sregex_iterator(text.begin(), text.end(), exit_re);
  if (it == std::sregex_iterator() || ++it == std::sregex_iterator())
    return fail("the rig profile has no second launcher exit_m = [x, y, z] to move");
  const std::smatch& m = *it;
  char replacement[160];
  std::snprintf(replacement, sizeof replacement, "exit_m = [%s, %.9g, %s]", m[1].str().c_str(),
                std::stod(m[2].str()) + dy_m, m[3].str().c_str());
  return text.substr(0, m.position(0)) + replacement + text.substr(m.position(0) + m.length(0));
}

Result<hw::RigProfile> profileWithOffset(const hw::RigProfile& p, double dy_m) {
  auto text = withSlideOffset(p.text, dy_m);
  if (!text) return text.error();
  return hw::parseRigProfile(*text, p.source);
}

struct Replanned {
  ShotPlan plan;
  std::string note;
};

// The shot nearest to `planned` that the rig can fire (collide plan's
// answer), with a note saying what changed and why.
std::optional<Replanned> nearestFeasible(const hw::RigProfile& profile,
                                         const PlannedShot& planned) {
  PlanRequest want;
  want.incidence_deg = planned.incidence_deg;
  want.speed_m_s = planned.speed_m_s;
  Infeasible why;
  auto plan = planShot(profile, want, &why);
  if (!plan && why.nearest) plan = planShot(profile, *why.nearest);
  if (!plan) return std::nullopt;
  char speeds[64];
  if (plan->isWall())  // one sphere, at the plate
    std::snprintf(speeds, sizeof speeds, "%.2f m/s", plan->speed_at_contact_m_s[0]);
  else
    std::snprintf(speeds, sizeof speeds, "%.2f and %.2f m/s", plan->speed_at_contact_m_s[0],
                  plan->speed_at_contact_m_s[1]);
  char note[200];
  std::snprintf(note, sizeof note,
                "planned %.1f deg at %s instead of %.1f deg (the nearest shot the rig can fire)",
                plan->incidence_deg, speeds, planned.incidence_deg);
  return Replanned{std::move(*plan), note};
}

}  // namespace

Result<hw::RigProfile> aimForIncidence(const hw::RigProfile& profile, double incidence_deg,
                                       const std::array<double, 2>& speed_m_s,
                                       double* slide_offset_m) {
  const double target = incidence_deg * kPi / 180.0;
  const double sigma = 0.5 * (profile.spheres.diameter_m[0] + profile.spheres.diameter_m[1]);
  // The slide moves only within its travel (when the profile gives it).
  const auto& travel = profile.launchers[1].slide_travel_m;
  const auto inTravel = [&](double dy) {
    return !travel || (dy >= (*travel)[0] - 1e-12 && dy <= (*travel)[1] + 1e-12);
  };
  // Trial positions move the parsed exit point (the text is edited once, for
  // the position chosen).
  hw::RigProfile trial = profile;
  const Vec3 exit = profile.launchers[1].exit_m;
  auto angleAt = [&](double dy) -> Result<double> {
    trial.launchers[1].exit_m = exit + Vec3(0, dy, 0);
    return plannedIncidence(trial, speed_m_s);
  };
  // The signed angle moves monotonically with the slide, from one grazing side
  // through head-on to the other: for each sign of the wanted angle, walk out
  // from 0 on each side until the angle passes it, then bisect. Of the (at
  // most two) positions found, the one nearer the profile's wins.
  auto a0 = angleAt(0.0);
  if (!a0) return a0.error();
  std::optional<double> best;
  for (const double want : {target, -target}) {
    for (const double side : {1.0, -1.0}) {
      const int steps = 24;
      double lo = 0.0, f_lo = *a0 - want;
      for (int k = 1; k <= steps; ++k) {
        const double hi = side * sigma * 1.1 * k / steps;
        if (!inTravel(hi) || (best && std::abs(hi) > std::abs(*best) + sigma)) break;
        auto a_hi = angleAt(hi);
        if (!a_hi) break;  // missed each other or left the image
        const double f_hi = *a_hi - want;
        if ((f_lo <= 0) != (f_hi <= 0) || f_lo == 0) {
          double a = lo, b = hi;
          bool a_below = f_lo <= 0;
          for (int i = 0; i < 50; ++i) {
            const double mid = 0.5 * (a + b);
            auto am = angleAt(mid);
            if (!am) return am.error();
            ((*am - want <= 0) == a_below ? a : b) = mid;
          }
          const double dy = 0.5 * (a + b);
          if (!best || std::abs(dy) < std::abs(*best)) best = dy;
          break;
        }
        lo = hi;
        f_lo = f_hi;
      }
    }
    if (target == 0) break;  // +0 and -0 are one angle
  }
  if (best) {
    if (slide_offset_m) *slide_offset_m = *best;
    return profileWithOffset(profile, *best);
  }
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "no position of launcher 2's vertical slide gives an incidence of %.1f deg at "
                "%.2f and %.2f m/s inside the image: choose a smaller angle or other speeds",
                incidence_deg, speed_m_s[0], speed_m_s[1]);
  return fail(buf);
}

std::vector<PlannedShot> planCampaign(const CampaignOptions& o) {
  std::vector<PlannedShot> shots(static_cast<std::size_t>(std::max(0, o.shots)));
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> speed(o.speed_min_m_s, o.speed_max_m_s);
  const std::size_t n = shots.size();
  for (std::size_t i = 0; i < n; ++i) {
    // Evenly spaced angles (cell centres) so every part of the range is covered.
    const double u = n == 1 ? 0.5 : (i + 0.5) / n;
    shots[i].incidence_deg = o.angle_min_deg + u * (o.angle_max_deg - o.angle_min_deg);
    shots[i].speed_m_s = {speed(rng), speed(rng)};
  }
  // Fire them in random order so a drift in the rig does not masquerade as a
  // dependence on the angle.
  std::shuffle(shots.begin(), shots.end(), rng);
  return shots;
}

Status prepareCampaign(const hw::RigProfile& profile, const CampaignOptions& o) {
  if (o.shots < 1) return fail("--shots must be at least 1");
  if (!(o.angle_min_deg >= 0 && o.angle_min_deg <= o.angle_max_deg && o.angle_max_deg < 90))
    return fail("incidence angles must satisfy 0 <= min <= max < 90 degrees");
  if (!(o.speed_min_m_s > 0 && o.speed_min_m_s <= o.speed_max_m_s))
    return fail("exit speeds must satisfy 0 < min <= max (m/s)");
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec && !std::filesystem::exists(o.out_dir))
    return ioError(ec.value(), "creating the shot folder", o.out_dir);
  // Before the first shot is fired: a shot that cannot be saved is wasted.
  if (auto writable = checkWritableFolder(o.out_dir); !writable) return writable.error();
  const auto& cam = profile.camera_config;
  const double shot_bytes =
      static_cast<double>(cam.width) * cam.height *
          (cam.format == vision::PixelFormat::Mono8 ? 1 : 2) *
          (profile.burst.pre_trigger_frames + profile.burst.post_trigger_frames) +
      1e6;
  if (auto room = checkFreeSpace(o.out_dir, shot_bytes, "save a shot in " + o.out_dir); !room)
    return room.error();
  return Ok{};
}

std::string stopReason(const CampaignOptions& o, int failed_in_a_row,
                       const CampaignReport& report) {
  if (Status ready = report.devices->ready(); !ready)
    return "the next shot was refused: " + ready.error().message;
  if (o.max_consecutive_failures <= 0 || failed_in_a_row < o.max_consecutive_failures) return "";
  return std::to_string(failed_in_a_row) +
         " shots in a row failed on the rig (last: " + report.failures.back() +
         "): check the devices, then fire the remaining shots (firing again with nothing changed "
         "will not help)";
}

Result<AimedShot> aimCampaignShot(const hw::RigProfile& profile, const PlannedShot& planned) {
  AimedShot out;
  out.exit_speed_m_s = planned.speed_m_s;
  if (profile.wall) out.exit_speed_m_s[1] = out.exit_speed_m_s[0];  // launcher 2 never fires
  auto aimed = profile.wall
                   ? aimWallForIncidence(profile, planned.incidence_deg, out.exit_speed_m_s[0])
                   : aimForIncidence(profile, planned.incidence_deg, out.exit_speed_m_s);
  if (aimed) {
    out.profile = std::move(aimed).value();
    return out;
  }
  // The rig cannot fire this one (the slide out of travel, a plate turned so
  // far that the launcher would sit behind it, a speed beyond the
  // calibration): the planner's nearest shot instead.
  auto replanned = nearestFeasible(profile, planned);
  if (!replanned) return aimed.error();
  out.profile = std::move(replanned->plan.aimed);
  out.exit_speed_m_s = replanned->plan.exit_speed_m_s;
  out.replanned = replanned->note;
  return out;
}

Result<std::optional<hw::Shot>> fireCampaignShot(const hw::RigProfile& profile,
                                                 const PlannedShot& planned,
                                                 const CampaignOptions& o, int index,
                                                 CampaignReport& report, std::stop_token cancel) {
  const std::string id = makeShotId(wallTimeUnixNs(), index);
  auto aimed = aimCampaignShot(profile, planned);
  if (!aimed) {
    ++report.failed;
    report.failures.push_back(id + ": " + aimed.error().message);
    return std::optional<hw::Shot>();
  }
  if (!aimed->replanned.empty()) report.replanned.push_back(id + ": " + aimed->replanned);
  const std::array<double, 2> speed = aimed->exit_speed_m_s;
  // A different simulation seed per shot: dots, spins and scatter differ.
  aimed->profile.simulation.seed = o.seed * 1000003ULL + index;
  auto fired = fireShot(aimed->profile, hw::ShotRequest::atSpeeds(speed[0], speed[1]), id, cancel,
                        report.devices);
  if (!fired) return fail("shot " + std::to_string(index + 1) + ": " + fired.error().message);
  hw::Shot& shot = *fired;
  ++report.fired;
  auto saved = saveShot(o.out_dir, shot);
  if (!saved)
    return fail(saved.error().message + " (" + std::to_string(report.files.size()) +
                " shots saved in " + o.out_dir + " before this one are intact)");
  shot.id = *saved;  // the next free id when an earlier shot had this one
  report.files.push_back((std::filesystem::path(o.out_dir) / shotFileName(shot.id)).string());
  if (shot.status == hw::ShotStatus::Ok) {
    ++report.ok;
  } else {
    ++report.failed;
    report.failures.push_back(shot.id + ": " + shot.failure_reason);
  }
  return std::optional<hw::Shot>(std::move(shot));
}

Result<CampaignReport> runCampaign(const hw::RigProfile& profile, const CampaignOptions& o,
                                   const CampaignProgress& progress, std::stop_token cancel) {
  if (auto ready = prepareCampaign(profile, o); !ready) return ready.error();
  CampaignReport report;
  const std::vector<PlannedShot> plan = planCampaign(o);
  int failed_in_a_row = 0;
  for (std::size_t i = 0; i < plan.size(); ++i) {
    report.stopped_because = stopReason(o, failed_in_a_row, report);
    if (cancel.stop_requested() || !report.stopped_because.empty()) {
      report.cancelled = cancel.stop_requested();
      report.not_fired = static_cast<int>(plan.size() - i);
      break;
    }
    auto shot = fireCampaignShot(profile, plan[i], o, static_cast<int>(i), report, cancel);
    if (!shot) return shot.error();
    if (!*shot) continue;  // could not be aimed (counted as failed)
    failed_in_a_row = (*shot)->status == hw::ShotStatus::Ok ? 0 : failed_in_a_row + 1;
    if (progress) progress(static_cast<int>(i + 1), static_cast<int>(plan.size()), **shot);
  }
  return report;
}

}  // namespace collide::app
