// `collide campaign`: fire N simulated (or real) shots sweeping the incidence
// angle and store them as shot files plus a catalog.
#include "app/campaign.hpp"

#include <cstdio>
#include <iostream>

#include "app/adaptive_campaign.hpp"
#include "app/cli/command.hpp"
#include "app/cli/interrupt.hpp"
#include "app/cli/progress.hpp"
#include "app/rig_setup.hpp"

namespace {

int runAdaptive(const collide::hw::RigProfile& profile, const collide::app::CampaignOptions& o,
                const collide::AdaptiveOptions& design, std::stop_token stop) {
  using namespace collide;
  AdaptiveOptions checked = design;
  checked.angle_min_deg = o.angle_min_deg, checked.angle_max_deg = o.angle_max_deg;
  if (auto bad = chooseNextShot({}, {}, checked); !bad) {
    std::cerr << "collide campaign: " << bad.error().message << "\n";
    return cli::kExitBadInput;
  }
  auto report = app::runAdaptiveCampaign(
      profile, o, design,
      [&](int done, int budget, const app::AdaptiveShot& shot, const AdaptiveStatus& st) {
        char head[96];
        std::snprintf(head, sizeof head, "shot %d of at most %d: %.1f deg, ", done, budget,
                      shot.incidence_deg);
        std::cout << head << (shot.id.empty() ? "not fired" : shot.id) << "\n  why: " << shot.why
                  << "\n";
        if (!shot.note.empty()) std::cout << "  note: " << shot.note << "\n";
        std::cout << "  now: " << app::adaptiveSigmasText(st, design) << std::endl;
      },
      stop);
  if (!report) {
    std::cerr << "collide campaign: " << report.error().message << "\n";
    return cli::kExitFailure;
  }
  const app::CampaignReport& c = report->campaign;
  std::cout << c.fired << " shots fired (" << c.ok << " ok, " << c.failed << " failed) into "
            << o.out_dir << "\n";
  // One text for the CLI and the GUI: why it ended, with the sigmas against the targets.
  const std::string why = app::adaptiveStopText(*report, o, design);
  if (report->targets_met || c.cancelled)
    std::cout << why << "\n";
  else
    std::cerr << "collide campaign: " << why
              << (c.stopped_because.empty() ? ": raise --shots or loosen the targets" : "") << "\n";
  return report->targets_met && c.stopped_because.empty() ? cli::kExitOk : cli::kExitFailure;
}

void setupCampaign(CLI::App& sub, std::function<int()>& run) {
  auto rig = std::make_shared<std::string>();
  auto o = std::make_shared<collide::app::CampaignOptions>();
  sub.add_option("--rig", *rig, "Rig profile (TOML), e.g. config/sim.toml")->required();
  sub.add_option("--shots", o->shots, "Number of shots to fire")->check(CLI::PositiveNumber);
  sub.add_option("--out", o->out_dir, "Folder for the shot files and catalog.sqlite")->required();
  sub.add_option("--seed", o->seed, "Seed of the sweep and of the simulation (reproducible)");
  sub.add_option("--angle-min-deg", o->angle_min_deg, "Smallest incidence angle, degrees")
      ->capture_default_str();
  sub.add_option("--angle-max-deg", o->angle_max_deg, "Largest incidence angle, degrees")
      ->capture_default_str();
  sub.add_option("--speed-min", o->speed_min_m_s, "Slowest exit speed, m/s")->capture_default_str();
  sub.add_option("--speed-max", o->speed_max_m_s, "Fastest exit speed, m/s")->capture_default_str();
  auto adaptive = std::make_shared<bool>(false);
  auto design = std::make_shared<collide::AdaptiveOptions>();
  sub.add_flag("--adaptive", *adaptive,
               "Choose each shot's angle where mu or beta_0 is least known; stop at the targets "
               "(--shots is then the budget)");
  sub.add_option("--target-sigma-mu", design->target_sigma_mu,
                 "With --adaptive: stop when sigma(mu) is at most this")
      ->capture_default_str();
  sub.add_option("--target-sigma-beta0", design->target_sigma_beta0,
                 "With --adaptive: stop when sigma(beta_0) is at most this")
      ->capture_default_str();
  sub.footer(
      "Incidence angle: between the line of centres and the relative velocity at contact\n"
      "(0 = head-on); it is set by moving launcher 2's vertical slide. Each shot is saved as\n"
      "it completes; Ctrl-C stops after the current shot and keeps everything fired.");
  run = [=] {
    auto profile = collide::hw::loadRigProfile(*rig);
    if (!profile) {
      std::cerr << "collide campaign: " << profile.error().message << "\n";
      return collide::cli::kExitBadInput;
    }
    // Every backend's settings are checked now (devices stay closed), not at
    // shot 1: a wrong Modbus address is a bad profile, not a failed shot.
    if (auto rig_check = collide::app::buildRig(*profile); !rig_check) {
      std::cerr << "collide campaign: " << rig_check.error().message << "\n";
      return collide::cli::kExitBadInput;
    }
    collide::cli::StopOnInterrupt stop;
    if (*adaptive) return runAdaptive(*profile, *o, *design, stop.token());
    collide::cli::ProgressBar bar("campaign", o->shots);
    auto report = collide::app::runCampaign(
        *profile, *o,
        [&](int done, int, const collide::hw::Shot& shot) {
          bar.update(done,
                     shot.id + (shot.status == collide::hw::ShotStatus::Ok ? " ok" : " FAILED"));
        },
        stop.token());
    if (!report) {
      std::cerr << "collide campaign: " << report.error().message << "\n";
      return collide::cli::kExitFailure;
    }
    std::cout << report->fired << " shots fired (" << report->ok << " ok, " << report->failed
              << " failed) into " << o->out_dir << "\n";
    for (const auto& r : report->replanned) std::cout << "  replanned: " << r << "\n";
    for (const auto& f : report->failures) std::cout << "  failed: " << f << "\n";
    if (report->cancelled)
      std::cout << "stopped early on request (" << report->not_fired
                << " planned shots not fired); every shot fired was saved\n";
    if (!report->stopped_because.empty())
      std::cerr << "collide campaign: stopped after " << report->fired << " of " << o->shots
                << " shots: " << report->stopped_because << "\n";
    // Any failed shot, or a campaign that stopped itself, is a failure that
    // scripts must see; a stop the user asked for (Ctrl-C) is not.
    const bool complete = report->failed == 0 && report->stopped_because.empty();
    return complete ? collide::cli::kExitOk : collide::cli::kExitFailure;
  };
}

}  // namespace

COLLIDE_COMMAND(campaign,
                "Fire N shots sweeping the incidence angle and store them (--rig --shots --out)",
                setupCampaign);
