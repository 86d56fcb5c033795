#pragma once
// Weighted linear least squares: minimise sum_i w_i (y_i - A_i . c)^2.
// The one solver behind the trajectory fits, the launch-calibration refit and
// any other linear model in analysis/.
#include <Eigen/Dense>
#include <string>
#include <utility>

#include "analysis/result.hpp"

namespace collide {

/// What the weights mean, which decides how the covariance is scaled.
enum class WeightKind {
  /// Only ratios matter (w_i proportional to 1/sigma_i^2, scale unknown). The
  /// noise scale is estimated from the residuals: covariance = (A^T W A)^-1 * chi^2/dof.
  kRelative,
  /// w_i = 1/sigma_i^2 with sigma_i the known standard uncertainty of y_i.
  /// Covariance = (A^T W A)^-1, not rescaled; chi^2/dof then tests the sigmas.
  kInverseVariance,
};

/// Per-observation weights and their meaning.
struct Weights {
  Eigen::VectorXd values;  ///< empty: every observation weight 1
  WeightKind kind = WeightKind::kRelative;

  /// Equal weights, noise scale estimated from the residuals.
  static Weights equal() { return {}; }
  /// Relative weights (>= 0; a zero weight drops the observation).
  static Weights relative(Eigen::VectorXd w) { return {std::move(w), WeightKind::kRelative}; }
  /// Known standard uncertainties sigma_i (finite, > 0, same unit as y): w_i = 1/sigma_i^2.
  /// A sigma that is not finite and positive makes the fit fail with a message.
  static Weights fromSigmas(const Eigen::VectorXd& sigma);
};

struct LinearFit {
  Eigen::VectorXd coefficients;  ///< c, one per column of A
  /// Covariance of c, scaled according to WeightKind. With kRelative weights and
  /// dof == 0 the noise scale is unknown and every entry is NaN.
  Eigen::MatrixXd covariance;
  Eigen::VectorXd residuals;  ///< y_i - A_i . c, unweighted, one per observation
  double chi2 = 0.0;          ///< sum_i w_i residual_i^2
  int dof = 0;                ///< observations with w_i > 0, minus the number of coefficients
  WeightKind kind = WeightKind::kRelative;
  Eigen::VectorXd weights;  ///< the weights actually used (all 1 if none were given)

  /// chi^2 / dof; NaN when dof == 0.
  double reducedChi2() const;
  /// sqrt(mean residual^2) over observations with w_i > 0, unweighted, unit of y.
  double residualRms() const;
  /// Standard uncertainty of coefficient k: sqrt(covariance(k, k)).
  double sigma(int k) const;
};

/// Solves min_c sum_i w_i (y_i - A_i . c)^2 (A is N x P, y has N entries).
/// Columns are equilibrated and the system solved by SVD, so widely different
/// column scales (1, t, t^2 with t in milliseconds) do not cost precision.
/// Errors (message names `what`, the caller's name for the data):
///  - A and y (or the weights) of different lengths;
///  - a non-finite entry in A, y or the weights, or a negative weight;
///  - fewer observations with positive weight than coefficients;
///  - a rank-deficient design (e.g. all abscissae equal).
Result<LinearFit> weightedLeastSquares(const Eigen::MatrixXd& design, const Eigen::VectorXd& y,
                                       const Weights& weights, const std::string& what = "data");

}  // namespace collide
