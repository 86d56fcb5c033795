// `collide campaign`: fire N simulated (or real) shots sweeping the incidence
// angle and store them as shot files plus a catalog.
#include "app/campaign.hpp"

#include <iostream>

#include "app/cli/command.hpp"
#include "app/cli/interrupt.hpp"
#include "app/cli/progress.hpp"
#include "app/rig_setup.hpp"

namespace {

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
