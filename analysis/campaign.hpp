#pragma once
// Fits over a campaign of shots of one material (docs/SPEC.md "Measuring a material";
// thesis chapter 5): Walton's friction mu and largest tangential restitution
// beta_0 from beta against x = -v_n/v_s (Fig. 5.9), the normal restitution e as a
// constant and as a function of the normal impact speed (Figs. 5.12, 5.13), and
// the model curves to draw over the measured points (Figs. 3.4, 5.9, 5.11).
//
// Angles. SPEC's incidence angle gamma lies in [pi/2, pi] (cot gamma = v_n/v_s).
// The thesis quotes angles as the acute angle psi = pi - gamma between the
// approach direction and the line of centres (tan psi = -v_s/v_n; 0 = head-on,
// 90 degrees = grazing), e.g. "gamma_0 ~ 40 degrees". This header speaks psi and
// its two trigonometric abscissae:
//   x = -v_n/v_s = cot psi  (beta plot, Fig. 5.9; large x = near head-on)
//   t = -v_s/v_n = tan psi  (tangent-form and f plots, Figs. 3.4, 5.11)
//
// Every function is pure and may be called from any thread. User errors come back
// as Result errors whose message names the shot and field and says what to do.
#include <Eigen/Dense>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "analysis/types.hpp"

namespace collide {

/// One analysed collision as the campaign fits see it, each quantity with its
/// standard uncertainty (sigma). The incidence angle is not stored: it is
/// -v_n/v_s by definition, and a second copy could disagree.
struct CampaignShot {
  double v_n_m_s = 0;        ///< normal contact velocity before impact, v_c . n; < 0 on approach
  double v_n_sigma_m_s = 0;  ///< its standard uncertainty, >= 0
  double v_s_m_s = 0;        ///< tangential contact speed before impact |v_s|, >= 0
  double v_s_sigma_m_s = 0;  ///< its standard uncertainty, >= 0
  double e = 0;              ///< normal restitution -v_n'/v_n
  double e_sigma = 0;        ///< > 0
  double beta = 0;           ///< tangential restitution, v_s' = -beta v_s; unused when v_s = 0
  double beta_sigma = 0;     ///< > 0
  double f = 0;              ///< impulse ratio |dP_t|/|dP_n|; carried for plots, not fitted
  double f_sigma = 0;        ///< >= 0

