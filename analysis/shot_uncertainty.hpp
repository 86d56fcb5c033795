#pragma once
// A shot's properties and their uncertainties (docs/SPEC.md steps 3-6): every
// fitted input (trajectory coefficients, spins, the systematic centre errors,
// the unseen out-of-plane parts) is drawn from its distribution, the
// collision instant found again, the kinematics evaluated there and Walton's
// inverse applied; the spread of the results over the draws is their
// uncertainty. Pure maths, SI units.
#include <Eigen/Dense>
#include <array>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "analysis/contact.hpp"
#include "analysis/shot_inverse.hpp"
#include "analysis/trajectory.hpp"

namespace collide {

/// How an error of a sphere's measured depth moves one trajectory fit's
/// in-plane velocity: a centre placed on the wrong plane is off by
/// -x dz / Z0 (x from the optical axis, z towards the camera), so the move
/// has a direction, not a spread on both axes. m/s per standard deviation.
struct DepthCoupling {
  /// Per standard deviation of the depth's rate (v_z): along the position
  /// from the optical axis, and along the velocity as the track bends.
  Eigen::Vector2d per_rate = Eigen::Vector2d::Zero();
  /// Per standard deviation of the depth at the collision: along the velocity.
  Eigen::Vector2d per_offset = Eigen::Vector2d::Zero();
};

/// Everything measured about one shot, as the Monte Carlo draws it.
struct ShotModel {
  std::array<std::array<const TrajectoryFit*, 2>, 2> fit{};  ///< [sphere][0 before, 1 after]
  std::array<std::array<double, 2>, 2>
      inflation{};  ///< of each fit's covariance (residual correlation)
  std::array<std::array<double, 2>, 2> drift{};       ///< systematic velocity sigma, m/s
  std::array<std::array<DepthCoupling, 2>, 2> depth;  ///< [sphere][side]
  /// Systematic position sigma per axis, m: an offset that holds over a
  /// track, drawn for each of a sphere's two fits on its own.
  std::array<double, 2> offset{};
  std::array<std::array<Vec3, 2>, 2> spin;  ///< [sphere][side], rad/s
  std::array<std::array<Eigen::Matrix3d, 2>, 2> spin_cov;
  std::array<double, 2> diameter{}, mass{};
  double contact = 0;  ///< contact distance, m
  /// Its uncertainty where the centres are measured, m: the centres of two
  /// touching spheres lie that much nearer or further apart than the
  /// diameters say (e.g. a radius bias on a shaded limb). At grazing
  /// incidence it moves the contact instant, and so the line of centres,
  /// most.
  double contact_sigma = 0;
  double t_before = 0, t_after = 0;  ///< the nominal instants (pre-, post-impact fits)
  double w_before = 0.5;             ///< weight of the pre-impact instant in t_c
  /// Each sphere's position at contact is where its pre- and post-impact
  /// fits meet (the centre does not jump): their positions at t_c averaged
  /// with these weights of the pre-impact fit's. 1: the pre-impact fit alone.
  /// contactPositionWeights gives the inverse-variance ones.
  std::array<double, 2> w_position_before{1.0, 1.0};
  /// Weight in t_c of each sphere's kinkTime (where its pre- and post-impact
  /// tracks meet, analysis/contact.hpp); the contact-distance instants'
  /// combination (w_before) takes the rest. 0: those instants alone.
  std::array<double, 2> w_kink{0.0, 0.0};
  /// False when the fits never came within the contact distance (a nearly
  /// grazing impact, vision/shot_fits.hpp kinkInstant): t_before = t_after
  /// are where the spheres' tracks bend, and the instant rests on the kinks
  /// alone (instantWeights leaves the contact-distance instants out; the
  /// draws do not look for them).
  bool contact_reached = true;
  /// What is known of the line of centres' z part before the spins speak:
  /// its mean (a measurement, e.g. from the spheres' apparent sizes, or 0 for
  /// a prior) and standard deviation.
  double nz_mean = 0.0;
  double nz_sigma = 0.01;
  double vz_fraction = 0.005;  ///< prior sigma of v_z before impact, fraction of the speed
  /// Each sphere's measured v_z before impact (value, sigma; m/s), e.g. from
  /// its apparent size; unset: 0 with the prior vz_fraction.
  std::array<std::optional<std::array<double, 2>>, 2> vz_before;
  /// The part of vz_before's sigma (m/s) drawn with the same deviate as the
  /// pre-impact fit's depth.per_rate: one error of the depth's rate moves
  /// both (at most vz_before's sigma; the rest is drawn on its own).
  std::array<double, 2> vz_before_shared{};
};

/// The weight of each sphere's pre-impact fit in its position at contact
/// (ShotModel::w_position_before): the inverse variance of each fit's
/// position at the nominal instant t_c_s (its covariance times its
/// inflation), against the post-impact fit's. Either fit's position variance
/// not finite and > 0: 1 for that sphere (the pre-impact fit alone).
std::array<double, 2> contactPositionWeights(const ShotModel& model, double t_c_s);

/// The collision instant's four estimates, weighed: where the pre-impact
/// fits are one contact distance apart (t_before), where the post-impact
/// ones are (t_after), and where each sphere's two fits meet (kinkTime).
/// Their errors, to first order in the four fits' position errors at the
/// instant (each fit's covariance times its inflation) and in the contact
/// distance's error (contact_sigma, which moves t_before and t_after apart
/// and not the kinks), are correlated: the estimates share the fits. The
/// weights are generalised least squares' over the four (C^-1 1 / 1' C^-1
/// 1), kept non-negative (the most negative estimate is left out and the
/// rest weighed again: negative weights amplified what the linear model
/// leaves out and flagged 5 of 30 ideal shots). Evaluated on the
/// fits at t_before, t_after and t_c_s; a kink whose fits' velocities do not
/// differ, or an estimate on a fit without a finite position variance, gets
/// no weight; with none usable, the model's w_before and no kinks. Without
/// the contact reached (ShotModel::contact_reached), the kinks alone.
struct InstantWeights {
  double before = 0.5;               ///< ShotModel::w_before
  std::array<double, 2> kink{0, 0};  ///< ShotModel::w_kink
};
InstantWeights instantWeights(const ShotModel& model, double t_c_s);

/// One draw (or the nominal evaluation) of a shot.
struct ShotDraw {
  double t_c = 0;    ///< combined collision instant
  double dt_ba = 0;  ///< pre-impact minus post-impact collision instant
  /// Sphere 1's kink minus sphere 2's (kinkTime, s; NaN where a sphere's
  /// fits do not bend): one impulse bends both tracks at once, so it is 0
  /// but for the errors of the four fits' positions at the instant.
  double kink_gap = std::numeric_limits<double>::quiet_NaN();
  std::array<Vec3, 2> v_before, v_after, w_before, w_after;
  ShotInverse inverse;  ///< n_z, Walton's measurement, v_s', energy change
  bool ok = false;
};

/// The inputs the Monte Carlo draws, grouped by where their error comes
/// from: the rows of an error budget (errorBudget). Bit flags; a draw with
/// some left out takes those at their measured values.
enum UncertaintySource : unsigned {
  kFitNoise = 1u << 0,         ///< the trajectory fits' coefficients: the centres' scatter
  kCentreDrift = 1u << 1,      ///< the centres' slow wander (dots, lamp): ShotModel::drift
  kDepth = 1u << 2,            ///< depth errors moving the centres (depth), and the v_z they
                               ///< share (vz_before_shared)
  kOutOfPlaneSpeed = 1u << 3,  ///< v_z before impact, the rest: its prior or size measurement
  kPositionOffset = 1u << 4,   ///< the centres' systematic offset: ShotModel::offset
  kContactDistance = 1u << 5,  ///< ShotModel::contact_sigma
  kSpins = 1u << 6,            ///< the measured (or unknown) spins: spin_cov
  kLineOfCentresZ = 1u << 7,   ///< n_z's prior or size measurement: nz_sigma
};
constexpr unsigned kEverySource = (1u << 8) - 1;

/// A trajectory fit's own coefficients as a track (drawTrack's nominal case).
PlaneTrack nominalTrack(const TrajectoryFit& f);

/// A trajectory fit's coefficients, drawn from their covariance (times
/// `inflation`) plus a systematic position offset per axis, and shifted in
/// velocity by `drift_m_s` (per axis, drawn by the caller: drawDriftPair);
/// the fit's own coefficients when `nominal`. `sources`: kFitNoise for the
/// coefficients, kPositionOffset for the offset (the drift is always added).
PlaneTrack drawTrack(const TrajectoryFit& f, double inflation, const Eigen::Vector2d& drift_m_s,
                     double offset_m, std::mt19937_64& rng, bool nominal,
                     unsigned sources = kEverySource);

/// One draw, on one axis, of the systematic velocity errors a slow wander of
/// the measured centre (the dots' pull on the outline) gives one sphere's
/// pre- and post-impact fits, of standard deviations `sigma_before` and
/// `sigma_after` (m/s). The wander is taken as independent at each track's
/// far end and shared at the contact, where the two tracks meet: a fit's
/// velocity error is the change of the wander over its span, so the two are
/// anti-correlated (-1/2): s_b (g_c - g_0) / sqrt(2) and s_a (g_1 - g_c) /
/// sqrt(2). Simulated backlit walls, where this term is most of the velocity
/// sigma, show -0.4 (docs/benchmarks.md, session 30).
std::array<double, 2> drawDriftPair(double sigma_before, double sigma_after, std::mt19937_64& rng);

/// The shot from one draw of every input in `sources` (or the nominal
/// values): collision instant, velocities and spins there, Walton's inverse.
ShotDraw evaluateShot(const ShotModel& model, std::mt19937_64& rng, bool nominal,
                      unsigned sources = kEverySource);

/// Running standard deviation of the finite values added (Welford's update:
/// no cancellation when the spread is tiny against the mean).
struct Spread {
  double mean = 0, m2 = 0;
  int n = 0;
  void add(double x);
  double sigma() const;  ///< NaN below two values
};

/// The nominal shot and the spread of its quantities over `draws` draws.
struct ShotUncertainty {
  ShotDraw nominal;  ///< nominal.ok false: not a collision
  Spread e, beta, beta_from_impulse, f, gamma_deg, vn, vs, vs_after, t_c, dt_ba;
  Spread kinetic_energy_change, n_z;
  /// beta (from the spins) minus beta_from_impulse (from the velocities and
  /// the spins before), draw by draw: their difference's own spread, the
  /// yardstick of the angular-momentum check (both share most inputs).
  Spread beta_spin_minus_impulse;
  std::array<std::array<Spread, 3>, 2> v_before, v_after;  ///< [sphere][axis]
  Spread kink_gap;                                         ///< ShotDraw::kink_gap
  /// How much kink_gap's variance grows per m^2 of a further centre offset
  /// per track (per axis, each of the four tracks its own): 2 (1/|dv_1|^2 +
  /// 1/|dv_2|^2), s^2/m^2, dv_s each sphere's velocity change at the nominal
  /// instant. NaN where a sphere's velocity does not change.
  double kink_gap_var_per_offset_var = std::numeric_limits<double>::quiet_NaN();
};

/// Nominal evaluation, then `draws` random ones (of the inputs in `sources`)
/// from a generator seeded with `seed` (fixed: the same shot gives the same
/// sigmas).
ShotUncertainty propagateShot(const ShotModel& model, int draws = 300, std::uint64_t seed = 12345,
                              unsigned sources = kEverySource);

/// beta from the spins after the impact (`beta`) and `beta_from_impulse`
/// (the velocities' change and the spins before, thesis eq. A.4: angular
/// momentum about the contact point) are two estimates of one value that
/// share the inputs before the impact. Their least-variance combination
/// w beta + (1 - w) beta_from_impulse takes the weight
/// w = (V_i - C) / V_d from the draws (V_i beta_from_impulse's variance,
/// V_d their difference's, C = (V_s + V_i - V_d) / 2 their covariance), held
/// to [0, 1] (no extrapolation beyond either estimate). 1 where
/// beta_from_impulse has no spread or the difference has none (the two are
/// one estimate), or where a spread is unknown.
double betaSpinWeight(double var_spins, double var_impulse, double var_difference);
double betaSpinWeight(const ShotUncertainty& u);
/// The standard deviation of w beta + (1 - w) beta_from_impulse over the
/// draws (exact for their sample moments).
double combinedBetaSigma(double var_spins, double var_impulse, double var_difference, double w);
double combinedBetaSigma(const ShotUncertainty& u, double w);

/// One row of an error budget: e's, beta's and gamma's standard deviations
/// (gamma in degrees) when only `source` is drawn; beta's is that of the
/// combination with the whole propagation's weight (betaSpinWeight).
struct ErrorBudgetRow {
  UncertaintySource source{};
  const char* name = "";  ///< as the results JSON names it, e.g. "trajectory_fits"
  double e = 0, beta = 0, gamma_deg = 0;
};

/// What each group of inputs contributes to the stated sigmas: the
/// propagation again with one source at a time (from the same seed as
/// propagateShot), every source in kEverySource order. The sources are drawn
/// independently of each other, so their squares add up to about the whole
/// sigma's square (exactly only where the inverse is linear). Costs 8
/// propagations: asked for, not done on every shot (AnalysisSettings::
/// error_budget).
std::vector<ErrorBudgetRow> errorBudget(const ShotModel& model, int draws = 300,
                                        std::uint64_t seed = 12345, double beta_spin_weight = 1.0);

}  // namespace collide
