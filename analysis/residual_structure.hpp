#pragma once
// Whether a fit's residuals have order in them, or are scatter (used by the
// shot analysis' `large_residuals` flag, vision/shot_analysis.hpp).
//
// Residuals that are independent from one observation to the next (detector
// noise, a sphere's dots crossing its blurred outline) only widen the fit's
// uncertainty, which the fit's chi^2 already scales. Residuals with order
// mean the model or the data are wrong: a smooth run of one sign (a track
// that bends, a contact inside the segment, a mismatched sphere) or an
// alternating pattern (a camera shaking every other frame).
//
// Two tests on the residuals in observation order, over the observations
// with w_i > 0 (samples taken at even intervals, as a track's frames are):
//  - order from one sample to the next: the lag-1 autocorrelation of the
//    weighted residuals e_i = sqrt(w_i) r_i,
//      r1 = sum_i e_i e_{i+1} / sum_i e_i^2,
//    about -1/n with a standard deviation of about 1/sqrt(n) for n
//    independent errors (Box and Jenkins; Durbin-Watson is about 2 (1 - r1)).
//    An alternating offset drives it towards -1, a smooth misfit towards +1;
//  - a smooth trend: the residuals r_i themselves (unweighted: a detector's
//    stated sigmas can be far from the real scatter, and weights that wrong
//    made it fire 7-12 times too often) fitted with a quadratic and with a
//    cubic in the sample index, F = (chi2 quadratic - chi2 cubic) /
//    (chi2 cubic / (n - 4)): Student's t^2 with n - 4 degrees of freedom for
//    independent errors of any scale. This one sees a track that bends away
//    from a parabola, which r1 alone at n = 16 does not (r1 of a pure cubic
//    misfit is only about 0.56 there).
// Both are independent of the residuals' scale: they ask about order, not size.
#include "analysis/least_squares.hpp"
#include "analysis/trajectory.hpp"

namespace collide {

/// The sums behind r1 for one fit: of e_i e_(i+1) and of e_i^2 over its
/// weighted residuals in observation order, and how many there are. Summed
/// over several fits of the same samples (a track's x and y) they pool them.
struct Lag1Sums {
  double products = 0, squares = 0;
  int n = 0;
};
Lag1Sums lag1Sums(const LinearFit& fit);

/// r1 of `fit`'s weighted residuals, in observation order; NaN when the fit
/// has fewer than 3 degrees of freedom (its residuals say nothing about
/// order) or all residuals are zero.
double residualLag1Correlation(const LinearFit& fit);

/// F of a cubic trend in the residuals, unweighted (sample index as abscissa);
/// NaN with fewer than 6 observations of positive weight or residuals a cubic
/// fits exactly.
double residualTrendF(const LinearFit& fit);

/// Either test beyond its critical value at two-sided normal quantile `z`
/// (3.29: a 1 in 1000 chance each for independent errors): |r1 + 1/n| >
/// z / sqrt(n), or F > t^2 with t Student's quantile for n - 4 degrees of
/// freedom at the same probability. False when neither can be computed.
bool residualsStructured(const LinearFit& fit, double z = 3.29);

/// Variance inflation for a track whose residuals are correlated from frame
/// to frame: (1 + rho) / (1 - rho), rho the lag-1 autocorrelation of the
/// weighted residuals pooled over x and y, clamped to [0, 0.8] (Bartlett).
/// The fit's covariance assumes independent frames; neighbouring frames share
/// slowly changing detection errors (dots near the limb, blur, shading the
/// edge model misses), which move a velocity more than independent ones would.
double residualInflation(const TrajectoryFit& fit);

/// A slow wander of every sample about its true place, which a fit cannot
/// tell from its own curve (its residuals stay small): a stationary process of
/// RMS `rms` (unit of y), correlated between samples at times t_i, t_j as
/// exp(-(t_i - t_j)^2 / (2 time_s^2)). Returned: the standard deviation it
/// gives an estimate sum_i gain_i y_i, sqrt(gain' K gain) rms. `t` in
/// increasing order (pairs more than 8 time_s apart, whose correlation is
/// below 1e-13, are skipped). Zero for rms or time_s not > 0; NaN for t and
/// gain of different lengths.
double wanderSigma(const Eigen::VectorXd& t, const Eigen::VectorXd& gain, double rms,
                   double time_s);

/// The gains of a quadratic fit y = c0 + c1 tau + c2 tau^2 / 2 (tau = t -
/// t_ref) with weights w (0 leaves a sample out): c = G y, rows c0, c1, c2.
/// Empty with fewer than three samples of positive weight.
Eigen::Matrix<double, 3, Eigen::Dynamic> quadraticGains(const Eigen::VectorXd& t,
                                                        const Eigen::VectorXd& w, double t_ref);

}  // namespace collide