  /// x = -v_n/v_s = cot psi, dimensionless; +inf for a head-on shot (v_s = 0).
  double cotIncidence() const { return -v_n_m_s / v_s_m_s; }
  /// Standard uncertainty of x, propagating v_n and v_s as uncorrelated: both
  /// are projections of one contact velocity whose error is isotropic in the
  /// image plane, so its normal and tangential parts are independent.
  double cotIncidenceSigma() const;
  /// t = -v_s/v_n = tan psi, dimensionless; 0 head-on.
  double tanIncidence() const { return -v_s_m_s / v_n_m_s; }
  /// psi in radians, [0, pi/2]: 0 head-on, pi/2 grazing. SPEC's gamma = pi - psi.
  double incidenceAngle_rad() const;
};

/// A fitted number and its standard uncertainty, in the units of the field
/// that holds it.
struct FittedValue {
  double value = 0;
  double sigma = 0;
};

enum class CollisionRegime { Sliding, Rolling };

/// The loss minimised over the shots' normalised residuals z (residual over
/// its effective sigma). Least squares lets one wrong shot (a beta of -2.68
/// with a small sigma) pull the whole fit; the robust losses are iteratively
/// reweighted least squares with weights u(z / s), s = max(1, 1.4826
/// median |z|) (a robust scale: a campaign scattering beyond its stated sigmas
/// does not down-weight every shot):
enum class RobustLoss {
  LeastSquares,  ///< u = 1
  Huber,         ///< u = min(1, c / |z|), c = 1.345 (95 % efficient for Gaussian errors)
  Cauchy,        ///< u = 1 / (1 + (z / c)^2), c = 2.385
};

struct RobustOptions {
  RobustLoss loss = RobustLoss::LeastSquares;
  double tuning = 0;  ///< c; 0: the loss's default above
};

/// Robust weight u of a normalised residual (already divided by the scale).
double robustWeight(double z, const RobustOptions& options);

/// "least squares", "Huber", "Cauchy".
std::string robustLossName(RobustLoss loss);

struct FrictionOptions {
  /// K = 4 I / (m sigma^2); 2/5 for homogeneous spheres.
  double inertia_factor_K = 0.4;
  /// Each line of the model (sliding slope, rolling plateau) needs at least this
  /// many shots: with fewer, one "fitted" point can sit on its own line exactly
  /// and the partition, not the data, decides the result.
  int min_shots_per_regime = 3;
  /// Loss of the fit (and of fitCampaign's mean e). fitFriction defaults to
  /// least squares; fitCampaign to Huber (campaignOptions()).
  RobustOptions robust;
};

/// beta(x) = min(beta_0, -1 + s x) with s = (1 + 1/K)(1 + e) mu, fitted to a
/// campaign. Uncertainties are 1 sigma, from the linearised covariance scaled by
/// scale_factor (see below).
struct FrictionFit {
  FittedValue slope;             ///< s = (1 + 1/K)(1 + e) mu, slope of the sliding line
  FittedValue beta0;             ///< plateau of the rolling regime
  FittedValue mu;                ///< s / ((1 + 1/K)(1 + e)); sigma includes e's
  FittedValue e;                 ///< the restitution used to turn s into mu (the input)
  FittedValue switch_cot;        ///< x0 = (1 + beta0)/s: sliding below, rolling above
  FittedValue switch_angle_deg;  ///< psi0 = atan(1/x0) in degrees (thesis gamma_0)
  Eigen::Matrix2d slope_beta0_covariance = Eigen::Matrix2d::Zero();  ///< of (s, beta0)
  double chi2 = 0;  ///< sum of squared normalised residuals (effective variances)
  int dof = 0;      ///< shots - 2
  /// max(1, sqrt(chi2/dof)): uncertainties are inflated by it when the scatter
  /// exceeds what the shots' own sigmas explain (Birge ratio, PDG convention).
  double scale_factor = 1;
  double inertia_factor_K = 0.4;
  std::vector<CollisionRegime> regime;  ///< per input shot, in input order
  int sliding_count = 0;
  int rolling_count = 0;
  /// Per input shot, the robust loss's final weight u in [0, 1] (1: full
  /// weight, always so for least squares); chi2 and the covariance use it.
  std::vector<double> robust_weight;

