#pragma once
// The adaptive campaign's choice of the next shot (issue 16 §2): after each
// analysed shot, where should the next one go so that the uncertainties of
// Walton's mu and beta_0 shrink fastest?
//
// Model (analysis/campaign.hpp): beta(x) = min(beta_0, -1 + s x), x = cot psi,
// s = (1 + 1/K)(1 + e) mu. A sliding shot (x below the switch x0, the grazing
// side) tells about s only, with weight x^2 / sigma_beta^2; a rolling shot
// (x above x0, towards head-on) tells about beta_0 only, with weight
// 1 / sigma_beta^2. sigma_beta grows towards head-on (v_s -> 0), about as
// 1/sin psi at a given speed, so the most telling shots lie near the switch on
// either side, where the regime itself is uncertain.
//
// Choice. With a fit, every candidate angle on a 0.5 degree grid is scored by
// the expected criterion after adding it: the larger of sigma_mu/target_mu
// and sigma_beta0/target_beta0 from the linearised covariance (the fit's,
// plus the candidate's information), averaged over the two regimes with the
// probability that the candidate slides (from x0 and its sigma). The lowest
// score wins. The speed: over the shots so far, log(sigma_beta sin psi)
// against log |v_c| gives how the noise scales with speed (sigma_beta ~ V^q:
// q = -1 when the velocity errors do not grow with speed, above 0 when blur
// and fewer frames in view make them grow faster than V). Once at least four
// shots spread over 20 % in speed say so, each candidate angle is scored at
// the slowest and the fastest speed of the rig's range (a power law is best
// at one end) and the better pair wins; until then the shot goes to the end
// of the range furthest from the speeds fired so far, to learn the law.
// Before a fit is possible (too few shots, or too few on one side of the
// switch) the angles are spread: the first shots evenly over the range, then
// the largest gap in psi (speeds drawn by the campaign).
#include <limits>
#include <optional>
#include <random>
#include <span>
#include <string>

#include "analysis/campaign.hpp"
#include "analysis/result.hpp"

namespace collide {

struct AdaptiveOptions {
  double target_sigma_mu = 0.005;
  double target_sigma_beta0 = 0.02;
  double angle_min_deg = 10.0;  ///< psi range the rig can fire (0 = head-on)
  double angle_max_deg = 80.0;
  /// Relative contact speeds the rig can fire, m/s; the next shot's speed is
  /// chosen in this range once the shots so far tell how sigma_beta scales
  /// with speed (0, 0: not chosen, the campaign draws it).
  double speed_min_m_s = 0.0, speed_max_m_s = 0.0;
  int initial_shots = 6;  ///< spread evenly before the first fit
  FrictionOptions friction;
};

/// Where the campaign stands after the shots so far.
struct AdaptiveStatus {
  std::optional<RestitutionMean> restitution;
  std::optional<FrictionFit> friction;
  std::string fit_error;     ///< why there is no friction fit yet (empty when there is)
  bool targets_met = false;  ///< both sigmas at or below their targets
};

/// The next shot and why.
struct NextShot {
  double incidence_deg = 0.0;  ///< psi, degrees (0 head-on)
  /// Relative contact speed, m/s; NaN: not chosen (no speed range given, or
  /// before a fit: the campaign draws it).
  double speed_m_s = std::numeric_limits<double>::quiet_NaN();
  std::string why;  ///< one sentence with the figures behind the choice
  /// Expected sigmas once this shot is in (NaN before a fit).
  double expected_sigma_mu = 0.0, expected_sigma_beta0 = 0.0;
};

/// Fits the shots so far (e as a weighted mean, then the friction fit).
AdaptiveStatus assessCampaign(std::span<const CampaignShot> shots, const AdaptiveOptions& options);

/// The next shot's incidence given the shots so far and their assessment.
/// Errors: an empty or reversed angle range, targets not > 0.
Result<NextShot> chooseNextShot(std::span<const CampaignShot> shots, const AdaptiveStatus& status,
                                const AdaptiveOptions& options);

/// Measurement noise of a synthetic shot (synthesizeShot).
struct ShotNoise {
  double sigma_beta_at_90 = 0.01;  ///< sigma_beta = this / sin psi (at 4 m/s)
  double sigma_v_m_s = 0.01;       ///< per contact-velocity component (v_n, v_s), at 4 m/s
  double sigma_e = 0.005;
  double relative_speed_m_s = 4.0;  ///< |v_c| at contact
  /// The velocity errors scale as (|v_c| / 4 m/s)^this (0: as at 4 m/s; 2:
  /// blur-limited), and sigma_beta as (|v_c| / 4 m/s)^(this - 1).
  double speed_exponent = 0.0;
};

/// A shot as Walton's model gives it at incidence psi (degrees) for `material`,
/// with Gaussian measurement noise: beta = min(beta_0, -1 + (1 + 1/K)(1 + e) mu
/// cot psi) + noise. For benchmarks and tests of campaign designs.
CampaignShot synthesizeShot(const Material& material, double psi_deg, const ShotNoise& noise,
                            std::mt19937_64& rng, double inertia_factor_K = 0.4);

}  // namespace collide
