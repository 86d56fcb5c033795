#pragma once
// A campaign: many shots of one material, sweeping the launch conditions so the
// incidence angles span a wide range (the thesis' Figs. 5.9-5.13 need shots
// from near head-on to grazing) and |v_n| varies. Each shot is fired through
// the ordinary sequencer and saved (HDF5 file + catalog row) as it completes,
// so stopping half-way loses nothing already fired.
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stop_token>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "hw/device_health.hpp"
#include "hw/rig_profile.hpp"
#include "hw/shot.hpp"

namespace collide::app {

struct CampaignOptions {
  int shots = 20;
  std::string out_dir;
  std::uint64_t seed = 1;
  /// Incidence angle: between the line of centres and the relative velocity at
  /// contact, degrees (0 = head-on). Swept evenly over the shots, then shuffled.
  double angle_min_deg = 10.0;
  double angle_max_deg = 80.0;
  /// Exit speeds, m/s, drawn uniformly per shot and launcher.
  double speed_min_m_s = 1.6;
  double speed_max_m_s = 2.6;
  /// The campaign stops after this many shots in a row failed on the rig (a
  /// regulator outage, a camera gone): firing on would only pile up failures.
  /// A device that stopped answering (lost, hw/device_health.hpp) stops it
  /// at once, before the next shot.
  int max_consecutive_failures = 3;
};

/// The launch conditions chosen for one shot.
struct PlannedShot {
  double incidence_deg = 0.0;
  std::array<double, 2> speed_m_s{0.0, 0.0};
  /// Vertical slide offset of launcher 2 (m) that gives the incidence angle.
  double slide_offset_m = 0.0;
};

struct CampaignReport {
  int fired = 0;
  int ok = 0;
  int failed = 0;
  std::vector<std::string> files;     ///< shot files written, in firing order
  std::vector<std::string> failures;  ///< "<shot id>: <reason>" per failed shot
  bool cancelled = false;
  /// Why the campaign stopped before its last shot on its own ("3 shots in a
  /// row failed ..."); empty when it ran to the end or was cancelled.
  std::string stopped_because;
  /// Shots planned but never fired (stopped or cancelled early).
  int not_fired = 0;
  /// "<shot id>: planned ... instead of ..." for each shot the rig could not
  /// fire as swept (too grazing for its speeds, ...): the planner's nearest
  /// feasible shot was fired instead.
  std::vector<std::string> replanned;
  /// The devices' health across the campaign's shots (each shot builds its
  /// own rig for the same devices): a device lost in one shot refuses the
  /// next at once. Never null.
  std::shared_ptr<hw::DeviceHealth> devices = std::make_shared<hw::DeviceHealth>();
};

/// Called after each shot is saved: shots done so far, total, the shot.
using CampaignProgress = std::function<void(int done, int total, const hw::Shot& shot)>;

/// The profile with launcher 2's vertical slide moved so that, at these exit
/// speeds, the spheres meet at `incidence_deg` (spin and scatter aside). The
/// returned profile's text is the edited TOML, so the shot records the
/// geometry it was really fired with. Errors: the profile text has no second
/// `exit_m`, or no slide position gives the angle inside the image.
Result<hw::RigProfile> aimForIncidence(const hw::RigProfile& profile, double incidence_deg,
                                       const std::array<double, 2>& speed_m_s,
                                       double* slide_offset_m = nullptr);

/// The sweep: `options.shots` launch conditions, reproducible from the seed.
std::vector<PlannedShot> planCampaign(const CampaignOptions& options);

/// Checks the options, creates options.out_dir and checks it is writable and
/// has room for a shot: what must hold before anything is fired.
Status prepareCampaign(const hw::RigProfile& profile, const CampaignOptions& options);

/// How a planned shot is fired on this rig: launcher 2's slide aimed for its
/// incidence at its speeds (a wall rig: launcher 1 aimed at the wall), or,
/// when the rig cannot fire that, the planner's nearest feasible shot.
struct AimedShot {
  hw::RigProfile profile;                      ///< fire this
  std::array<double, 2> exit_speed_m_s{0, 0};  ///< at these exit speeds
  std::string replanned;  ///< empty, or what changed: "planned 74.0 deg at ... instead of ..."
};
/// Errors: neither the shot nor any near it can be fired (the aiming's reason).
Result<AimedShot> aimCampaignShot(const hw::RigProfile& profile, const PlannedShot& planned);

/// Aims (or replans, see CampaignReport::replanned), fires and saves one shot
/// of a campaign, counting it in `report`. None: it could not be aimed (counted
/// as failed, with the reason). Errors: the rig could not fire at all, or the
/// shot could not be saved (the message says the earlier shots are intact).
Result<std::optional<hw::Shot>> fireCampaignShot(const hw::RigProfile& profile,
                                                 const PlannedShot& planned,
                                                 const CampaignOptions& options, int index,
                                                 CampaignReport& report,
                                                 std::stop_token cancel = {});

/// Why a campaign must stop: a device is lost (report.devices; the next shot
/// is refused without asking anything of any device), or
/// options.max_consecutive_failures shots in a row failed (empty: go on).
std::string stopReason(const CampaignOptions& options, int failed_in_a_row,
                       const CampaignReport& report);

/// Fires and saves the campaign into options.out_dir (created if missing).
/// Failed shots are saved too (status failed, with the reason) and the
/// campaign goes on, unless a device stopped answering (lost) or
/// `max_consecutive_failures` shots in a row failed: then it stops and says why
/// (CampaignReport::stopped_because). Errors (before any shot): bad options, an out_dir that cannot
/// be created, a rig that cannot be built. Blocks; call from a worker.
Result<CampaignReport> runCampaign(const hw::RigProfile& profile, const CampaignOptions& options,
                                   const CampaignProgress& progress = {},
                                   std::stop_token cancel = {});

}  // namespace collide::app