  /// (e, mu, beta0) at their fitted values, for the curve functions below.
  Material material() const { return Material{e.value, mu.value, beta0.value}; }
};

/// Fits s and beta_0 jointly by weighted least squares of the piecewise model;
/// the switch between the regimes is found by the fit (the exact optimum over
/// every partition of the shots into sliding and rolling), not set by hand. The
/// error in x enters through effective variances sigma_beta^2 + (dbeta/dx)^2
/// sigma_x^2. mu then follows from s and `e` (e.g. fitRestitutionMean's), with
/// e's uncertainty propagated; e is taken as independent of the beta data.
///
/// shots: v_n < 0, v_s > 0 (head-on shots have no beta), finite beta,
/// beta_sigma > 0, v_n_sigma and v_s_sigma >= 0. e: finite value > -1, sigma >= 0.
/// Errors: too few shots; a bad field (named, with the shot's index); too few
/// shots on one side of the switch (says which side and which shots to add);
/// beta not rising with x at all.
Result<FrictionFit> fitFriction(std::span<const CampaignShot> shots, FittedValue e,
                                const FrictionOptions& options = {});

/// e as one number for the whole campaign.
struct RestitutionMean {
  FittedValue e;            ///< weighted mean (weights 1/e_sigma^2); sigma scaled by scale_factor
  double scatter = 0;       ///< sample standard deviation of the shots' e values
  double chi2 = 0;          ///< about the mean
  int dof = 0;              ///< shots - 1
  double scale_factor = 1;  ///< max(1, sqrt(chi2/dof))
  int count = 0;
  std::vector<double> robust_weight;  ///< per shot, as FrictionFit's
};

/// Needs >= 2 shots with finite e, e_sigma > 0 (v_s and beta are not read).
/// With a robust loss the mean is reweighted until the weights settle; chi2,
/// the Birge ratio and sigma then use the final weights.
Result<RestitutionMean> fitRestitutionMean(std::span<const CampaignShot> shots,
                                           const RobustOptions& robust = {});

/// Laws for e against the normal impact speed v = |v_n| in m/s (parameters are
/// for v in m/s):
enum class RestitutionLaw {
  Constant,      ///< e = c
  PowerLaw,      ///< e = a v^(-b): free power law; b = 1/4 is the plastic law
                 ///< uncapped, and the thesis found b ~ 0.12 for Teflon ("half
                 ///< that predicted by Johnson"), so b is reported on that scale
  ViscoElastic,  ///< 1 - e = c v^(1/5) (Kuwabara and Kono)
  Plastic,       ///< e = min(1, c v^(-1/4)) (Johnson; e = 1 below the yield speed c^4)
};

/// Short name ("constant", "power law", "visco-elastic", "plastic").
std::string restitutionLawName(RestitutionLaw law);

struct RestitutionLawFit {
  RestitutionLaw law = RestitutionLaw::Constant;
  std::string formula;                       ///< e.g. "e = a |v_n|^(-b)"
  std::vector<std::string> parameter_names;  ///< e.g. {"a", "b"}
  std::vector<FittedValue> parameters;       ///< same order; sigmas scaled by scale_factor
  Eigen::MatrixXd covariance;                ///< of parameters, scaled
  double chi2 = 0;  ///< with effective variances e_sigma^2 + (de/dv)^2 v_n_sigma^2
  int dof = 0;
  double scale_factor = 1;
  double minus2_log_likelihood = 0;  ///< Gaussian, including the ln(2 pi sigma^2) terms
  double aic = 0;                    ///< -2 ln L + 2 k
  double bic = 0;                    ///< -2 ln L + k ln n: the criterion used to choose
  double delta_bic = 0;              ///< bic minus the best law's bic (0 for the winner)

  /// The fitted law at normal impact speed |v_n| (m/s, >= 0).
  double restitutionAt(double normal_speed_m_s) const;
};

/// Strength of the preference for the winning law over the runner-up, on Kass
/// and Raftery's (1995) scale for delta BIC (~ 2 ln Bayes factor).
enum class Evidence {
  BareMention,  ///< delta BIC < 2: the data do not tell the laws apart
  Positive,     ///< 2..6
  Strong,       ///< 6..10
  VeryStrong,   ///< > 10
};

std::string evidenceName(Evidence evidence);

struct RestitutionLaws {
  std::vector<RestitutionLawFit> fits;                  ///< all four laws, in enum order
  RestitutionLaw preferred = RestitutionLaw::Constant;  ///< lowest BIC
  double bic_margin = 0;  ///< runner-up's BIC minus the winner's, >= 0
  Evidence evidence = Evidence::BareMention;

