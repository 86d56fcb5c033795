#include "analysis/least_squares.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace collide {

Weights Weights::fromSigmas(const Eigen::VectorXd& sigma) {
  Eigen::VectorXd w(sigma.size());
  for (Eigen::Index i = 0; i < sigma.size(); ++i) {
    // NaN rather than a silently valid weight: the solver rejects it with a message.
    w[i] = std::isfinite(sigma[i]) && sigma[i] > 0 ? 1.0 / (sigma[i] * sigma[i])
                                                   : std::numeric_limits<double>::quiet_NaN();
  }
  return {std::move(w), WeightKind::kInverseVariance};
}

double LinearFit::reducedChi2() const {
  return dof > 0 ? chi2 / dof : std::numeric_limits<double>::quiet_NaN();
}

double LinearFit::residualRms() const {
  double sum = 0.0;
  int n = 0;
  for (Eigen::Index i = 0; i < residuals.size(); ++i) {
    if (weights.size() == residuals.size() && weights[i] <= 0) continue;
    sum += residuals[i] * residuals[i];
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

double LinearFit::sigma(int k) const {
  return std::sqrt(covariance(k, k));
}

Result<LinearFit> weightedLeastSquares(const Eigen::MatrixXd& design, const Eigen::VectorXd& y,
                                       const Weights& weights, const std::string& what) {
  const Eigen::Index n = design.rows();
  const Eigen::Index p = design.cols();
  if (y.size() != n)
    return fail(what + ": " + std::to_string(y.size()) + " values for " + std::to_string(n) +
                " rows of the model; give one value per observation");
  Eigen::VectorXd w = weights.values.size() == 0 ? Eigen::VectorXd::Ones(n) : weights.values;
  if (w.size() != n)
    return fail(what + ": " + std::to_string(w.size()) + " weights for " + std::to_string(n) +
                " observations; give one weight (or sigma) per observation");
  if (!design.allFinite() || !y.allFinite())
    return fail(what + ": contains a non-finite value (NaN or infinity); drop or fix that point");
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!std::isfinite(w[i]) || w[i] < 0)
      return fail(what + ": weight of point " + std::to_string(i) + " is " + std::to_string(w[i]) +
                  "; weights must be finite and >= 0 (sigmas finite and > 0)");
  }
  const int used = int((w.array() > 0).count());
  if (used < p)
    return fail(what + ": " + std::to_string(used) + " usable points for " + std::to_string(p) +
                " coefficients; give at least " + std::to_string(p) + " points");

  // Row scaling by sqrt(w) turns the weighted problem into an ordinary one;
  // column equilibration keeps the singular values (and the rank test) honest
  // when columns differ by orders of magnitude.
  const Eigen::VectorXd sw = w.array().sqrt();
  Eigen::MatrixXd a = sw.asDiagonal() * design;
  Eigen::VectorXd col_scale(p);
  for (Eigen::Index j = 0; j < p; ++j) {
    const double norm = a.col(j).norm();
    col_scale[j] = norm > 0 ? 1.0 / norm : 1.0;
  }
  a = a * col_scale.asDiagonal();
  const Eigen::VectorXd b = sw.asDiagonal() * y;

  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  const double tol = std::numeric_limits<double>::epsilon() * double(std::max(n, p)) * 16.0;
  if (p > 0 && (s[p - 1] <= tol * s[0] || s[0] == 0.0))
    return fail(what + ": the points do not determine all " + std::to_string(p) +
                " coefficients (the model is degenerate for these abscissae, e.g. all equal); "
                "spread the points out");

  const Eigen::VectorXd s_inv = s.array().inverse();
  const Eigen::MatrixXd v_scaled = col_scale.asDiagonal() * svd.matrixV();
  LinearFit fit;
  fit.kind = weights.kind;
  fit.weights = w;
  fit.coefficients = v_scaled * (s_inv.asDiagonal() * (svd.matrixU().transpose() * b));
  fit.covariance = v_scaled * s_inv.array().square().matrix().asDiagonal() * v_scaled.transpose();
  fit.residuals = y - design * fit.coefficients;
  fit.chi2 = (w.array() * fit.residuals.array().square()).sum();
  fit.dof = used - int(p);
  if (weights.kind == WeightKind::kRelative) {
    if (fit.dof > 0)
      fit.covariance *= fit.chi2 / fit.dof;
    else
      fit.covariance.setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return fit;
}

}  // namespace collide