  const RestitutionLawFit& fit(RestitutionLaw law) const { return fits[int(law)]; }
};

/// Fits every law by weighted least squares. The error in |v_n| enters through
/// effective variances (iterated to convergence).
/// Needs >= 4 shots with v_n < 0, finite e, e_sigma > 0, v_n_sigma >= 0, and at
/// least two different |v_n| (a speed law needs a range of speeds).
Result<RestitutionLaws> fitRestitutionLaws(std::span<const CampaignShot> shots);

/// Everything a campaign report shows. mu uses the campaign's mean e.
/// Head-on shots (v_s = 0) count for e only: they have no beta. friction.regime
/// still has one entry per input shot and lists them as Rolling (x = +inf lies
/// beyond any switch), but they are not in the fit nor in its counts.
/// `laws` holds an error instead of fits when the shots do not span a range of
/// speeds (an angle campaign at one pressure is still a valid campaign).
struct CampaignFit {
  RestitutionMean restitution;
  /// Empty, with the reason, when the shots cannot give mu and beta_0 (too few
  /// oblique shots with measured spins, e.g. a campaign of bare backlit
  /// silhouettes): e and its laws are still fitted.
  Result<FrictionFit> friction;
  Result<RestitutionLaws> laws;
};

/// The campaign fits' defaults: FrictionOptions with the Huber loss.
FrictionOptions campaignOptions();

/// e's mean and the friction fit use options.robust (Huber by default); the
/// laws of e(|v_n|) are least-squares fits. Head-on shots (v_s = 0) and shots
/// whose beta is NaN (spins not measured) count for e only. Fails only when e
/// cannot be fitted; a friction fit the shots cannot give is an error inside
/// (friction.error() says why and what to add).
/// friction.robust_weight and restitution.robust_weight say which shots the
/// loss set aside.
Result<CampaignFit> fitCampaign(std::span<const CampaignShot> shots,
                                const FrictionOptions& options = campaignOptions());

/// Bootstrap cross-check of the covariance uncertainties: resample the shots
/// with replacement, refit e (mean) and the friction model, and take the
/// standard deviations. Resamples whose fit fails (e.g. too few rolling shots
/// drawn) are counted and left out.
struct FrictionBootstrap {
  double slope_sigma = 0;
  double beta0_sigma = 0;
  double mu_sigma = 0;
  double e_sigma = 0;
  double switch_cot_sigma = 0;
  int resamples_used = 0;
  int resamples_failed = 0;
};

/// resamples >= 10. Deterministic for a given seed. Errors: as fitFriction on
/// the full set, or when fewer than half the resamples could be fitted.
Result<FrictionBootstrap> bootstrapFriction(std::span<const CampaignShot> shots, int resamples,
                                            std::uint64_t seed,
                                            const FrictionOptions& options = {});

// Model curves for plotting, from fitted (or any) material parameters.
// K is the inertia factor (2/5 for homogeneous spheres).

/// Walton's beta at x = -v_n/v_s >= 0: min(beta0, -1 + (1 + 1/K)(1 + e) mu x).
/// x = +inf gives beta0.
double campaignBetaCurve(double cot_incidence, const Material& m, double inertia_factor_K = 0.4);

/// Walton's impulse ratio f at t = -v_s/v_n >= 0:
/// min(mu, (1 + beta0) t / ((1 + 1/K)(1 + e))) (rolling near head-on, then mu).
double campaignImpulseRatioCurve(double tan_incidence, const Material& m,
                                 double inertia_factor_K = 0.4);

/// The two straight lines of the tangent-form plot, y = -v_s'/v_n against
/// t = -v_s/v_n (thesis Fig. 3.4), where v_s' = -beta v_s is signed along v_s:
/// sliding y = t - s, rolling y = -beta0 t, meeting at t0.
struct TangentFormLines {
  double sliding_intercept = 0;  ///< -s = -(1 + 1/K)(1 + e) mu (the sliding slope is 1)
  double rolling_slope = 0;      ///< -beta0 (the rolling line passes through the origin)
  double switch_tan = 0;         ///< t0 = s / (1 + beta0) = tan psi0
};

TangentFormLines campaignTangentFormLines(const Material& m, double inertia_factor_K = 0.4);

/// The model's y = -v_s'/v_n at t >= 0: max(-beta0 t, t - s) (= -beta(1/t) t).
double campaignTangentFormCurve(double tan_incidence, const Material& m,
                                double inertia_factor_K = 0.4);

}  // namespace collide
